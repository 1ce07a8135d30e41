"""The experiment grid of ``benchmarks.run`` and its incremental, resumable cell storage.

A **cell** is one ``train()`` call: (learner, reward, alpha, gamma) at fixed run settings.
An **experiment** is a named set of cells:

- ``main``: every learner x every reward at (alpha, gamma) — the paper's Table 3 and Figures 3-5;
- ``alpha_sweep``: the sweep learner x sweep reward at each alpha, gamma fixed — Figures 6-7;
- ``gamma_sweep``: the same at each gamma, alpha fixed.

A cell that belongs to several experiments (e.g. Q-learning/r4 at alpha = gamma = 0.3)
is trained once.  After each cell, its summary (the scalars and curves of
:func:`tableclean_suite.metrics.summarize`) is written to
``OUT/cells/<label>-<hash>.npz``, where ``hash`` is a digest of everything that determines
the cell (:func:`cell_config`).  A rerun loads the cells whose config matches instead of
retraining them, so an interrupted run resumes where it stopped and changing one flag only
retrains the cells it affects.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

import tableclean_suite
from tableclean_suite.learners import get_learner, train
from tableclean_suite.metrics import SUMMARY_SCALARS, summarize
from tableclean_suite.rewards import get_reward_pattern

#: Bump when the stored layout or the meaning of a stored field changes.
CELL_FORMAT_VERSION = 1

#: Curves stored per cell (all of ``summarize``'s curves).
CURVE_NAMES = ("success", "average_reward", "terminal", "episodes")


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
class Settings:
    """Everything shared by all cells of a run.

    ``transitions`` is a path (calibrated backend) and ``transitions_sha256`` its content
    digest; ``workers`` does not change the numbers, so it is not part of a cell's config.
    """

    runs: int
    iterations: int
    epsilon: float
    max_itr: int
    seed: int
    start: str = "fixed"
    ineffective: str = "ineffective"
    backend: str = "symbolic"
    transitions: str | None = None
    transitions_sha256: str | None = None
    threshold: float = 0.95
    plateau_fraction: float = 0.25
    workers: int | None = None


@dataclass(frozen=True)
class Membership:
    """A cell's place in one experiment (a row of Table 3)."""

    experiment: str
    cell: Cell


def build_grid(
    learners,
    rewards,
    alpha: float,
    gamma: float,
    sweep_learner: str,
    sweep_reward: str,
    alpha_sweep=(),
    gamma_sweep=(),
    sweeps: bool = True,
) -> list[Membership]:
    """The (experiment, cell) memberships of a run, in table order, without duplicates.

    The alpha sweep varies alpha at ``gamma``; the gamma sweep varies gamma at ``alpha``.
    Values are compared as floats, so ``0.3`` and ``0.30`` are the same cell.
    """
    alpha, gamma = float(alpha), float(gamma)
    grid = [Membership("main", Cell(l, r, alpha, gamma)) for l in learners for r in rewards]
    if sweeps:
        grid += [Membership("alpha_sweep", Cell(sweep_learner, sweep_reward, float(a), gamma)) for a in alpha_sweep]
        grid += [Membership("gamma_sweep", Cell(sweep_learner, sweep_reward, alpha, float(g))) for g in gamma_sweep]
    return list(dict.fromkeys(grid))


def unique_cells(grid: list[Membership]) -> list[Cell]:
    """The distinct cells of a grid, in first-appearance order (each is trained once)."""
    return list(dict.fromkeys(m.cell for m in grid))


