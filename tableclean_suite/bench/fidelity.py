"""Fidelity of the skills: does physics do what the task model says, from every reachable state?

    tableclean-bench fidelity [--task SPEC] [--robots ROBOT] [--trials N] [--out DIR] [--seed S] [--fresh]
                                  [--randomize]

One *round* executes every action of the spec (``--task``, default ``paper``) once from every
reachable non-terminal state (paper: 18 states x 4 actions = 72 trials;
``three_segments_two_objects``: 315 x 4 = 1260):

- Each all-unclean start layout (``N**M * N``: the paper's four) is reset with fresh placement
  noise (a seed per round and layout), and the reachable states are visited depth-first by executing actions in
  physics: a state is *reached* once, its scene is snapshotted (MuJoCo state + the env's dirt),
  and every action is executed from a restored copy of that snapshot; the successors the
  physics reached as the model predicts are visited next.  A state that no executed plan
  reached in a round (because a skill failed on the way) is staged directly by a reset
  (``reached_by = "staged"``); when that fails too (the pick staging a held object), each of its
  trials is recorded as a failure (``reason`` "not staged: ...", an abstraction fault observed).
- A trial *agrees* when the abstraction reads back the model's successor and the observed
  outcome is the model's outcome; an abstraction fault never agrees.

``--trials N`` rounds give N trials per (state, action) pair.  Rounds are independent (each
has its own seed), so they run in parallel: ``--workers N`` processes on this machine, or
``--executor ray [--ray-address HOST:PORT]`` (`tableclean_suite.executors`); every worker
builds its own scene and the rows are stored in round order.  Results go to ``DIR``:
``fidelity_trials.csv`` (one row per execution; rewritten atomically after every finished
round, so an interrupted run resumes where it stopped and never keeps a partial round:
`trial_store`; ``--fresh`` starts over), ``fidelity_pairs.csv`` (agreement per pair) and
``fidelity_skills.csv`` (success, retries, steps and seconds per skill, over executions the controller
did not refuse).  `collect` is the execution code ``tableclean-bench calibrate`` reuses.

The summary prints the overall agreement and each skill's success as counts, rates and their
one-sided 95 % exact (Clopper-Pearson) lower bounds ([lower_bound][tableclean_suite.bench.fidelity.lower_bound]).

``--randomize`` runs the scene with randomised dynamics (``randomization="on"``: the documented
ranges of `tableclean_suite.environments.randomization`), drawn anew at every staged reset
from that reset's seed; its results go to ``DIR_randomized`` by default.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")

from tableclean_suite.bench import trial_store  # noqa: E402
from tableclean_suite.bench.outputs import atomic_write_text, output_lock  # noqa: E402
from tableclean_suite.bench import cli  # noqa: E402
from tableclean_suite.bench.trial_store import TRIAL_FIELDS  # noqa: E402, F401  (re-exported)
from tableclean_suite.executors.blas import single_blas_thread  # noqa: E402
from tableclean_suite.task import Outcome, TaskModel, TaskState, get_task_spec  # noqa: E402

TRIALS_CSV = "fidelity_trials.csv"
PAIRS_CSV = "fidelity_pairs.csv"
SKILLS_CSV = "fidelity_skills.csv"
#: Output directory of the ``paper`` spec (other specs: ``<this>_<spec name>``).
DEFAULT_OUT = "results/fidelity"
#: Suffix of the default output directory with ``--randomize``.
RANDOMIZED_SUFFIX = "_randomized"
#: Confidence of the one-sided lower bound of every rate ([lower_bound][tableclean_suite.bench.fidelity.lower_bound]).
CONFIDENCE = 0.95
FAULT = "fault"
#: How the reason of a trial from a state that could not be staged starts (no skill ran: not in the skill table).
NOT_STAGED = "not staged"


class ResumeError(ValueError):
    """An existing trials file does not match the requested run."""


def round_seed(seed: int, round_index: int) -> int:
    """The scene seed of one round (placement noise of its four start layouts)."""
    return int(np.random.SeedSequence([int(seed), int(round_index)]).generate_state(1)[0])


def _trial_row(round_index, seed, layout, reached_by, state: TaskState, action: str, result, model) -> dict:
    expected, expected_outcome = model.step(state, action)
    observed = result.state_after
    observed_outcome = None if result.outcome is None else Outcome(result.outcome)
    agree = observed is not None and observed == expected and observed_outcome == expected_outcome
    return {
        "round": round_index,
        "seed": seed,
        "layout": layout,
        "reached_by": reached_by,
        "state": state.index,
        "action": model.action_name(action),
        "expected_state": expected.index,
        "expected_outcome": expected_outcome.name.lower(),
        "observed_state": -1 if observed is None else observed.index,
        "observed_outcome": FAULT if observed_outcome is None else observed_outcome.name.lower(),
        "agree": int(agree),
        "success": int(bool(result.success)),
        "improper": int(bool(result.improper)),
        "steps": int(result.steps),
        "retries": int(result.retries),
        "wall_time": round(float(result.wall_time), 4),
        "env_time": round(float(result.env_time), 4),
        "reason": str(result.reason).replace("\n", " "),
    }


def action_names(model: TaskModel, actions: Iterable | None = None) -> tuple[str, ...]:
    """The names of ``actions`` (names, Actions or indices; None: all) in the model's order, without repeats."""
    if actions is None:
        return tuple(model.action_names)
    chosen = {model.action_name(a) for a in actions}
    return tuple(name for name in model.action_names if name in chosen)


