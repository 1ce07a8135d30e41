"""Fidelity of the skills: does physics do what the task model says, from every reachable state?

    tableclean-bench fidelity [--task SPEC] [--robots ROBOT] [--trials N] [--out DIR] [--seed S] [--fresh]
                                  [--randomize]

One *round* executes every action once from every reachable non-terminal state of ``--task``
(paper: 18 states x 4 actions = 72 trials).  Each all-unclean start layout is reset with placement
noise seeded per round and layout; states are visited depth-first in physics, each snapshotted and
every action executed from a restored copy.  A state no plan reached in a round is staged by a reset
(``reached_by = "staged"``); when staging fails, its trials are failures (reason "not staged: ...").
A trial *agrees* when the abstraction reads back the model's successor and outcome.

``--trials N`` rounds (independent, seeded) run in this process, ``--workers N`` local processes or
``--executor ray``.  ``DIR`` gets ``fidelity_trials.csv`` (whole rounds, rewritten atomically after
each; a run resumes, ``--fresh`` starts over), ``fidelity_pairs.csv`` (agreement per pair) and
``fidelity_skills.csv`` (per skill, executions the controller did not refuse).  The summary gives
rates with one-sided 95 % exact lower bounds ([lower_bound][tableclean_suite.bench.fidelity.lower_bound]).
``--randomize``: randomised dynamics drawn at every reset (default ``--out`` gets ``_randomized``).

The shared machinery of ``tableclean-bench robots`` and ``objects`` lives here too: optimal-plan
episodes ([`play_episodes`][tableclean_suite.bench.fidelity.play_episodes]) and count cells with lower bounds.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

from tableclean_suite import intervals
from tableclean_suite.bench import trial_store
from tableclean_suite.bench.trial_store import TrialStoreError, read_rows
from tableclean_suite.bench.outputs import atomic_write_text, output_lock
from tableclean_suite.bench import cli
from tableclean_suite.executors.blas import single_blas_thread
from tableclean_suite.task import Outcome, TaskModel, TaskState, get_task_spec

TRIALS_CSV = "fidelity_trials.csv"
PAIRS_CSV = "fidelity_pairs.csv"
SKILLS_CSV = "fidelity_skills.csv"
#: Output directory of the ``paper`` spec (other specs: ``<this>_<spec name>``).
DEFAULT_OUT = "results/fidelity"
#: Suffix of the default output directory with ``--randomize``.
RANDOMIZED_SUFFIX = "_randomized"
#: Confidence of the one-sided lower bound of every rate ([lower_bound][tableclean_suite.bench.fidelity.lower_bound]).
CONFIDENCE = intervals.DEFAULT_CONFIDENCE
FAULT = "fault"
#: How the reason of a trial from a state that could not be staged starts (no skill ran: not in the skill table).
NOT_STAGED = "not staged"



def round_seed(seed: int, round_index: int) -> int:
    """The scene seed of one round (placement noise of its four start layouts)."""
    return int(np.random.SeedSequence([int(seed), int(round_index)]).generate_state(1)[0])


def _trial_row(round_index, seed, layout, reached_by, state: TaskState, action: str, result, model) -> dict:
    expected, expected_outcome = model.step(state, action)
    observed = result.state_after
    observed_outcome = None if result.outcome is None else Outcome(result.outcome)
    agree = observed is not None and observed == expected and observed_outcome == expected_outcome
    return {
        "round": round_index, "seed": seed, "layout": layout, "reached_by": reached_by, "state": state.index,
        "action": model.action_name(action), "expected_state": expected.index,
        "expected_outcome": expected_outcome.name.lower(), "observed_state": -1 if observed is None else observed.index,
        "observed_outcome": FAULT if observed_outcome is None else observed_outcome.name.lower(), "agree": int(agree),
        "success": int(bool(result.success)), "improper": int(bool(result.improper)), "steps": int(result.steps),
        "retries": int(result.retries), "wall_time": round(float(result.wall_time), 4),
        "env_time": round(float(result.env_time), 4), "reason": str(result.reason).replace("\n", " "),
    }


def action_names(model: TaskModel, actions: Iterable | None = None) -> tuple[str, ...]:
    """The names of ``actions`` (names, Actions or indices; None: all) in the model's order, without repeats."""
    if actions is None:
        return tuple(model.action_names)
    chosen = {model.action_name(a) for a in actions}
    return tuple(name for name in model.action_names if name in chosen)


