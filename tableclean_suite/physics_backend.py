"""Skills in MuJoCo as a step environment for the learners (``train(backend="physics")``).

[`PhysicsStepEnv`][tableclean_suite.physics_backend.PhysicsStepEnv] puts the ``TableClean`` robosuite scene into a task state
([`stage`][tableclean_suite.physics_backend.stage]), executes actions with the [`SkillController`][tableclean_suite.controllers.skill_controller.SkillController]
and reads the next state back through the environment's abstraction.
[`PhysicsBackend.train`][tableclean_suite.physics_backend.PhysicsBackend.train] spreads runs over worker processes, each training its share with
[`tableclean_suite.learners.stepper.train_run`][tableclean_suite.learners.stepper.train_run].

Faults and failures (the policy, documented once here)
------------------------------------------------------
- *Skill failure with a readable state* (e.g. a wipe that left too much dirt): this is what
  physics did, so the learner sees the observed state and the outcome
  [`TaskModel.classify`][tableclean_suite.task.model.TaskModel.classify] gives it.  Counted in ``stats["skill_failures"]``.
- *Abstraction fault* (the scene maps to no task state: object dropped between segments,
  sponge not back home, instability, ...): the observed result is not a task state, so it is
  never mapped to one.  The scene is restored to the snapshot taken before the action (the
  last good state) and the action is executed again, up to ``max_retries`` times; each fault is
  counted in ``stats["faults"]`` (and by kind in ``stats["fault_reasons"]``).  If every retry
  faults, [`PhysicsFaultError`][tableclean_suite.physics_backend.PhysicsFaultError] is raised (``fault_policy="raise"`` raises at the first
  fault).  The learner therefore only ever sees physically observed task states.

The counters of a physics training (summed over runs) come back under the key ``"stats"``
(``TrainingResult.info["physics"]`` when called through ``train``): ``steps`` (learner
iterations), ``executions`` (skill executions incl. retries), ``skill_failures``, ``faults``,
``fault_reasons`` (dict), ``restages``, ``control_steps``, ``wall_time`` (seconds spent in
physics steps), ``workers``.
"""

from __future__ import annotations

import contextlib
import json
import os
from collections import Counter
from dataclasses import dataclass

import numpy as np

from tableclean_suite.executors.base import check_count
from tableclean_suite.executors.blas import single_blas_thread
from tableclean_suite.learners.rng import run_key
from tableclean_suite.task import HELD, Action, TaskModel, TaskState, as_state

#: Values of ``PhysicsStepEnv(fault_policy=...)``.
FAULT_POLICIES = ("retry", "raise")
#: Keys accepted in ``train(..., physics_options=...)``.
PHYSICS_OPTIONS = ("env_kwargs", "skill_configs", "fault_policy", "max_retries")


class PhysicsFaultError(RuntimeError):
    """The physics could not produce a task state for an action, even after retries."""


class StagingError(RuntimeError):
    """The scene could not be put into the requested task state."""


def start_of(state: TaskState) -> tuple[tuple[int, ...], int, tuple[int, ...], tuple[int, ...]]:
    """``(object_segments, arm_segment, dirty_segments, deferred)`` of the reset that stages ``state``.

    Segment numbers are 1-based.  A held object starts on the arm's segment and is picked
    after the reset; PICK takes the lowest-numbered object there, so the objects numbered
    below it that lie on the arm's segment start on the next segment instead and are put
    back onto the arm's segment after the pick (``deferred``, 0-based object indices).
    """
    arm = state.arm
    held = state.held_object
    other = (arm + 1) % state.n_segments
    segments, deferred = [], []
    for j, where in enumerate(state.objects):
        if where == HELD:
            segments.append(arm + 1)
        elif held is not None and where == arm and j < held:
            segments.append(other + 1)
            deferred.append(j)
        else:
            segments.append(where + 1)
    dirty = tuple(k + 1 for k in range(state.n_segments) if not state.is_clean(k))
    return tuple(segments), arm + 1, dirty, tuple(deferred)