def layout_label(state: TaskState) -> str:
    """``"1-1"`` (object segment, arm segment; 1-based) for one object, ``"1.2-3"`` for objects 1, 2 and the arm."""
    return ".".join(str(o + 1) for o in state.objects) + f"-{state.arm + 1}"


@single_blas_thread()  # the same bits in this process, a local worker or a Ray worker
def run_round(scene, round_index: int, seed: int, on_trial: Callable[[dict], None] | None = None,
              actions: Iterable | None = None) -> list[dict]:
    """One round: every action in ``actions`` (default: the model's) once from every reachable non-terminal state.

    ``scene`` is a [`tableclean_suite.physics_backend.PhysicsStepEnv`][tableclean_suite.physics_backend.PhysicsStepEnv] (its env,
    controller and model are used).  States only reachable through a left-out action are
    staged.  Returns the trial rows in execution order.
    """
    from tableclean_suite.physics_backend import StagingError, stage
    from tableclean_suite.skill_result import SkillResult

    actions = action_names(scene.model, actions)

    env, controller, model = scene.env, scene.controller, scene.model
    targets = [s for s in model.reachable_states() if not s.is_terminal]
    visited: set[TaskState] = set()
    rows: list[dict] = []
    base_seed = round_seed(seed, round_index)

    def record(row):
        rows.append(row)
        if on_trial is not None:
            on_trial(row)

    def visit(state: TaskState, layout: str, reached_by: str) -> None:
        visited.add(state)
        saved = env.get_scene_state()
        children = []
        for k, action in enumerate(actions):
            if k:
                env.set_scene_state(saved)
            result = controller.execute(action)
            record(_trial_row(round_index, base_seed, layout, reached_by, state, action, result, model))
            expected = model.step(state, action)[0]
            if (result.state_after == expected and not expected.is_terminal and expected not in visited
                    and expected not in (c for c, _ in children)):
                children.append((expected, env.get_scene_state()))
        for child, child_snapshot in children:
            if child not in visited:
                env.set_scene_state(child_snapshot)
                visit(child, layout, "plan")

    starts = model.unclean_layouts()
    for k, start in enumerate(starts):
        if start in visited:
            continue
        stage(env, controller, start, seed=base_seed + k)
        visit(start, layout_label(start), "plan")
    for k, state in enumerate(targets):
        if state not in visited:  # a skill failed on every path to it this round
            try:
                stage(env, controller, state, seed=base_seed + len(starts) + k)
            except StagingError as error:  # (e.g. the pick that stages a held object failed): each trial fails
                visited.add(state)
                for action in actions:
                    failed = SkillResult(action, False, False, 0, f"{NOT_STAGED}: {error}", state, None, None)
                    record(_trial_row(round_index, base_seed, "staged", "staged", state, action, failed, model))
                continue
            visit(state, "staged", "staged")
    return rows


def read_trials(path: Path, log: Callable[[str], None] | None = None) -> list[dict]:
    """Rows of a trials CSV (numbers converted), ``[]`` when it does not exist.

    A damaged last line (an interrupted write) is dropped; any other damage, or unexpected
    columns, raises [`ResumeError`][tableclean_suite.bench.fidelity.ResumeError] naming the line.
    """
    try:
        return trial_store.read_rows(Path(path), log)
    except trial_store.TrialStoreError as error:
        raise ResumeError(str(error)) from None