@single_blas_thread()  # the same bits in this process, a local worker or a Ray worker
def run_round(scene, round_index: int, seed: int, actions: Iterable | None = None) -> list[dict]:
    """The trial rows, in execution order, of one round of ``actions`` (default: all) on ``scene`` (a
    [`PhysicsStepEnv`][tableclean_suite.physics_backend.PhysicsStepEnv]); states only reachable through a
    left-out action are staged."""
    from tableclean_suite.physics_backend import StagingError, stage
    from tableclean_suite.skill_result import SkillResult

    actions = action_names(scene.model, actions)
    env, controller, model = scene.env, scene.controller, scene.model
    targets = [s for s in model.reachable_states() if not s.is_terminal]
    visited: set[TaskState] = set()
    rows: list[dict] = []
    base_seed = round_seed(seed, round_index)

    def visit(state: TaskState, layout: str, reached_by: str) -> None:
        visited.add(state)
        saved = env.get_scene_state()
        children = []
        for k, action in enumerate(actions):
            if k:
                env.set_scene_state(saved)
            result = controller.execute(action)
            rows.append(_trial_row(round_index, base_seed, layout, reached_by, state, action, result, model))
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
        visit(start, ".".join(str(o + 1) for o in start.objects) + f"-{start.arm + 1}", "plan")  # "1.2-3": objects, arm
    for k, state in enumerate(targets):
        if state not in visited:  # a skill failed on every path to it this round
            try:
                stage(env, controller, state, seed=base_seed + len(starts) + k)
            except StagingError as error:  # (e.g. the pick that stages a held object failed): each trial fails
                visited.add(state)
                for action in actions:
                    failed = SkillResult(action, False, False, 0, f"{NOT_STAGED}: {error}", state, None, None)
                    rows.append(_trial_row(round_index, base_seed, "staged", "staged", state, action, failed, model))
                continue
            visit(state, "staged", "staged")
    return rows


def trials_per_round(model: TaskModel, actions: Iterable) -> int:
    """Trials of one complete round: every executed action from every reachable non-terminal state."""
    return sum(not s.is_terminal for s in model.reachable_states()) * len(tuple(actions))


@dataclass(frozen=True)
class FidelityRound:
    """One round as an executor task of plain values: ``(spec JSON,)``, 0-based round, ``--seed``, action
    names and the worker's ``PhysicsStepEnv`` options as sorted items."""

    spec: tuple
    round_index: int
    seed: int
    actions: tuple
    physics_options: tuple = ()

    @property
    def label(self) -> str:
        return f"fidelity round {self.round_index + 1}"


def run_round_task(task: FidelityRound) -> list[dict]:
    """Run one [`FidelityRound`][tableclean_suite.bench.fidelity.FidelityRound] on this process's scene
    ([`process_session`][tableclean_suite.physics_backend.process_session])."""
    from tableclean_suite.physics_backend import process_session

    scene = process_session(task.spec[0], dict(task.physics_options))
    return run_round(scene, task.round_index, task.seed, actions=task.actions)


#: Suffix (after the trials CSV's stem) of the file recording what the stored trials were run with.
CONFIGURATION_SUFFIX = ".config.json"


def run_configuration(model: TaskModel, physics_options: dict | None, plugins: Iterable[str] = ()) -> dict:
    """What determines a trial besides its round and seed, as JSON values: the task spec, the scene's options
    and the code ([`code_digest`][tableclean_suite.bench.digests.code_digest], ``--plugins`` included)."""
    from tableclean_suite.bench.digests import code_digest

    configuration = {"task": model.spec.to_dict(), "physics_options": physics_options or {},
                     "code_digest": code_digest(plugins)}
    return json.loads(json.dumps(configuration, sort_keys=True, default=repr))


