"""The experiment grid of ``benchmarks.run`` and its resumable cell storage.

A **cell** is one trained configuration (learner, reward, alpha, gamma) of a `RunConfig`; an
**experiment** a named set of cells: ``main`` (learners x rewards: Table 3, Figures 3-5),
``alpha_sweep`` / ``gamma_sweep`` (Figures 6-7) and ``literature`` (Cruz et al.'s methods: Table 4).
A cell is trained once ([train_cell][tableclean_suite.bench.experiments.train_cell]) and stored in
``OUT/cells/<label>-<hash>.npz``, ``hash`` digesting what determines its numbers
([cell_config][tableclean_suite.bench.experiments.cell_config]): a rerun loads the cells it can.
"""

from __future__ import annotations

import hashlib
import json
import sys
import time
from dataclasses import asdict, astuple, dataclass, field, fields, replace
from functools import cached_property
from pathlib import Path

import numpy as np

import tableclean_suite
from tableclean_suite import analysis, metrics, resources, settling
from tableclean_suite.learners.memory import learner_training_memory
from tableclean_suite.backends import CHECKPOINT_Q, get_backend
from tableclean_suite.bench import digests, statistics
from tableclean_suite.bench.config import LITERATURE_LEARNERS, RunConfig
from tableclean_suite.bench.outputs import OutputError, atomic_write, describe_os_error, sha256_file
from tableclean_suite.bench.statistics import CellStatistics
from tableclean_suite.learners import code_digest, train
from tableclean_suite.curves import CurveSums
from tableclean_suite.learning_time import LearningTime
from tableclean_suite.metrics import CURVE_NAMES, SUMMARY_SCALARS, Plateaus, Summary, summarize
from tableclean_suite.physics_backend import merge_stats
from tableclean_suite.rewards import get_reward_pattern

#: Bump when the stored layout or the meaning of a stored field changes.
CELL_FORMAT_VERSION = 4

#: Memory budget of one training chunk's records and final Q-tables (bytes): about
#: ``CHUNK_BYTES / (T * RECORD_BYTES_PER_ITERATION + S * A * 8)`` runs (>= 1).
CHUNK_BYTES = 1_000_000_000
#: reward (float64) + outcome, state, action, episode end (int8 each).
RECORD_BYTES_PER_ITERATION = 8 + 4


@dataclass(frozen=True, order=True)
class Cell:
    """One trained configuration of the grid (hyperparameters that vary between cells)."""

    learner: str
    reward: str
    alpha: float
    gamma: float

    @property
    def label(self) -> str:
        """A readable file-name-safe label, e.g. ``q_learning-r4-a0.3-g0.3``."""
        return f"{self.learner}-{self.reward}-a{self.alpha:g}-g{self.gamma:g}"


@dataclass(frozen=True)
class Membership:
    """A cell's place in one experiment (a row of Table 3)."""

    experiment: str
    cell: Cell


def config_grid(config: RunConfig) -> list[Membership]:
    """The (experiment, cell) memberships of a run, in table order, without duplicates (values
    compared as floats); the alpha sweep is at ``gamma``, the gamma sweep at ``alpha``."""
    alpha, gamma = float(config.alpha), float(config.gamma)
    grid = [Membership("main", Cell(l, r, alpha, gamma)) for l in config.learners for r in config.rewards]
    if config.sweeps:
        learner, reward = config.sweep_learner, config.sweep_reward
        grid += [Membership("alpha_sweep", Cell(learner, reward, float(a), gamma)) for a in config.alpha_sweep]
        grid += [Membership("gamma_sweep", Cell(learner, reward, alpha, float(g))) for g in config.gamma_sweep]
    if config.literature:
        grid += [Membership("literature", Cell(l, config.literature_reward, alpha, gamma)) for l in LITERATURE_LEARNERS]
    return list(dict.fromkeys(grid))


def unique_cells(grid: list[Membership]) -> list[Cell]:
    """The distinct cells of a grid, in first-appearance order (each is trained once)."""
    return list(dict.fromkeys(m.cell for m in grid))


def key_digests(config: RunConfig, model, transitions=None) -> tuple[str, str, str | None]:
    """The code, task and calibrated-table (None without one) digests of a run's cell keys."""
    return (digests.code_digest(config.plugins), digests.task_digest(model),
            sha256_file(config.transitions) if transitions is not None else None)