def trials_per_round(model: TaskModel, actions: Iterable) -> int:
    """Trials of one complete round: every executed action from every reachable non-terminal state."""
    return sum(not s.is_terminal for s in model.reachable_states()) * len(tuple(actions))


@dataclass(frozen=True)
class FidelityRound:
    """One round as a task for an executor: plain values only (the worker builds its own scene).

    Attributes:
        spec: the task spec as JSON (``TaskSpec.to_dict()``).
        round_index: 0-based round number; with ``seed`` it fixes the round's placements.
        seed: the run's base seed (``--seed``).
        actions: names of the executed actions.
        physics_options: keyword arguments of the worker's ``PhysicsStepEnv`` (plain values).
    """

    spec: tuple
    round_index: int
    seed: int
    actions: tuple
    physics_options: tuple = ()

    @property
    def label(self) -> str:
        return f"fidelity round {self.round_index + 1}"


def run_round_task(task: FidelityRound) -> list[dict]:
    """Run one [`FidelityRound`][tableclean_suite.bench.fidelity.FidelityRound] in this process (the scene is built once per process, spec and
    options: [`tableclean_suite.physics_backend.process_session`][tableclean_suite.physics_backend.process_session])."""
    from tableclean_suite.physics_backend import process_session

    scene = process_session(task.spec[0], dict(task.physics_options))
    return run_round(scene, task.round_index, task.seed, actions=task.actions)


#: Suffix (after the trials CSV's stem) of the file recording what the stored trials were run with.
CONFIGURATION_SUFFIX = ".config.json"


def run_configuration(model: TaskModel, physics_options: dict | None, scene=None, plugins: Iterable[str] = ()) -> dict:
    """What determines a trial besides its round and seed: the task spec, the scene's options
    (robot, randomisation, ...) and the code that runs, ``--plugins`` included
    ([`code_digest`][tableclean_suite.bench.digests.code_digest]: an edited skill, primitive or
    object type measures other trials); JSON values, anything else by ``repr``."""
    import json

    from tableclean_suite.bench.digests import code_digest

    options = "a given scene" if scene is not None else (physics_options or {})
    configuration = {"task": model.spec.to_dict(), "physics_options": options, "code_digest": code_digest(plugins)}
    return json.loads(json.dumps(configuration, sort_keys=True, default=repr))


def configuration_path(trials_csv: Path) -> Path:
    """Where the options of the trials in ``trials_csv`` are recorded: ``<trials stem>.config.json``."""
    trials_csv = Path(trials_csv)
    return trials_csv.with_name(trials_csv.stem + CONFIGURATION_SUFFIX)