def cell_config(cell: Cell, settings: Settings, model_repr: str) -> dict:
    """Everything that determines a cell's stored summary (JSON-serialisable).

    The reward pattern and learner are recorded by value (a re-registered user pattern
    with the same name but other values gets a new hash); the package version is
    included so that a new release of the learners retrains.
    """
    pattern = get_reward_pattern(cell.reward)
    learner = get_learner(cell.learner)
    reward_values = {k: getattr(pattern, k) for k in (
        "terminal", "relevant_clean", "irrelevant_clean", "routine", "improper",
        "ineffective", "looping_penalty", "looping_mode", "terminal_mode",
    )}
    return {
        "format_version": CELL_FORMAT_VERSION,
        "package_version": tableclean_suite.__version__,
        "learner": {"name": learner.name, "on_policy": learner.on_policy,
                    "td_target": getattr(learner.td_target, "__qualname__", repr(learner.td_target))},
        "reward": {"name": pattern.name, **reward_values},
        "alpha": cell.alpha,
        "gamma": cell.gamma,
        "runs": settings.runs,
        "iterations": settings.iterations,
        "epsilon": settings.epsilon,
        "max_itr": settings.max_itr,
        "seed": settings.seed,
        "model": model_repr,
        "backend": settings.backend,
        "transitions_sha256": settings.transitions_sha256,
        "threshold": settings.threshold,
        "plateau_fraction": settings.plateau_fraction,
    }