def stage(env, controller, state, seed: int | None = None) -> TaskState:
    """Reset ``env`` so that its symbolic state is ``state`` (a held object is picked up; see [`start_of`][tableclean_suite.physics_backend.start_of]).

    ``state`` is a [`TaskState`][tableclean_suite.task.state.TaskState] or a code of the controller's model.  ``seed`` re-seeds the
    env's placement randomness first (None: continue its stream).  Raises [`StagingError`][tableclean_suite.physics_backend.StagingError]
    when the abstraction does not read back ``state``.
    """
    model = getattr(controller, "model", None)
    state = model.as_state(state) if isinstance(model, TaskModel) else as_state(state)
    if state.is_terminal:
        raise StagingError(f"cannot stage the terminal state {state.index} ({state.name})")
    objects, arm, dirty, deferred = start_of(state)
    if seed is not None:
        env.rng = np.random.default_rng(seed)
    env.set_start(None, arm, dirty, object_segments=objects)
    env.reset()
    if state.holding:
        result = controller.execute(Action.PICK)
        if not result.success:
            raise StagingError(f"staging {state.name}: the pick failed ({result.reason})")
        for j in deferred:
            env.put_object(j, state.arm)
    try:
        reached = env.symbolic_state()
    except Exception as error:  # AbstractionError: report it as a staging problem
        raise StagingError(f"staging {state.name}: abstraction fault ({error})") from error
    if reached != state:
        raise StagingError(f"staging {state.name}: the scene reads as {reached.name}")
    return reached


#: ``make_skill_env`` arguments that give a start layout ([`staging_env_kwargs`][tableclean_suite.physics_backend.staging_env_kwargs]).
LAYOUT_ARGUMENTS = ("object_segment", "arm_segment", "object_segments")


def staging_env_kwargs(model: TaskModel, env_kwargs: dict | None) -> dict:
    """The ``make_skill_env`` arguments of a scene whose every reset is staged
    ([`stage`][tableclean_suite.physics_backend.stage]): ``env_kwargs`` with ``task`` defaulting to
    ``model``'s spec and, without a layout (`LAYOUT_ARGUMENTS`), `DEFAULT_LAYOUT` (the spec's start
    may hold an object, which the scene's start refuses)."""
    from tableclean_suite.controllers.make import DEFAULT_LAYOUT

    kwargs = dict(env_kwargs or {})
    kwargs.setdefault("task", model.spec)
    if not set(LAYOUT_ARGUMENTS) & set(kwargs):
        kwargs.update(zip(("object_segment", "arm_segment"), DEFAULT_LAYOUT))
    return kwargs