def cell_config(run: CellRun, code: str, task: str, transitions_sha256: str | None = None) -> dict:
    """Everything that determines a cell's stored summary (JSON-serialisable): the cell ``run``
    ([`CellRun`][tableclean_suite.bench.experiments.CellRun]), the reward pattern by value,
    the learner's settings and code digest, the ``code`` and ``task`` digests
    ([digests][tableclean_suite.bench.digests]), the calibrated table file's ``transitions_sha256``
    and a simulated plan's label."""
    pattern, learner = get_reward_pattern(run.cell.reward), run.learner
    reward_values = {f.name: getattr(pattern, f.name) for f in fields(pattern) if f.compare}
    return {
        "format_version": CELL_FORMAT_VERSION,
        "package_version": tableclean_suite.__version__,
        "learner": {"name": learner.name, "on_policy": learner.on_policy,
                    "td_target": getattr(learner.td_target, "__qualname__", repr(learner.td_target)),
                    "settings": learner.settings(), "code_digest": code_digest(learner)},
        "reward": {**reward_values, "outcome_values": pattern.outcome_values().tolist()},
        "cell": asdict(run.cell),
        "settings": run.config.cell_settings(),
        "model": repr(run.model),
        "task_digest": task,
        "transitions_sha256": transitions_sha256,
        "code_digest": code,
        **({"analysis": run.plan.label} if run.plan.kind != "exact" else {}),
    }