def configuration_path(trials_csv: Path) -> Path:
    """Where the options of the trials in ``trials_csv`` are recorded: ``<trials stem>.config.json``."""
    return Path(trials_csv).with_name(Path(trials_csv).stem + CONFIGURATION_SUFFIX)


def read_configuration(trials_csv: Path) -> dict | None:
    """The recorded [`run_configuration`][tableclean_suite.bench.fidelity.run_configuration] of ``trials_csv``'s
    trials, None without a record;
    [`TrialStoreError`][tableclean_suite.bench.trial_store.TrialStoreError] when unreadable."""
    record = configuration_path(trials_csv)
    if not record.exists():
        return None
    try:
        stored = json.loads(record.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:  # UnicodeDecodeError and JSONDecodeError are ValueErrors
        raise TrialStoreError(f"{record} is unreadable ({type(error).__name__}: {error}); pass --fresh or another "
                          "--out") from None
    if not isinstance(stored, dict) or "task" not in stored:
        raise TrialStoreError(f"{record} is not a trials configuration (no 'task'); pass --fresh or another --out")
    return stored


def check_configuration(trials_csv: Path, configuration: dict) -> None:
    """Record ``configuration`` beside ``trials_csv``;
    [`TrialStoreError`][tableclean_suite.bench.trial_store.TrialStoreError] when the stored trials were measured with
    another configuration (naming the keys), or hold trials without a readable record."""
    record = configuration_path(trials_csv)
    if trials_csv.exists():
        stored = read_configuration(trials_csv)
        if stored is not None:
            differing = sorted(k for k in stored.keys() | configuration.keys() if stored.get(k) != configuration.get(k))
            if differing:
                raise TrialStoreError(f"{trials_csv} was measured with another {' and '.join(differing)} "
                                  f"({record}); pass the same options, another --out, or --fresh")
            return
        if len(trial_store.read_lines(trials_csv)) > 1:  # trials, not just a header
            raise TrialStoreError(f"{trials_csv} holds trials but {record.name} is missing, so the options they were "
                              "measured with (task, robot, randomisation) are unknown; pass --fresh or another --out")
    trials_csv.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(record, json.dumps(configuration, sort_keys=True, indent=1))


def check_trial_rows(rows, model: TaskModel, source) -> None:
    """[`TrialStoreError`][tableclean_suite.bench.trial_store.TrialStoreError] naming the file, row and value of a
    stored trial that does not belong to ``model`` (state, action, observed state or outcome)."""
    outcomes = {o.name.lower() for o in Outcome} | {FAULT}
    for position, row in enumerate(rows):
        where = f"{source}: round {row.get('round')}, trial {position + 1}"
        state = row["state"]
        if not 0 <= state < model.n_states or model.decode(state).is_terminal:
            raise TrialStoreError(f"{where}: state {state} is not a non-terminal state of task {model.spec.name!r} "
                              f"(codes 0..{model.n_states - 1})")
        if row["action"] not in model.action_names:
            raise TrialStoreError(f"{where}: action {row['action']!r} is not one of task {model.spec.name!r}'s "
                              f"({', '.join(model.action_names)})")
        if row["observed_outcome"] not in outcomes:
            raise TrialStoreError(f"{where}: observed outcome {row['observed_outcome']!r} is not one of "
                              f"{', '.join(sorted(outcomes))}")
        if row["observed_outcome"] != FAULT and not 0 <= row["observed_state"] < model.n_states:
            raise TrialStoreError(f"{where}: observed state {row['observed_state']} is outside task "
                              f"{model.spec.name!r}'s codes 0..{model.n_states - 1}")


def collect(trials: int, seed: int, trials_csv: str | Path, fresh: bool = False,
            log: Callable[[str], None] | None = print, physics_options: dict | None = None,
            actions: Iterable | None = None, model: TaskModel | None = None, executor=None,
            plugins: Iterable[str] = ()) -> list[dict]:
    """Run rounds until there are ``trials`` of them; returns all trial rows (resumed ones included).

    Every finished round is stored in ``trials_csv`` and complete stored rounds are resumed (``fresh`` deletes
    them first); its folder is locked meanwhile ([`output_lock`][tableclean_suite.bench.outputs.output_lock]).
    ``executor`` (default: this process) runs the rounds, each worker building its scene with
    ``physics_options``.  ``actions`` limits the executed actions; ``model`` is the task (default ``paper``).

    Raises:
        TrialStoreError: the stored trials were measured with another seed, actions or
            [`run_configuration`][tableclean_suite.bench.fidelity.run_configuration] (``plugins`` included).
    """
    model = model or TaskModel()
    actions = action_names(model, actions)
    per_round = trials_per_round(model, actions)
    path = Path(trials_csv)
    with output_lock(path.parent):  # one writer per trials folder: a second run exits 2, never mixes rounds
        if fresh and path.exists():
            path.unlink()
        check_configuration(path, run_configuration(model, physics_options, plugins))
        rows = trial_store.complete_rounds(read_rows(path, log), per_round, log)
        check_trial_rows(rows, model, path)
        done_rounds = sorted({row["round"] for row in rows})
        if rows and {row["seed"] for row in rows} != {round_seed(seed, r) for r in done_rounds}:
            raise TrialStoreError(f"{path} was measured with another --seed; pass that seed or --fresh")
        measured = {row["action"] for row in rows}
        if rows and measured != set(actions):
            raise TrialStoreError(f"{path} holds trials of {sorted(measured)}, not of the requested actions; "
                                  "use --fresh")
        todo = [r for r in range(trials) if r not in done_rounds]
        if done_rounds and log:
            log(f"resuming: {len(done_rounds)} round(s) already in {path}, {len(todo)} to run")
        if not todo:
            return [row for row in rows if row["round"] < trials]
        started = time.perf_counter()
        owned = executor is None  # this process's default: its scenes close when the rounds are done
        if owned:
            from tableclean_suite.executors import LocalExecutor

            executor = LocalExecutor(workers=1)
        spec = (json.dumps(model.spec.to_dict(), sort_keys=True),)
        tasks = [FidelityRound(spec, r, seed, tuple(actions), tuple(sorted((physics_options or {}).items())))
                 for r in todo]
        results = executor.map(run_round_task, tasks)
        try:
            for round_index, new in zip(todo, results):
                if len(new) != per_round:
                    raise TrialStoreError(f"round {round_index + 1} produced {len(new)} trials, not {per_round}")
                rows.extend(new)
                trial_store.write_rows(path, sorted(rows, key=lambda row: row["round"]))
                if log:
                    agree = sum(r["agree"] for r in new)
                    log(f"round {round_index + 1}/{trials}: {agree}/{len(new)} agree, "
                        f"{time.perf_counter() - started:.1f} s")
        finally:
            if owned:
                from tableclean_suite.physics_backend import close_sessions

                close_sessions()
        return [row for row in rows if row["round"] < trials]


# ---------------------------------------------------------------------------------------------
# tables
# ---------------------------------------------------------------------------------------------
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
        agreements = sum(r["agree"] for r in group)
        table.append({
            "state": state, "state_name": model.decode(state).name, "action": action,
            "expected": f"{group[0]['expected_state']}/{group[0]['expected_outcome']}", "trials": len(group),
            "agreements": agreements, "agreement_rate": round(agreements / len(group), 4),
            "faults": sum(r["observed_outcome"] == FAULT for r in group), "disagreements_seen": " ".join(disagreements),
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
        refused = (Outcome.IMPROPER, Outcome.INEFFECTIVE)  # the controller runs no skill
        ran = [r for r in mine if model.step(r["state"], r["action"])[1] not in refused]
        n = len(ran)

        def mean(key, digits):
            return round(float(np.mean([r[key] for r in ran])), digits) if n else float("nan")

        table.append({
            "skill": action, "executions": n, "successes": sum(r["success"] for r in ran),
            "success_rate": mean("success", 4), "agreement_rate": mean("agree", 4),
            "faults": sum(r["observed_outcome"] == FAULT for r in ran), "retries": sum(r["retries"] for r in ran),
            "saved_by_retry": sum(bool(r["success"] and r["retries"]) for r in ran),
            "mean_steps": mean("steps", 1), "mean_seconds": mean("wall_time", 3), "refused": len(mine) - n,
        })
    return table


def write_csv(path: Path, table: list[dict]) -> None:
    """Write ``table`` (rows of one shape) to ``path`` as CSV atomically."""
    trial_store.write_rows(path, table, tuple(table[0]) if table else ("empty",))


def lower_bound(successes: int, executions: int, confidence: float = CONFIDENCE) -> float:
    """One-sided exact lower bound of a rate, in [0, 1]
    ([clopper_pearson][tableclean_suite.intervals.clopper_pearson] ``"greater"``); ``executions`` 0 gives 0."""
    return intervals.clopper_pearson(successes, executions, confidence, "greater")[0] if executions else 0.0


def percent_down(rate: float) -> str:
    """``rate`` (in [0, 1]) as a percentage rounded down to 0.1 % (a lower bound is never shown higher)."""
    return f"{math.floor(rate * 1000 + 1e-9) / 10:.1f} %"


def count_cells(count: int, n: int) -> tuple[str, str]:
    """``("count/n = rate %", "lower bound %")`` of ``count`` of ``n``, the bound rounded down."""
    return f"{count}/{n} = {100 * count / n:.2f} %", percent_down(lower_bound(count, n))


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
    return lines + [f"  {skill}: success {result['successes'][skill]}/{n} = {100 * rate:.2f} % (95 % lower bound "
                    f"{percent_down(lower_bound(result['successes'][skill], n))})"
                    for skill, (rate, n) in result["skills"].items() if n]


def measure(out: Path, model: TaskModel, trials: int, seed: int, **options) -> tuple[list, list, dict]:
    """[`collect`][tableclean_suite.bench.fidelity.collect] ``trials`` rounds into ``out`` (``options``: its
    keywords) and write their pair and skill tables there; returns ``(pairs, skills, summary)``."""
    rows = collect(trials, seed, Path(out) / TRIALS_CSV, model=model, **options)
    pairs, skills = pair_table(rows, model), skill_table(rows, model)
    write_csv(Path(out) / PAIRS_CSV, pairs)
    write_csv(Path(out) / SKILLS_CSV, skills)
    return pairs, skills, summary(rows, model)


# ---------------------------------------------------------------------------------------------
# episodes (tableclean-bench robots and objects)
# ---------------------------------------------------------------------------------------------
def shortest_plan(env, model: TaskModel, episode: int) -> list:
    """The default ``plan_of`` of [`play_episodes`][tableclean_suite.bench.fidelity.play_episodes]: reset, the
    model's shortest plan."""
    env.reset()
    return model.shortest_plan(env.symbolic_state())


def play_episodes(count: int, plan_of: Callable = shortest_plan, model: TaskModel | None = None, log=None,
                  label: str = "", **env_kwargs) -> dict:
    """Play ``count`` episodes in one skill env ([`make_skill_env`][tableclean_suite.controllers.make.make_skill_env]
    of ``env_kwargs``, closed at the end) and tally them.

    ``plan_of(env, model, episode)`` resets the env and returns the actions to execute (the controller stops at
    the first failure).  An episode succeeds when every skill does and the state read back at the end is
    terminal; an exception (an abstraction fault) fails it.  Returns ``{"episodes", "successes", "seconds",
    "skills", "failures"}``: ``seconds`` the episodes' wall-clock time in all (resets included, the scene build
    not), ``skills`` per executed skill ``[executions, successes, agreements, retries]`` (an agreement: the
    state read back is the model's successor), ``failures`` ``(episode, reason, results)`` per failed episode
    (``reason`` names the failed skills, or ``"not terminal"``).
    """
    from tableclean_suite.controllers import SkillController, make_skill_env

    tally = {"episodes": count, "successes": 0, "seconds": 0.0, "skills": {}, "failures": []}
    env = make_skill_env(**env_kwargs)
    try:
        controller = SkillController(env) if model is None else SkillController(env, model)
        model = controller.model
        for episode in range(count):
            started = time.perf_counter()
            try:
                results = controller.execute_plan(plan_of(env, model, episode))
                ok = all(r.success for r in results) and env.symbolic_state().is_terminal
                reason = "; ".join(f"{model.action_name(r.action)}: {r.reason}" for r in results if not r.success)
            except Exception as error:  # an abstraction fault at the start or the end: a failed episode
                results, ok, reason = [], False, f"{type(error).__name__}: {error}"
            tally["seconds"] += time.perf_counter() - started
            tally["successes"] += ok
            for r in results:
                count_of = tally["skills"].setdefault(model.action_name(r.action), [0] * 4)
                count_of[0] += 1
                count_of[1] += bool(r.success)
                count_of[2] += r.state_after is not None and r.state_after == r.expected
                count_of[3] += r.retries
            if not ok:
                tally["failures"].append((episode, reason or "not terminal", results))
                if log:
                    log(f"  {label} episode {episode}: FAILED ({reason or 'not terminal'})")
    finally:
        env.close()
    return tally


# ---------------------------------------------------------------------------------------------
# CLI
# ---------------------------------------------------------------------------------------------
def add_execution_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of [`collect`][tableclean_suite.bench.fidelity.collect] shared by fidelity and calibrate."""
    cli.add_task_argument(parser)
    parser.add_argument("--trials", type=cli.positive_int, default=5,
                        help="trials per (state, action) pair = rounds (default 5)")
    cli.add_seed_argument(parser, "the placement noise")
    parser.add_argument("--actions", type=cli.name_list, default=None,
                        help="comma-separated actions to execute (default all of the spec's, e.g. "
                             "move,pick,place,clean)")
    parser.add_argument("--quiet", action="store_true", help="print only the summary")
    cli.add_executor_arguments(parser, "rounds")  # --workers, --executor, --ray-address


def scene_env_kwargs(robot: str, randomize: bool) -> dict:
    """The scene options of a fidelity run on ``robot`` (randomised dynamics ``"on"`` if ``randomize``):
    one form for every command, so their stored trials' configurations compare equal."""
    return {"robots": robot, **({"randomization": "on"} if randomize else {})}


def physical_model(parser: argparse.ArgumentParser, task, flag: str = "--task") -> TaskModel:
    """The model of task spec ``task`` (a name, ``.json`` path or spec), checked against the physical scene;
    exits 2 naming ``flag`` when it is unknown or does not fit the scene."""
    from tableclean_suite.physics_backend import check_physical_task

    try:
        model = TaskModel(spec=get_task_spec(task))
        check_physical_task(model)
    except (ValueError, OSError) as error:
        parser.error(f"{flag}: {error}")
    return model


def parse_task_and_actions(parser: argparse.ArgumentParser, args) -> tuple[TaskModel, tuple[str, ...]]:
    """The model of ``--task`` ([`physical_model`][tableclean_suite.bench.fidelity.physical_model]) and the names
    of ``--actions``; exits 2 on bad input."""
    model = physical_model(parser, args.task)
    try:
        return model, action_names(model, args.actions)
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


def _columns(table: list[dict], columns: str) -> str:
    """The Markdown table of ``table``'s space-separated ``columns``."""
    return cli.markdown_table([[row[column] for column in columns.split()] for row in table], columns.split())


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
            pairs, skills, result = measure(out, model, args.trials, args.seed, fresh=args.fresh, actions=actions,
                                            log=None if args.quiet else print, executor=executor,
                                            physics_options={"env_kwargs": env_kwargs}, plugins=args.plugins)
    except TrialStoreError as error:
        parser.error(str(error))  # exits 2
    if not args.quiet:
        print("\nper (state, action):")
        print(_columns(pairs, "state action expected trials agreement_rate faults disagreements_seen"))
    print("\nper skill (executions the controller ran; refused = improper/ineffective, no motion):")
    print(_columns(skills, "skill executions success_rate agreement_rate faults retries saved_by_retry mean_steps "
                           "mean_seconds refused"))
    print()
    print("\n".join(summary_lines(result, f"{model.spec.name} on {robot}")))
    print(f"CSVs in {out}/ ({time.perf_counter() - started:.0f} s)")
    return 0


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("fidelity", "python -m tableclean_suite.bench.fidelity"))