class PhysicsStepEnv:
    """Skills in MuJoCo as a step environment for [`train_run`][tableclean_suite.learners.stepper.train_run].

    ``reset(draw)`` stages the model's start state picked by ``draw`` (a both-unclean layout
    -> the env's ``object_segment``/``arm_segment``); ``step(state, action, draw)`` executes
    ``action`` with the SkillController and returns ``(state_after.index, outcome)``.
    Faults and failures: see the module docstring.

    Args:
        model: the task model (start states, rules the controller follows).
        env_kwargs: arguments for [`make_skill_env`][tableclean_suite.controllers.make.make_skill_env] (robosuite.make),
            e.g. ``{"robots": "UR5e"}`` (robots with a registered skill config,
            [`supported_robots`][tableclean_suite.environments.robot_registry.supported_robots]).
        skill_configs: per-action skill config overrides for the SkillController.
        fault_policy: ``"retry"`` (default) or ``"raise"``.
        max_retries: re-executions of an action after a fault before giving up (>= 0).
        env: an already made env to use instead of making one.
    """

    def __init__(self, model: TaskModel | None = None, env_kwargs: dict | None = None, skill_configs=None,
                 fault_policy: str = "retry", max_retries: int = 3, env=None):
        from tableclean_suite.controllers import SkillController, make_skill_env

        if fault_policy not in FAULT_POLICIES:
            raise ValueError(f"unknown fault_policy {fault_policy!r}; allowed: {', '.join(FAULT_POLICIES)}")
        check_count("max_retries", max_retries, 0)
        self.model = model if model is not None else TaskModel()
        check_physical_task(self.model, (env_kwargs or {}).get("task_config"))
        self.env = env if env is not None else make_skill_env(**staging_env_kwargs(self.model, env_kwargs))
        self.controller = SkillController(self.env, self.model, skill_configs=skill_configs)
        self.fault_policy = fault_policy
        self.max_retries = int(max_retries)
        self.stats = _empty_stats()

    def close(self) -> None:
        """Close the scene (its MuJoCo simulation and renderers)."""
        self.env.close()

    def seed(self, seed: int) -> None:
        """Re-seed the scene's placement randomness (object placement, arm initialisation noise)."""
        self.env.rng = np.random.default_rng(seed)

    def reset(self, draw: float) -> int:
        state = self.model.sample_start(draw)
        stage(self.env, self.controller, state)
        self.stats["restages"] += 1
        return state.index

    def step(self, state: int, action: int, draw: float) -> tuple[int, int]:
        before = self.model.as_state(state)
        try:
            current = self.env.symbolic_state()
        except Exception as error:  # noqa: BLE001 - reported, never mapped
            current = f"a fault ({error})"
        if current != before:
            raise PhysicsFaultError(f"the scene reads {current}, but the learner is in state {before.name}")
        saved = self.env.get_scene_state()
        for attempt in range(self.max_retries + 1):
            if attempt:
                self.env.set_scene_state(saved)
            result = self.controller.execute(int(action))
            self.stats["executions"] += 1
            self.stats["control_steps"] += result.steps
            self.stats["wall_time"] += result.wall_time
            if result.state_after is not None:
                if not result.success and not result.improper:
                    self.stats["skill_failures"] += 1
                return result.state_after.index, int(result.outcome)
            self.stats["faults"] += 1
            self.stats["fault_reasons"][_reason_kind(result.reason)] += 1
            if self.fault_policy == "raise":
                break
        raise PhysicsFaultError(
            f"{self.model.action_name(int(action))} from {before.name}: abstraction fault on every attempt "
            f"({result.reason})"
        )


def _reason_kind(reason: str) -> str:
    """A short key of a fault reason, e.g. 'fault: object_between_segments: ...' -> 'object_between_segments'."""
    text = reason.split("fault", 1)[-1].lstrip(": ").strip()
    for prefix in ("before the action: ", "fault: "):
        if text.startswith(prefix):
            text = text[len(prefix):]
    return text.split(":", 1)[0].strip() or "unknown"


def _empty_stats() -> dict:
    return {
        "steps": 0, "executions": 0, "skill_failures": 0, "faults": 0, "fault_reasons": Counter(),
        "restages": 0, "control_steps": 0, "wall_time": 0.0,
    }


def merge_stats(parts) -> dict:
    """Counters of several runs or chunks summed (``fault_reasons`` by kind); ``workers``: the largest."""
    total = _empty_stats()
    for part in parts:
        for key, value in part.items():
            if key == "workers":
                total[key] = max(total.get(key) or 0, value or 0)
            elif key == "fault_reasons":
                total[key].update(value)
            else:
                total[key] += value
    total["fault_reasons"] = dict(total["fault_reasons"])
    return total


@dataclass(frozen=True)
class PhysicsRun:
    """One run of physics training as an executor task: plain values (the worker builds its own scene).

    Attributes:
        learner, reward: the configured `TabularLearner` and `RewardPattern` (picklable).
        spec: the task spec as JSON text (``TaskSpec.to_dict()``).
        index: the run's index in this call (0-based); its random key is ``(seed, first_run + index)``.
        iterations, seed, first_run: as in the [TrainingJob][tableclean_suite.backends.TrainingJob].
        options: the ``PhysicsStepEnv`` options (``physics_options``) as sorted items.
        hyper: ``alpha, gamma, epsilon, max_itr`` as sorted items.
        checkpoint: also keep the Q-table after this many iterations (0: none).
    """

    learner: object
    reward: object
    spec: str
    index: int
    iterations: int
    seed: int
    first_run: int
    options: tuple
    hyper: tuple
    checkpoint: int = 0

    @property
    def label(self) -> str:
        return f"physics run {self.first_run + self.index} ({self.learner.name}/{self.reward.name})"