def read_configuration(trials_csv: Path) -> dict | None:
    """The recorded options of ``trials_csv``'s trials ([`run_configuration`][tableclean_suite.bench.fidelity.run_configuration]), None without a record.

    Raises:
        ResumeError: the record is unreadable, not JSON, or not an object with ``task``.
    """
    import json

    record = configuration_path(trials_csv)
    if not record.exists():
        return None
    try:
        stored = json.loads(record.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:  # UnicodeDecodeError and JSONDecodeError are ValueErrors
        raise ResumeError(f"{record} is unreadable ({type(error).__name__}: {error}); pass --fresh or another "
                          "--out") from None
    if not isinstance(stored, dict) or "task" not in stored:
        raise ResumeError(f"{record} is not a trials configuration (no 'task'); pass --fresh or another --out")
    return stored


def _has_trials(trials_csv: Path) -> bool:
    """Whether ``trials_csv`` holds more than a header line."""
    try:
        with open(trials_csv, "rb") as handle:
            return len(handle.read(1 << 16).splitlines()) > 1
    except OSError:
        return False


def check_configuration(trials_csv: Path, configuration: dict, log: Callable[[str], None] | None = None) -> None:
    """Refuse to resume trials stored under another, or an unknown, configuration; record this run's
    beside the CSV (``<trials stem>.config.json``).

    Raises:
        ResumeError: the record names other options (the keys that differ are named), or the CSV
            holds trials but the record is missing (their options are unknown: a robot, a
            randomisation or a task other than this run's would be mixed in) or unreadable.
    """
    import json

    record = configuration_path(trials_csv)
    if trials_csv.exists():
        stored = read_configuration(trials_csv)
        if stored is not None:
            differing = sorted(key for key in set(stored) | set(configuration) if stored.get(key) != configuration.get(key))
            if differing:
                raise ResumeError(f"{trials_csv} was measured with another {' and '.join(differing)} "
                                  f"({record}); pass the same options, another --out, or --fresh")
            return
        if _has_trials(trials_csv):
            raise ResumeError(f"{trials_csv} holds trials but {record.name} is missing, so the options they were "
                              "measured with (task, robot, randomisation) are unknown; pass --fresh or another --out")
    trials_csv.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(record, json.dumps(configuration, sort_keys=True, indent=1))


def check_trial_rows(rows, model: TaskModel, source) -> None:
    """Refuse stored trials that do not belong to ``model``: a state or observed state outside its
    codes, a terminal start state, an action it does not have or an unknown outcome.

    Raises:
        ResumeError: naming the file, the row (round and position) and the value.
    """
    outcomes = {o.name.lower() for o in Outcome} | {FAULT}
    for position, row in enumerate(rows):
        where = f"{source}: round {row.get('round')}, trial {position + 1}"
        state = row["state"]
        if not 0 <= state < model.n_states or model.decode(state).is_terminal:
            raise ResumeError(f"{where}: state {state} is not a non-terminal state of task {model.spec.name!r} "
                              f"(codes 0..{model.n_states - 1})")
        if row["action"] not in model.action_names:
            raise ResumeError(f"{where}: action {row['action']!r} is not one of task {model.spec.name!r}'s "
                              f"({', '.join(model.action_names)})")
        if row["observed_outcome"] not in outcomes:
            raise ResumeError(f"{where}: observed outcome {row['observed_outcome']!r} is not one of "
                              f"{', '.join(sorted(outcomes))}")
        if row["observed_outcome"] != FAULT and not 0 <= row["observed_state"] < model.n_states:
            raise ResumeError(f"{where}: observed state {row['observed_state']} is outside task "
                              f"{model.spec.name!r}'s codes 0..{model.n_states - 1}")


def collect(trials: int, seed: int = 0, trials_csv: str | Path | None = None, fresh: bool = False,
            scene=None, log: Callable[[str], None] | None = print, physics_options: dict | None = None,
            actions: Iterable | None = None, model: TaskModel | None = None, executor=None,
            plugins: Iterable[str] = ()) -> list[dict]:
    """Run rounds until there are ``trials`` of them; returns all trial rows (resumed ones included).

    With ``trials_csv`` every finished round is stored (atomically, whole rounds only), and
    complete rounds already in it are not run again (a different ``seed`` raises
    [`ResumeError`][tableclean_suite.bench.fidelity.ResumeError]; ``fresh=True`` deletes the file first; incomplete rounds run again).
    ``scene`` reuses a PhysicsStepEnv in this process; otherwise ``executor`` (a
    [`tableclean_suite.executors`][tableclean_suite.executors] executor; default: this process) runs the rounds, each
    worker building its scene with ``physics_options``.  ``actions`` limits the executed
    actions (e.g. leave out the slow clean).  ``model`` is the task (default: the scene's,
    else ``paper``).  The trials' folder is locked while rounds run
    ([`output_lock`][tableclean_suite.bench.outputs.output_lock]): a second run into it raises
    [`OutputBusyError`][tableclean_suite.bench.outputs.OutputBusyError].  ``plugins`` (``--plugins`` entries)
    enter the trials' configuration ([`run_configuration`][tableclean_suite.bench.fidelity.run_configuration]): resuming after a plugin was edited
    raises [`ResumeError`][tableclean_suite.bench.fidelity.ResumeError].
    """
    import json

    model = scene.model if scene is not None else (model or TaskModel())
    actions = action_names(model, actions)
    per_round = trials_per_round(model, actions)
    path = None if trials_csv is None else Path(trials_csv)
    with contextlib.ExitStack() as held:
        if path is not None:  # one writer per trials folder: a second run exits 2, never mixes rounds
            held.enter_context(output_lock(path.parent))
        if path is not None and fresh and path.exists():
            path.unlink()
        if path is not None:
            check_configuration(path, run_configuration(model, physics_options, scene, plugins), log)
        rows = trial_store.complete_rounds(read_trials(path, log) if path is not None else [], per_round, log)
        check_trial_rows(rows, model, path)
        done_rounds = sorted({row["round"] for row in rows})
        if rows and {row["seed"] for row in rows} != {round_seed(seed, r) for r in done_rounds}:
            raise ResumeError(f"{path} was measured with another --seed; pass that seed or --fresh")
        measured = {row["action"] for row in rows}
        if rows and measured != set(actions):
            raise ResumeError(f"{path} holds trials of {sorted(measured)}, not of the requested actions; use --fresh")
        todo = [r for r in range(trials) if r not in done_rounds]
        if done_rounds and log:
            log(f"resuming: {len(done_rounds)} round(s) already in {path}, {len(todo)} to run")
        if not todo:
            return [row for row in rows if row["round"] < trials]
        started = time.perf_counter()
        owned = scene is None and executor is None  # this process's default: its scenes close when the rounds are done
        if scene is not None:
            results = (run_round(scene, r, seed, actions=actions) for r in todo)
        else:
            from tableclean_suite.executors import LocalExecutor

            executor = LocalExecutor(workers=1) if owned else executor
            spec = (json.dumps(model.spec.to_dict(), sort_keys=True),)
            tasks = [FidelityRound(spec, r, seed, tuple(actions), tuple(sorted((physics_options or {}).items())))
                     for r in todo]
            results = executor.map(run_round_task, tasks)
        try:
            for round_index, new in zip(todo, results):
                if len(new) != per_round:
                    raise ResumeError(f"round {round_index + 1} produced {len(new)} trials, not {per_round}")
                rows.extend(new)
                if path is not None:
                    trial_store.write_rows(path, sorted(rows, key=lambda row: row["round"]))
                if log:
                    agree = sum(r["agree"] for r in new)
                    log(f"round {round_index + 1}/{trials}: {agree}/{len(new)} agree, {time.perf_counter() - started:.1f} s")
        finally:
            if owned:
                from tableclean_suite.physics_backend import close_sessions

                close_sessions()
        return [row for row in rows if row["round"] < trials]


# ---------------------------------------------------------------------------------------------
# tables
# ---------------------------------------------------------------------------------------------
def _refused(row, model: TaskModel) -> bool:
    """The controller did not run a skill: the model calls the action improper or ineffective."""
    outcome = model.step(row["state"], row["action"])[1]
    return outcome in (Outcome.IMPROPER, Outcome.INEFFECTIVE)


def pair_table(rows: Iterable[dict], model: TaskModel | None = None) -> list[dict]:
    """Agreement per (state, action), sorted by state code then action (``model``: default ``paper``)."""
    model = model or TaskModel()
    groups: dict[tuple[int, str], list[dict]] = {}
    for row in rows:
        groups.setdefault((row["state"], row["action"]), []).append(row)
    order = {name: k for k, name in enumerate(model.action_names)}
    table = []
    for (state, action), group in sorted(groups.items(), key=lambda kv: (kv[0][0], order[kv[0][1]])):
        disagreements = sorted({f"{r['observed_state']}/{r['observed_outcome']}" for r in group if not r["agree"]})
        table.append({
            "state": state,
            "state_name": model.decode(state).name,
            "action": action,
            "expected": f"{group[0]['expected_state']}/{group[0]['expected_outcome']}",
            "trials": len(group),
            "agreements": sum(r["agree"] for r in group),
            "agreement_rate": round(sum(r["agree"] for r in group) / len(group), 4),
            "faults": sum(r["observed_outcome"] == FAULT for r in group),
            "disagreements_seen": " ".join(disagreements),
        })
    return table


def skill_table(rows: Iterable[dict], model: TaskModel | None = None) -> list[dict]:
    """Per skill: executions the controller ran (not refused; not the trials of a state that could not be staged),
    success rate, retries (in all, and executions that succeeded after one), mean steps and seconds."""
    model = model or TaskModel()
    rows = list(rows)
    table = []
    for action in model.action_names:
        mine = [r for r in rows if r["action"] == action and not str(r["reason"]).startswith(NOT_STAGED)]
        ran = [r for r in mine if not _refused(r, model)]
        n = len(ran)
        table.append({
            "skill": action,
            "executions": n,
            "successes": sum(r["success"] for r in ran),
            "success_rate": round(sum(r["success"] for r in ran) / n, 4) if n else float("nan"),
            "agreement_rate": round(sum(r["agree"] for r in ran) / n, 4) if n else float("nan"),
            "faults": sum(r["observed_outcome"] == FAULT for r in ran),
            "retries": sum(r["retries"] for r in ran),
            "saved_by_retry": sum(bool(r["success"] and r["retries"]) for r in ran),
            "mean_steps": round(float(np.mean([r["steps"] for r in ran])), 1) if n else float("nan"),
            "mean_seconds": round(float(np.mean([r["wall_time"] for r in ran])), 3) if n else float("nan"),
            "refused": len(mine) - n,
        })
    return table


def write_csv(path: Path, table: list[dict]) -> None:
    """Write ``table`` (rows of one shape) to ``path`` as CSV atomically ([`trial_store.write_rows`][tableclean_suite.bench.trial_store.write_rows])."""
    trial_store.write_rows(path, table, tuple(table[0]) if table else ("empty",))


def format_table(table: list[dict], columns: Iterable[str]) -> str:
    """A Markdown table of the given columns."""
    columns = list(columns)
    lines = ["| " + " | ".join(columns) + " |", "|" + "|".join("---" for _ in columns) + "|"]
    for row in table:
        lines.append("| " + " | ".join(str(row[c]) for c in columns) + " |")
    return "\n".join(lines)


def lower_bound(successes: int, executions: int, confidence: float = CONFIDENCE) -> float:
    """One-sided exact (Clopper-Pearson, scipy's ``binomtest``) lower bound of a rate, in [0, 1].

    With ``confidence`` 0.95 the rate is at least this with 95 % confidence; 0 failures in ``n``
    executions give ``0.05 ** (1 / n)`` (0.990 at n = 299).  ``executions`` 0 gives 0.
    """
    from scipy.stats import binomtest

    if executions == 0:
        return 0.0
    return float(binomtest(int(successes), int(executions), alternative="greater")
                 .proportion_ci(confidence_level=confidence).low)


def percent_down(rate: float) -> str:
    """``rate`` (in [0, 1]) as a percentage rounded down to 0.1 % (a lower bound is never shown higher)."""
    return f"{math.floor(rate * 1000 + 1e-9) / 10:.1f} %"


def summary(rows: list[dict], model: TaskModel | None = None) -> dict:
    """Overall agreement (``agreements`` of ``trials``, and the rate), minimum per-pair agreement, abstraction
    faults and per skill ``skills`` (success rate, executions) and ``successes`` (successful executions)."""
    pairs, skills = pair_table(rows, model), skill_table(rows, model)
    total = len(rows)
    agreements = sum(r["agree"] for r in rows)
    return {
        "trials": total,
        "rounds": len({r["round"] for r in rows}),
        "agreements": agreements,
        "agreement": agreements / total if total else float("nan"),
        "min_pair_agreement": min((p["agreement_rate"] for p in pairs), default=float("nan")),
        "faults": sum(r["observed_outcome"] == FAULT for r in rows),
        "skills": {s["skill"]: (s["success_rate"], s["executions"]) for s in skills},
        "successes": {s["skill"]: s["successes"] for s in skills},
    }


def summary_lines(result: dict, title: str) -> list[str]:
    """The printed summary of a [summary][tableclean_suite.bench.fidelity.summary] dict: ``title``, the
    agreement and every executed skill's success as ``count/n = rate`` with the one-sided 95 % lower bound
    ([lower_bound][tableclean_suite.bench.fidelity.lower_bound], rounded down to 0.1 %)."""
    trials, agreements = result["trials"], result["agreements"]
    lines = [f"{title}: {trials} trials in {result['rounds']} round(s): agreement {agreements}/{trials} = "
             f"{100 * result['agreement']:.2f} % (95 % lower bound {percent_down(lower_bound(agreements, trials))}), "
             f"lowest pair {100 * result['min_pair_agreement']:.2f} %, {result['faults']} abstraction fault(s)"]
    for skill, (rate, n) in result["skills"].items():
        if n:
            successes = result["successes"][skill]
            lines.append(f"  {skill}: success {successes}/{n} = {100 * rate:.2f} % "
                         f"(95 % lower bound {percent_down(lower_bound(successes, n))})")
    return lines


# ---------------------------------------------------------------------------------------------
# CLI
# ---------------------------------------------------------------------------------------------
def add_execution_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of [`collect`][tableclean_suite.bench.fidelity.collect] shared by fidelity and calibrate: --task, --trials, --seed, --actions,
    --quiet and where the rounds run."""
    cli.add_task_argument(parser)
    parser.add_argument("--trials", type=cli.positive_int, default=5,
                        help="trials per (state, action) pair = rounds (default 5)")
    cli.add_seed_argument(parser, "the placement noise")
    parser.add_argument("--actions", default=None,
                        help="comma-separated actions to execute (default all of the spec's, e.g. move,pick,place,clean)")
    parser.add_argument("--quiet", action="store_true", help="print only the summary")
    cli.add_executor_arguments(parser, "rounds")  # --workers, --executor, --ray-address


def scene_env_kwargs(robot: str, randomize: bool) -> dict:
    """The scene options of a fidelity run on ``robot`` (randomised dynamics ``"on"`` if ``randomize``):
    one form for every command, so their stored trials' configurations compare equal."""
    return {"robots": robot, **({"randomization": "on"} if randomize else {})}


def parse_task_and_actions(parser: argparse.ArgumentParser, args) -> tuple[TaskModel, tuple[str, ...]]:
    """The model of ``--task`` (checked against the physical scene) and the names of ``--actions``; exits 2 on bad input."""
    from tableclean_suite.physics_backend import check_physical_task

    try:
        model = TaskModel(spec=get_task_spec(args.task))
        check_physical_task(model)
    except (ValueError, OSError) as error:
        parser.error(f"--task: {error}")
    if args.actions is None:
        return model, tuple(model.action_names)
    names = [part.strip() for part in str(args.actions).split(",") if part.strip()]
    if not names:
        parser.error("--actions: expected at least one action")
    try:
        return model, action_names(model, names)
    except ValueError as error:
        parser.error(f"--actions: {error}")


#: The program name in messages unless the caller gives one.
PROG = "tableclean-bench fidelity"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line: the shared options of [`cli`][tableclean_suite.bench.cli] and fidelity's own."""
    parser = cli.command_parser(prog, __doc__.split("\n\n")[0])
    add_execution_arguments(parser)
    cli.add_out_argument(parser, cli.DIRECTORY, None, f"output directory ({DEFAULT_OUT} when not given, or "
                                                      f"{DEFAULT_OUT}_<task> for another spec)")
    parser.add_argument("--fresh", action="store_true", help="discard earlier trials in --out and start over")
    cli.add_robots_argument(parser)
    parser.add_argument("--randomize", action="store_true",
                        help="randomised dynamics (mass, size, friction, damping, OSC gains, start noise; the ranges "
                             "of tableclean_suite.environments.randomization), drawn at every reset; the default "
                             f"--out gets the suffix {RANDOMIZED_SUFFIX}")
    return parser


def main(argv: list[str] | None = None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    parser, args = cli.parse_command(build_parser, argv, prog or PROG)
    model, actions = parse_task_and_actions(parser, args)
    robot = cli.parse_robot(parser, args)
    suffix = ("" if model.spec.name == "paper" else f"_{model.spec.name}") + ("" if robot == "Panda" else f"_{robot}")
    suffix += RANDOMIZED_SUFFIX if args.randomize else ""
    env_kwargs = scene_env_kwargs(robot, args.randomize)
    out = Path(args.out if args.out is not None else DEFAULT_OUT + suffix)
    started = time.perf_counter()
    executor = cli.executor_from_args(parser, args)
    try:
        with executor:
            rows = collect(args.trials, args.seed, out / TRIALS_CSV, fresh=args.fresh,
                           log=None if args.quiet else print, actions=actions, model=model, executor=executor,
                           physics_options={"env_kwargs": env_kwargs}, plugins=args.plugins)
    except ResumeError as error:
        parser.error(str(error))  # exits 2
    pairs, skills = pair_table(rows, model), skill_table(rows, model)
    write_csv(out / PAIRS_CSV, pairs)
    write_csv(out / SKILLS_CSV, skills)
    result = summary(rows, model)
    if not args.quiet:
        print("\nper (state, action):")
        print(format_table(pairs, ("state", "action", "expected", "trials", "agreement_rate", "faults", "disagreements_seen")))
    print("\nper skill (executions the controller ran; refused = improper/ineffective, no motion):")
    print(format_table(skills, ("skill", "executions", "success_rate", "agreement_rate", "faults", "retries", "saved_by_retry",
                                "mean_steps", "mean_seconds", "refused")))
    print()
    print("\n".join(summary_lines(result, f"{model.spec.name} on {robot}")))
    print(f"CSVs in {out}/ ({time.perf_counter() - started:.0f} s)")
    return 0


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("fidelity", "python -m tableclean_suite.bench.fidelity"))