def config_hash(config: dict) -> str:
    """A short stable digest of a cell config (16 hex digits of SHA-256 over sorted JSON)."""
    text = json.dumps(config, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def file_sha256(path) -> str:
    """SHA-256 of a file's bytes (to tag cells trained on a calibrated transition table)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


class CellFileError(RuntimeError):
    """A stored cell that cannot be read; the message names the file and the way out."""


class CellStore:
    """Summaries of finished cells, one ``.npz`` per cell under ``root``.

    Each file holds the cell's config (JSON) with its hash, the scalars (JSON) and the
    curves (float64 arrays).  Files are written atomically (temporary file, then rename),
    so an interrupted run never leaves a half-written cell behind.
    """

    def __init__(self, root):
        self.root = Path(root)

    def path(self, cell: Cell, digest: str) -> Path:
        return self.root / f"{cell.label}-{digest}.npz"

    def load(self, cell: Cell, config: dict) -> dict | None:
        """The stored summary of ``cell`` under ``config``, or None if there is none.

        Raises:
            CellFileError: the file exists but is unreadable or inconsistent.
        """
        digest = config_hash(config)
        path = self.path(cell, digest)
        if not path.exists():
            return None
        try:
            with np.load(path, allow_pickle=False) as data:
                stored_config = json.loads(str(data["config"]))
                stored_hash = str(data["config_hash"])
                scalars = json.loads(str(data["scalars"]))
                curves = {name: np.array(data[name], dtype=np.float64) for name in CURVE_NAMES}
        except Exception as error:  # any read/parse failure means the file is damaged
            raise CellFileError(
                f"cannot read cell file {path} (damaged, or not a cell file: {type(error).__name__}: {error}). "
                "Delete it or rerun with --fresh to retrain all cells."
            ) from None
        problems = []
        if stored_hash != digest or config_hash(stored_config) != digest:
            problems.append("its config does not match its name")
        if set(scalars) != set(SUMMARY_SCALARS):
            problems.append("its scalars are incomplete")
        if any(c.shape != (config["iterations"],) for c in curves.values()):
            problems.append(f"its curves are not of length {config['iterations']}")
        if problems:
            raise CellFileError(
                f"cell file {path} is inconsistent ({'; '.join(problems)}). "
                "Delete it or rerun with --fresh to retrain all cells."
            )
        return {**scalars, **curves}

    def save(self, cell: Cell, config: dict, summary: dict) -> Path:
        """Write ``summary`` (scalars and curves of ``summarize``) for ``cell`` atomically."""
        digest = config_hash(config)
        path = self.path(cell, digest)
        self.root.mkdir(parents=True, exist_ok=True)
        scalars = {name: _plain(summary[name]) for name in SUMMARY_SCALARS}
        temporary = path.with_name(path.name + ".tmp")
        with open(temporary, "wb") as handle:
            np.savez(
                handle,
                config=np.array(json.dumps(config, sort_keys=True)),
                config_hash=np.array(digest),
                scalars=np.array(json.dumps(scalars)),
                **{name: np.asarray(summary[name], dtype=np.float64) for name in CURVE_NAMES},
            )
        os.replace(temporary, path)
        return path


def _plain(value):
    """A JSON-safe scalar (None for missing, NaN kept as NaN: json writes it as ``NaN``)."""
    if value is None:
        return None
    if isinstance(value, (np.integer, int)) and not isinstance(value, bool):
        return int(value)
    return float(value)


def train_cell(cell: Cell, settings: Settings, model, transitions=None) -> tuple[dict, float, float]:
    """Train one cell and summarise it; returns ``(summary, train_seconds, metrics_seconds)``.

    The :class:`TrainingResult` is discarded as soon as it is summarised (it is
    ``runs x iterations`` x 5 arrays, ~50 MB at the defaults).
    """
    started = time.perf_counter()
    result = train(
        learner=cell.learner, reward=cell.reward, runs=settings.runs, iterations=settings.iterations,
        alpha=cell.alpha, gamma=cell.gamma, epsilon=settings.epsilon, max_itr=settings.max_itr,
        seed=settings.seed, model=model, backend=settings.backend, transitions=transitions,
        workers=settings.workers,
    )
    trained = time.perf_counter()
    if "physics" in result.info:
        _report_physics(cell, result.info["physics"])
    summary = summarize(result, threshold=settings.threshold, plateau_fraction=settings.plateau_fraction)
    del result
    return summary, trained - started, time.perf_counter() - trained


def _report_physics(cell: Cell, stats: dict) -> None:
    """One line on stderr: how the skills fared while this cell trained in physics."""
    faults = ", ".join(f"{kind}: {n}" for kind, n in stats["fault_reasons"].items()) or "none"
    print(
        f"physics {cell.label}: {stats['steps']} learner steps, {stats['executions']} skill executions, "
        f"{stats['skill_failures']} skill failures, {stats['faults']} faults ({faults}), "
        f"{stats['restages']} restages, {stats['control_steps']} control steps, {stats['wall_time']:.1f} s in skills",
        file=sys.stderr,
    )


@dataclass
class GridRun:
    """What :func:`run_grid` did: summaries per cell, and how they were obtained."""

    summaries: dict
    resumed: int = 0
    trained: int = 0
    train_seconds: float = 0.0
    metrics_seconds: float = 0.0


def run_grid(
    grid: list[Membership],
    settings: Settings,
    model,
    store: CellStore,
    transitions=None,
    fresh: bool = False,
    progress: bool = True,
) -> GridRun:
    """Train (or load) every distinct cell of ``grid``; each trained cell is saved at once.

    Args:
        grid: memberships from :func:`build_grid`.
        settings: run-wide settings.
        model: the :class:`~tableclean_suite.task.TaskModel`.
        store: where summaries live.
        transitions: a loaded :class:`TransitionTable` for the calibrated backend.
        fresh: ignore stored cells (and overwrite them).
        progress: a tqdm bar over cells on stderr.

    Raises:
        CellFileError: a stored cell matching the config is unreadable (unless ``fresh``).
    """
    from tqdm.auto import tqdm

    cells = unique_cells(grid)
    outcome = GridRun(summaries={})
    bar = tqdm(cells, desc="cells", unit="cell", disable=not progress, leave=False)
    for cell in bar:
        bar.set_postfix_str(cell.label)
        config = cell_config(cell, settings, repr(model))
        summary = None if fresh else store.load(cell, config)
        if summary is not None:
            outcome.resumed += 1
        else:
            summary, train_s, metrics_s = train_cell(cell, settings, model, transitions)
            store.save(cell, config, summary)
            outcome.trained += 1
            outcome.train_seconds += train_s
            outcome.metrics_seconds += metrics_s
        outcome.summaries[cell] = summary
    bar.close()
    return outcome


def cell_records(grid: list[Membership], summaries: dict) -> tuple[list[dict], list[dict]]:
    """Cell records (keys + scalars) and curve sets, one per membership, for :mod:`benchmarks.tables`."""
    records, curves = [], []
    for member in grid:
        summary = summaries[member.cell]
        record = {"cell_id": member.cell.label, **asdict(member.cell), "experiment": member.experiment}
        record.update({name: summary[name] for name in SUMMARY_SCALARS})
        records.append(record)
        curves.append({name: summary[name] for name in CURVE_NAMES})
    return records, curves