def _train_one(env: "PhysicsStepEnv", task: PhysicsRun, on_step=None) -> tuple[int, dict, dict]:
    """Train ``task``'s run on ``env``, its scene reseeded from the run's key; ``(index, record, counters)``."""
    from tableclean_suite.learners.stepper import train_run

    run = task.first_run + task.index
    env.stats = _empty_stats()
    env.seed(run_key(task.seed, run))
    with single_blas_thread():  # the same bits in this process, a local worker or a Ray worker
        record = train_run(env, task.learner, task.reward, task.iterations, seed=task.seed, run=run, on_step=on_step,
                           checkpoint=task.checkpoint, **dict(task.hyper))
    env.stats["steps"] += task.iterations
    stats = dict(env.stats)
    stats["fault_reasons"] = dict(stats["fault_reasons"])
    return task.index, record, stats


#: PhysicsStepEnvs built in this process by executor tasks, by (spec JSON, options as sorted JSON).
_SESSIONS: dict = {}


def process_session(spec_json: str, options: dict) -> "PhysicsStepEnv":
    """The PhysicsStepEnv of ``spec_json`` (``TaskSpec.to_dict()`` as JSON) and ``options`` in this
    process, built on first use and kept ([`close_sessions`][tableclean_suite.physics_backend.close_sessions] closes them)."""
    import multiprocessing

    from tableclean_suite.task import TaskSpec

    key = (spec_json, json.dumps(options, sort_keys=True, default=repr))
    if key not in _SESSIONS:
        if multiprocessing.parent_process() is not None:  # a worker process: robosuite's start-up lines are noise
            from tableclean_suite.robosuite_adapter import apply_verbosity

            apply_verbosity(False)
        _SESSIONS[key] = PhysicsStepEnv(TaskModel(spec=TaskSpec.from_dict(json.loads(spec_json))), **options)
    return _SESSIONS[key]


def close_sessions() -> None:
    """Close the scenes [`process_session`][tableclean_suite.physics_backend.process_session] built in this process."""
    while _SESSIONS:
        _SESSIONS.popitem()[1].close()


def run_physics_task(task: PhysicsRun):
    """Train one [`PhysicsRun`][tableclean_suite.physics_backend.PhysicsRun] in this process (the scene built once per process and spec,
    [`process_session`][tableclean_suite.physics_backend.process_session]); returns ``(index, record, stats of this run)``."""
    return _train_one(process_session(task.spec, dict(task.options)), task)


def check_physical_task(model: TaskModel, task_config: dict | None = None) -> None:
    """Raise ``ValueError`` when the ``TableClean`` scene cannot build and run ``model``'s spec: up to
    [`max_segments`][tableclean_suite.environments.config.max_segments] segments, objects of registered
    types that fit side by side on a segment, a registered skill
    ([`register_skill`][tableclean_suite.controllers.registry.register_skill]) per action.
    """
    from tableclean_suite.controllers.registry import get_skill_class
    from tableclean_suite.environments.config import make_config, scene_geometry
    from tableclean_suite.environments.objects import get_object_type
    from tableclean_suite.environments.scene_building import check_objects_fit

    spec = model.spec
    config = make_config(task_config)
    try:  # too many segments (a LayoutError), unknown object types, objects that do not fit
        geometry = scene_geometry(config, spec.segments)
        check_objects_fit([get_object_type(config["object_type"] or kind) for kind in spec.objects], geometry, config)
    except ValueError as error:
        raise ValueError(f"task {spec.name!r}: {error}") from None
    missing = []
    for name in spec.actions:
        try:
            get_skill_class(name)
        except KeyError:
            missing.append(name)
    if missing:
        from tableclean_suite.controllers.registry import SKILL_REGISTRY

        raise ValueError(f"task {spec.name!r}: no skill registered for action(s) {missing} (skills: "
                         f"{', '.join(SKILL_REGISTRY)}); add one with tableclean_suite.controllers.register_skill")