def config_hash(config: dict) -> str:
    """A short stable digest of a cell config (16 hex digits of SHA-256 over sorted JSON)."""
    text = json.dumps(config, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class CellFileError(RuntimeError):
    """A stored cell that cannot be read; the message names the file and the way out."""


class CellStore:
    """Summaries of finished cells, one ``.npz`` per cell under ``root``: config (JSON) and its
    hash, scalars and statistics (JSON), curves (float64), written atomically."""

    def __init__(self, root):
        self.root = Path(root)

    def path(self, cell: Cell, digest: str) -> Path:
        return self.root / f"{cell.label}-{digest}.npz"

    def load(self, cell: Cell, config: dict) -> tuple[Summary, CellStatistics] | None:
        """The stored summary and statistics of ``cell`` under ``config``, or None if there are none.

        Raises:
            CellFileError: the file exists but is unreadable or inconsistent.
        """
        digest = config_hash(config)
        path = self.path(cell, digest)
        if not path.exists():
            return None
        try:
            with np.load(path, allow_pickle=False) as data:
                stored = {name: data[name] for name in data.files}
            stored_config, scalars, facts = (json.loads(str(stored[name])) for name in ("config", "scalars",
                                                                                        "statistics"))
            stored_hash = str(stored["config_hash"])
            curves = {name: stored[name].astype(np.float64) for name in CURVE_NAMES}
            bands = {name: (stored[f"band_{name}_low"], stored[f"band_{name}_high"])
                     for name in (*statistics.BAND_CURVES, statistics.NOT_LEARNED) if f"band_{name}_low" in stored}
            survival = stored["survival"].astype(np.float64) if "survival" in stored else None
            runs = {name: stored[f"run_{name}"].astype(np.float64) for name in statistics.RUN_SCORES
                    if f"run_{name}" in stored}
        except Exception as error:  # any read/parse failure means the file is damaged
            raise CellFileError(
                f"cannot read cell file {path} (damaged, or not a cell file: {type(error).__name__}: {error}). "
                "Delete it or rerun with --fresh to retrain all cells."
            ) from None
        problems = []
        if stored_hash != digest or config_hash(stored_config) != digest:
            problems.append("its config does not match its name")
        if (set(scalars) != set(SUMMARY_SCALARS) or not set(facts["intervals"]) <= set(SUMMARY_SCALARS)
                or len(facts.get("settling", ())) != SETTLING_FIELDS or "learning" not in facts):
            problems.append("its scalars are incomplete")
        iterations = config["settings"]["iterations"]
        if any(c.shape != (iterations,) for c in (*curves.values(), *(b for pair in bands.values() for b in pair))):
            problems.append(f"its curves are not of length {iterations}")
        if any(len(values) != config["settings"]["runs"] for values in runs.values()):
            problems.append("its per-run scores are not one per run")
        if problems:
            raise CellFileError(
                f"cell file {path} is inconsistent ({'; '.join(problems)}). "
                "Delete it or rerun with --fresh to retrain all cells."
            )
        learned = facts["learning"]
        cell_stats = CellStatistics(
            intervals={name: tuple(_number(v) for v in bounds) for name, bounds in facts["intervals"].items()},
            bands=bands, runs=runs, survival=survival,
            learning=None if learned is None else LearningTime(**{name: learned[name] if name in ("runs", "budget")
                                                                   else _number(learned[name]) for name in learned}),
            settling=settling.Settling(*(_number(v) for v in facts["settling"][:3]), int(facts["settling"][3])),
        )
        return Summary(**scalars, **curves), cell_stats

    def save(self, cell: Cell, config: dict, summary: Summary, cell_stats: CellStatistics) -> Path:
        """Write ``summary`` and ``cell_stats`` for ``cell`` atomically.

        Raises:
            tableclean_suite.bench.outputs.OutputError: the file cannot be written; no partial file is left.
        """
        digest = config_hash(config)
        path = self.path(cell, digest)
        try:
            self.root.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise OutputError(f"cannot create the cell folder {str(self.root)!r}: {describe_os_error(error)}") from None
        facts = {"intervals": cell_stats.intervals,
                 "learning": None if cell_stats.learning is None else cell_stats.learning.as_dict(),
                 "settling": list(astuple(cell_stats.settling))}
        texts = {"config": json.dumps(config, sort_keys=True), "config_hash": digest,
                 "scalars": _json(summary.scalars()), "statistics": _json(facts)}
        numbers = {**summary.curves(),
                   **{f"band_{name}_{side}": bound for name, bounds in cell_stats.bands.items()
                      for side, bound in zip(("low", "high"), bounds)},
                   **{f"run_{name}": values for name, values in cell_stats.runs.items()},
                   **({} if cell_stats.survival is None else {"survival": cell_stats.survival})}

        def write(temporary: Path) -> None:
            with open(temporary, "wb") as handle:
                np.savez(handle, **{name: np.array(text) for name, text in texts.items()},
                         **{name: np.asarray(values, dtype=np.float64) for name, values in numbers.items()})

        return atomic_write(path, write)


#: Stored settling: drift, low, high, checkpoint.
SETTLING_FIELDS = 4


def _number(value) -> float:
    """A stored bound: None (JSON null) reads as NaN."""
    return float("nan") if value is None else float(value)


def _json(values) -> str:
    """``values`` as JSON, numpy scalars as Python ones (NaN written as ``NaN``, read back by `_number`)."""
    return json.dumps(values, default=lambda value: value.item())


def chunk_runs(iterations: int, budget_bytes: int = CHUNK_BYTES, q_table_bytes: int = 0) -> int:
    """Runs per training chunk so that one chunk's records and final Q-tables (``q_table_bytes``
    per run: S x A float64) stay within ``budget_bytes`` (>= 1)."""
    return max(1, budget_bytes // (int(iterations) * RECORD_BYTES_PER_ITERATION + int(q_table_bytes)))


#: Estimated seconds of training above which [`run_grid`][tableclean_suite.bench.experiments.run_grid] says
#: so on stderr.
LONG_GRID_SECONDS = 600


@dataclass(frozen=True, eq=False)
class CellRun:
    """One cell of a run with what its training, analysis, key and resource check read.

    Attributes:
        cell: the cell; ``config``: the run's [`RunConfig`][tableclean_suite.bench.config.RunConfig];
            ``model``: the [`TaskModel`][tableclean_suite.task.model.TaskModel]; ``transitions``: the
            calibrated [`TransitionTable`][tableclean_suite.learners.transitions.TransitionTable], if any.
        runs_per_chunk: runs per ``train()`` call; None: [`chunk_runs`][tableclean_suite.bench.experiments.chunk_runs].
    """

    cell: Cell
    config: RunConfig
    model: object
    transitions: object = None
    runs_per_chunk: int | None = None

    @cached_property
    def learner(self):
        """The [`TabularLearner`][tableclean_suite.learners.rules.TabularLearner] as the run trains it."""
        return self.config.learner(self.cell.learner)

    @property
    def train(self) -> dict:
        """``train()``'s keyword arguments shared by the cell's chunks."""
        config = self.config
        return dict(iterations=config.iterations, epsilon=config.epsilon, max_itr=config.max_itr, seed=config.seed,
                    backend=config.backend, workers=config.workers)

    @cached_property
    def chunk(self) -> int:
        """Runs per ``train()`` call (at most ``runs``), so that a chunk's records and Q-tables fit `CHUNK_BYTES`."""
        q_bytes = int(self.model.n_states) * int(self.model.n_actions) * resources.WORD_BYTES
        return min(self.config.runs, self.runs_per_chunk or chunk_runs(self.config.iterations, q_table_bytes=q_bytes))

    @cached_property
    def checkpoint(self) -> int:
        """The settling checkpoint's iteration; 0 when the backend cannot keep the Q-tables of a prefix."""
        replays_prefix = getattr(get_backend(self.config.backend), "deterministic_prefix", False)
        return settling.checkpoint_iteration(self.config.iterations) if replays_prefix else 0

    @cached_property
    def plan(self) -> analysis.AnalysisPlan:
        """Exact or simulated asymptotes ([`analysis.cell_plan`][tableclean_suite.analysis.cell_plan]),
        costed for the runs analysed a chunk at a time, the checkpoint's analysis included."""
        successors = 1 if self.transitions is None else int(self.transitions.max_successors)
        return analysis.cell_plan(self.model, self.cell.reward, self.learner, self.config.runs, self.config.iterations,
                                  self.config.max_itr, self.config.analysis, runs_per_call=self.chunk,
                                  checkpoint=self.checkpoint > 0, max_successors=successors,
                                  episodes=self.config.analysis_episodes)

    @cached_property
    def memory(self) -> resources.MemoryEstimate:
        """What training one chunk allocates (records, Q-tables, the checkpoint's, working arrays)."""
        return learner_training_memory(self.model, self.learner, self.chunk,
                                       self.config.iterations, checkpoint=self.checkpoint > 0)


def check_grid_resources(runs) -> float:
    """Refuse (before training) cells that cannot fit in memory (one chunk's records and Q-tables
    plus the largest analysis call) or would run too long; returns the estimated seconds of training
    and analysis (0 without cells).  ``runs``: the [`CellRun`][tableclean_suite.bench.experiments.CellRun]s
    of one run (one model).

    Raises:
        tableclean_suite.resources.ResourceError: one line naming the estimate, what is available
            and the override (`tableclean_suite.resources.OVERRIDE_ENV`).
    """
    runs = list(runs)
    if not runs:
        return 0.0
    first, model = runs[0], runs[0].model
    memory = max((run.memory for run in runs), key=lambda estimate: estimate.total)
    memory += resources.MemoryEstimate({"asymptote analysis": max(run.plan.bytes for run in runs),
                                        "per-run scores": first.config.runs * len(statistics.RUN_SCORES)
                                        * resources.WORD_BYTES})
    what = (f"a cell of task {model.spec.name!r} ({model.n_states} states x {model.n_actions} actions, "
            f"{first.chunk} of {first.config.runs} runs x {first.config.iterations} iterations at a time)")
    resources.require_memory(memory, what)
    plans = [run.plan for run in runs]
    seconds = sum(plan.training_seconds + plan.seconds for plan in plans)
    resources.require_time(seconds, f"training {len(runs)} cell(s) of task {model.spec.name!r}", plans_text(plans))
    return seconds


def plans_text(plans) -> str:
    """The distinct [`describe`][tableclean_suite.analysis.AnalysisPlan.describe] texts of ``plans``, with
    how many cells each is, joined by ``; ``."""
    texts = [plan.describe() for plan in plans]
    return "; ".join(f"{text} ({texts.count(text)} cells)" if texts.count(text) > 1 else text
                     for text in dict.fromkeys(texts))


def _train_chunk(run: CellRun, first: int, iterations: int, keep: int = 0):
    """``train()`` of the chunk of runs starting at ``first``, for ``iterations``, keeping the Q-tables at ``keep``."""
    cell = run.cell
    return train(learner=run.learner, reward=cell.reward, runs=min(run.chunk, run.config.runs - first), first_run=first,
                 alpha=cell.alpha, gamma=cell.gamma, task=run.model, transitions=run.transitions,
                 **{**run.train, "iterations": iterations}, checkpoint=keep)


def train_cell(run: CellRun) -> tuple[Summary, CellStatistics, float, float]:
    """Train one cell chunk by chunk of runs (memory: one chunk's records; the numbers do not
    depend on the chunking) and summarise it with intervals: each run's final asymptotes
    ([`final_run_facts`][tableclean_suite.analysis.final_run_facts], exact or simulated by the plan)
    and its settling (the success asymptote at the checkpoint against the final one).

    Returns:
        ``(summary, statistics, train_seconds, metrics_seconds)``.
    """
    cell, model, checkpoint, config = run.cell, run.model, run.checkpoint, run.config
    sums = CurveSums.zeros(config.iterations)
    chain = analysis.analysis_chain(model, cell.reward, run.transitions, run.plan)
    per_run = {name: [] for name in metrics.PLATEAU_NAMES}
    errors = {name: [] for name in analysis.ESTIMATED_FACTS}
    learned_at, drifts = [], []
    train_seconds = metrics_seconds = 0.0
    physics_stats: dict = {}
    for first in range(0, config.runs, run.chunk):
        started = time.perf_counter()
        result = _train_chunk(run, first, config.iterations, checkpoint)
        train_seconds += time.perf_counter() - started
        started = time.perf_counter()
        if "physics" in result.info:
            physics_stats = merge_stats([physics_stats, result.info["physics"]])
        sums.add(result)
        learned = getattr(result, "learned_at", None)
        if learned is not None:
            learned_at.append(np.asarray(learned))
        final = analysis.final_run_facts(result, chain, config.max_itr, model)
        early = checkpoint_result(result, checkpoint) if checkpoint else None
        early_success = (None if early is None
                         else analysis.final_asymptotes(early, chain, config.max_itr, model).success)
        for name, values in per_run.items():
            values.append(final[name])
        for name, values in errors.items():
            if name + analysis.ERROR_SUFFIX in final:
                values.append(final[name + analysis.ERROR_SUFFIX])
        del result, early
        metrics_seconds += time.perf_counter() - started
        if checkpoint:
            if early_success is None:  # the backend kept no checkpoint Q-tables: train the prefix again
                started = time.perf_counter()
                early = _train_chunk(run, first, checkpoint)
                train_seconds += time.perf_counter() - started
                started = time.perf_counter()
                early_success = analysis.final_asymptotes(early, chain, config.max_itr, model).success
                del early
                metrics_seconds += time.perf_counter() - started
            drifts.append(settling.behaviour_drift(final["success"], early_success))
    if physics_stats:
        _report_physics(cell, physics_stats)
    started = time.perf_counter()
    per_run = {name: np.concatenate(values) for name, values in per_run.items()}
    plateaus = Plateaus(**{name: float(values.mean()) for name, values in per_run.items()})
    summary = summarize(sums, plateaus=plateaus, threshold=config.threshold, plateau_fraction=config.plateau_fraction,
                        support_fraction=config.support_fraction)
    recorded = len(learned_at) > 0 and sum(map(len, learned_at)) == config.runs
    cell_stats = statistics.cell_statistics(
        sums, per_run, statistics.bootstrap_rng(config.seed, cell.label), config.support_fraction,
        config.bootstrap_samples, config.confidence,
        learned_at=np.concatenate(learned_at) if recorded else None, budget=config.iterations,
        drift=np.concatenate(drifts) if checkpoint else None, checkpoint=checkpoint,
        monte_carlo={name: analysis.monte_carlo_error(np.concatenate(values)) for name, values in errors.items()
                     if values},
        average_reward_limits=get_reward_pattern(cell.reward).step_reward_bounds(),
    )
    return summary, cell_stats, train_seconds, metrics_seconds + time.perf_counter() - started


def checkpoint_result(result, checkpoint: int):
    """The [`TrainingResult`][tableclean_suite.learners.train.TrainingResult] of the same runs trained for
    ``checkpoint`` iterations, read off ``result`` (records' prefix views, ``info["checkpoint_q"]``);
    None when the backend kept no checkpoint Q-tables."""
    q = result.info.get(CHECKPOINT_Q)
    if q is None:
        return None
    prefix = {name: getattr(result, name)[:, :checkpoint]
              for name in ("rewards", "outcomes", "states", "actions", "episode_end")}
    return type(result)(**prefix, q=q, config={**result.config, "iterations": int(checkpoint)})


def _report_physics(cell: Cell, stats: dict) -> None:
    """One line on stderr: how the skills fared while this cell trained in physics."""
    faults = ", ".join(f"{kind}: {n}" for kind, n in stats["fault_reasons"].items()) or "none"
    print(
        f"physics {cell.label}: {stats['steps']} learner steps, {stats['executions']} skill executions, "
        f"{stats['skill_failures']} skill failures, {stats['faults']} faults ({faults}), "
        f"{stats['restages']} restages, {stats['control_steps']} control steps, {stats['wall_time']:.1f} s in skills",
        file=sys.stderr,
    )


#: Compiled threads and physics processes of a cell trained by an executor's worker (the workers share the cores).
WORKER_NUMBA_THREADS = WORKER_PHYSICS_PROCESSES = 1


class CellKeyMismatchError(RuntimeError):
    """A worker computes another cell key than the driver (other code, registrations or files there)."""


@dataclass(frozen=True)
class CellTask:
    """One cell to train in an executor's worker, as plain values (the worker builds the model);
    ``key_hash``: the driver's [`config_hash`][tableclean_suite.bench.experiments.config_hash] of its
    cell key, which the worker must compute too."""

    cell: Cell
    config: RunConfig
    key_hash: str

    @property
    def label(self) -> str:
        """The cell's label (how executor errors name the task)."""
        return self.cell.label


def train_cell_task(task: CellTask) -> tuple[Summary, CellStatistics, float, float]:
    """[`train_cell`][tableclean_suite.bench.experiments.train_cell] of ``task`` in the process that
    runs it, on `WORKER_NUMBA_THREADS` compiled threads.

    Raises:
        CellKeyMismatchError: the worker's cell key differs from the driver's.
    """
    import numba

    numba.set_num_threads(min(WORKER_NUMBA_THREADS, numba.config.NUMBA_NUM_THREADS))
    config = task.config
    if config.plugins:
        from tableclean_suite.bench.plugins import load_plugins

        load_plugins(config.plugins)  # what the driver registered, registered here too
    model = config.task_model()
    transitions = config.transition_table(model)
    run = CellRun(task.cell, config, model, transitions)
    digest = config_hash(cell_config(run, *key_digests(config, model, transitions)))
    if digest != task.key_hash:
        raise CellKeyMismatchError(
            f"cell {task.cell.label}: this worker's cell key {digest} differs from the driver's {task.key_hash}; "
            "install the same code (and the modules registering its learners, rewards and tasks) and the same "
            "transition table on every machine")
    return train_cell(run)


@dataclass
class GridRun:
    """What [`run_grid`][tableclean_suite.bench.experiments.run_grid] did: summaries, statistics and
    [analysis plans][tableclean_suite.analysis.AnalysisPlan] per cell, counts and seconds."""

    summaries: dict = field(default_factory=dict)
    statistics: dict = field(default_factory=dict)
    resumed: int = 0
    trained: int = 0
    train_seconds: float = 0.0
    metrics_seconds: float = 0.0
    plans: dict = field(default_factory=dict)

    def comparison_cells(self, cells) -> list[dict]:
        """``{"learner", "reward", "runs"}`` of each of ``cells``: the cells
        [`comparisons`][tableclean_suite.bench.statistics.comparisons] compares."""
        return [{"learner": c.learner, "reward": c.reward, "runs": self.statistics[c].runs} for c in cells]


def run_grid(grid: list[Membership], config: RunConfig, model, store: CellStore, transitions=None,
             executor=None) -> GridRun:
    """Load the stored cells of ``grid`` ([`config_grid`][tableclean_suite.bench.experiments.config_grid])
    from ``store`` (none with ``config.fresh``) and train the others, each saved at once.
    ``transitions``: the table of ``config.transitions``; ``executor``: an
    [`Executor`][tableclean_suite.executors.base.Executor] training one
    [`CellTask`][tableclean_suite.bench.experiments.CellTask] per cell (the same bits); None: this process.

    Raises:
        CellFileError: a stored cell matching the config is unreadable.
        tableclean_suite.resources.ResourceError: refused before training
            ([`check_grid_resources`][tableclean_suite.bench.experiments.check_grid_resources]).
        tableclean_suite.executors.TaskFailedError: a cell failed in the executor (named).
    """
    from tqdm.auto import tqdm

    outcome = GridRun()
    runs = {cell: CellRun(cell, config, model, transitions) for cell in unique_cells(grid)}
    every_cell_trains = config.fresh or not any(store.root.glob("*.npz"))
    if every_cell_trains:  # refused before the task's digest builds its table
        estimate = check_grid_resources(runs.values())
    run_digests = key_digests(config, model, transitions)
    keys = {cell: cell_config(run, *run_digests) for cell, run in runs.items()}
    outcome.plans = {cell: run.plan for cell, run in runs.items()}
    pending = []
    for cell, key in keys.items():
        stored = None if config.fresh else store.load(cell, key)
        if stored is None:
            pending.append(cell)
        else:
            outcome.summaries[cell], outcome.statistics[cell] = stored
            outcome.resumed += 1
    if not every_cell_trains:
        estimate = check_grid_resources(runs[cell] for cell in pending)
    if pending:
        model.require_learnable()  # before the progress bar: a task that cannot end is refused in one line
    simulated = [outcome.plans[cell] for cell in pending if outcome.plans[cell].kind == "simulated"]
    if estimate > LONG_GRID_SECONDS or simulated:
        print(f"note: training {len(pending)} cell(s) is estimated to take about {resources.format_seconds(estimate)}"
              + (f"; {plans_text(simulated)}" if simulated else ""), file=sys.stderr)
    bar = tqdm(total=len(keys), initial=outcome.resumed, desc="cells", unit="cell", disable=not config.progress,
               leave=False)

    def train_here():
        for cell in pending:
            bar.set_postfix_str(f"{outcome.resumed} resumed, training {cell.label}" if outcome.resumed else cell.label)
            yield train_cell(runs[cell])

    if executor is None or not pending:
        results = train_here()
    else:
        bar.set_postfix_str(f"{outcome.resumed} resumed, training {len(pending)} on {executor!r}")
        # each trained single-threaded (physics: its runs in one process)
        worker_config = replace(config, workers=WORKER_PHYSICS_PROCESSES) if config.backend == "physics" else config
        results = executor.map(train_cell_task, [CellTask(cell, worker_config, config_hash(keys[cell]))
                                                 for cell in pending])
    for cell, (summary, cell_stats, train_s, metrics_s) in zip(pending, results):
        store.save(cell, keys[cell], summary, cell_stats)
        outcome.summaries[cell] = summary
        outcome.statistics[cell] = cell_stats
        outcome.trained += 1
        outcome.train_seconds += train_s
        outcome.metrics_seconds += metrics_s
        bar.update(1)
    bar.close()
    return outcome


def cell_records(grid: list[Membership], summaries: dict, cell_statistics: dict | None = None,
                 settle_tolerance: float = settling.DEFAULT_SETTLE_TOLERANCE,
                 plans: dict | None = None) -> tuple[list[dict], list[dict]]:
    """One record (keys, scalars; with ``cell_statistics``: ``_low``/``_high`` bounds, the learning
    time columns, ``behaviour_drift`` (+ bounds; NaN when not measured), ``checkpoint_iteration``,
    ``settled`` (drift <= ``settle_tolerance``)) and one curve set (with bands) per membership, for
    [`tables`][tableclean_suite.bench.tables]; with ``plans``, ``asymptotes`` holds each plan's label."""
    records, curves = [], []
    for member in grid:
        summary = summaries[member.cell]
        record = {"cell_id": member.cell.label, **asdict(member.cell), "experiment": member.experiment}
        record.update(summary.scalars())
        if plans is not None:
            record[statistics.ASYMPTOTES] = plans[member.cell].label
        curve_set = dict(summary.curves())
        stats = (cell_statistics or {}).get(member.cell)
        if stats is not None:
            for name, (low, high) in stats.intervals.items():
                record[f"{name}_low"], record[f"{name}_high"] = low, high
            record.update(statistics.learning_time_record(stats.learning))
            settled = stats.settling
            record.update(behaviour_drift=settled.drift, behaviour_drift_low=settled.low,
                          behaviour_drift_high=settled.high,
                          checkpoint_iteration=settled.checkpoint or None,  # None: not measured (e.g. physics)
                          settled=settled.settled(settle_tolerance))
            if stats.survival is not None:
                curve_set[statistics.NOT_LEARNED] = stats.survival
            for name, (low, high) in stats.bands.items():
                curve_set[f"{name}_low"], curve_set[f"{name}_high"] = low, high
        records.append(record)
        curves.append(curve_set)
    return records, curves