class PhysicsBackend:
    """``train(backend="physics")``: skills in MuJoCo (see the module docstring)."""

    name = "physics"
    #: Physics is seeded per run but not bit-reproducible, and a replay costs as much as the run:
    #: the harness does not replay a prefix to measure settling.
    deterministic_prefix = False

    def check_options(self, model: TaskModel, options: dict) -> dict:
        """Accepts ``physics_options`` (see `PHYSICS_OPTIONS`; ``env_kwargs["robots"]``, when given, a robot with a
        registered skill config); refuses specs the scene cannot build.  ``ValueError`` naming what is allowed."""
        unknown = sorted(set(options) - {"physics_options"})
        if unknown:
            raise ValueError(f"backend 'physics': unknown option(s) {unknown}; allowed: 'physics_options' "
                             "(transitions= is only used with backend='calibrated')")
        physics_options = dict(options.get("physics_options") or {})
        unknown = sorted(set(physics_options) - set(PHYSICS_OPTIONS))
        if unknown:
            raise ValueError(f"unknown physics_options key(s) {unknown}; allowed: {', '.join(PHYSICS_OPTIONS)}")
        env_kwargs = physics_options.get("env_kwargs") or {}
        if not isinstance(env_kwargs, dict):
            raise ValueError(f"physics_options env_kwargs must be a dict of make_skill_env arguments, got {env_kwargs!r}")
        if "robots" in env_kwargs:
            from tableclean_suite.controllers.robot_configs import check_robot

            check_robot(env_kwargs["robots"])
        check_physical_task(model, env_kwargs.get("task_config"))
        return {"physics_options": physics_options}

    def train(self, job):
        """Train ``job.runs`` runs with skills in physics (a [TrainingJob][tableclean_suite.backends.TrainingJob]).

        Run ``i`` uses the run key ``(seed, first_run + i)`` and a scene seeded from it, whichever
        worker trains it.  ``job.workers`` (default ``os.cpu_count()``, at most ``runs``): with one,
        everything runs here; else each run is a [`PhysicsRun`][tableclean_suite.physics_backend.PhysicsRun]
        task of ``job.executor`` (default ``LocalExecutor(workers)``: spawned processes, so a script
        needs the ``if __name__ == "__main__":`` guard).  The counters go to ``info["physics"]``.
        """
        from tableclean_suite.backends import CHECKPOINT_Q, BackendRecords
        from tableclean_suite.learners.stepper import RECORD_FIELDS

        learner, reward, runs, iterations = job.learner, job.reward, job.runs, job.iterations
        options = dict(job.options.get("physics_options") or {})  # checked by check_options
        workers = (os.cpu_count() or 1) if job.workers is None else job.workers
        check_count("workers", workers, 1)
        workers = min(int(workers), runs)
        bar = None
        if job.progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=runs * iterations, desc=f"{learner.name}/{reward.name} physics", leave=False)
        spec = json.dumps(job.model.spec.to_dict(), sort_keys=True)
        tasks = [PhysicsRun(learner, reward, spec, i, iterations, job.seed, job.first_run,
                            tuple(sorted(options.items())), tuple(sorted(job.hyperparameters.items())),
                            job.checkpoint) for i in range(runs)]
        results = []  # (index, record, stats) of each run
        if workers == 1 and job.executor is None:
            env = PhysicsStepEnv(job.model, **options)
            try:
                results = [_train_one(env, task, None if bar is None else (lambda t: bar.update(1))) for task in tasks]
            finally:
                env.close()
        else:
            from tableclean_suite.executors import LocalExecutor

            # a caller's executor stays open for the caller's next call (map starts what it needs)
            owned = LocalExecutor(workers=workers) if job.executor is None else contextlib.nullcontext(job.executor)
            with owned as running:
                for result in running.map(run_physics_task, tasks):
                    results.append(result)
                    if bar is not None:
                        bar.update(iterations)
        if bar is not None:
            bar.close()
        ordered = [record for _, record, _ in sorted(results, key=lambda result: result[0])]
        records = {name: np.stack([record[name] for record in ordered])
                   for name in (*RECORD_FIELDS, "q", "first_learned_at", "learned_at")}
        stats = merge_stats(run_stats for _, _, run_stats in results)
        stats["workers"] = workers
        info = {"physics": stats}
        if job.checkpoint:
            info[CHECKPOINT_Q] = np.stack([record[CHECKPOINT_Q] for record in ordered])
        return BackendRecords(**records, info=info)


PHYSICS = PhysicsBackend()
