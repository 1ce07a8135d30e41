"""``train()``: the stable entry point for training tabular learners on a task.

The task is a [`TaskSpec`][tableclean_suite.task.spec.TaskSpec] (``task=``: a registered name,
a spec, a ``.json`` path or a [`TaskModel`][tableclean_suite.task.model.TaskModel]; default
``paper``).  Where the steps come from is a *backend* looked up by name in
[`tableclean_suite.backends`][tableclean_suite.backends] (``"symbolic"``, ``"calibrated"``, ``"physics"`` or a
user's); this module imports none of them.

``engine="reference"`` runs the table backends through the plain per-step Python loop
instead of the compiled one (same numbers, much slower).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from tableclean_suite.backends import BackendRecords, TrainingJob, backend_names, get_backend
from tableclean_suite.learners.checks import check_number
from tableclean_suite.learners.exploration import Exploration, as_exploration
from tableclean_suite.learners.optimality import NOT_LEARNED
from tableclean_suite.learners.rules import TabularLearner, get_learner
from tableclean_suite.learners.transitions import TransitionTable
from tableclean_suite.rewards import RewardPattern, get_reward_pattern
from tableclean_suite.task import TaskModel, TaskSpec, as_task_model

#: The built-in backends' names (``tableclean_suite.backends.backend_names()`` lists user ones too).
BACKENDS = ("symbolic", "calibrated", "physics")
ENGINES = ("compiled", "reference")


@dataclass
class TrainingResult(BackendRecords):
    """Everything one ``train()`` call recorded: the fields of
    [BackendRecords][tableclean_suite.backends.BackendRecords] (records, Q-tables, ``config``, ``info``),
    with the call's arguments in ``config``, and each run's learning time.

    A run's greedy policy is *optimal* when, in the task model's deterministic transitions,
    its greedy action (the training loop's choice when not exploring, on the Q row the learner
    acts on, with the call's tie rule) leads from every start state of the task to the terminal
    state in exactly the shortest-plan number of steps of that start
    ([optimality][tableclean_suite.learners.optimality]); for the calibrated backend too, the
    model's transitions judge it.  It is checked before the first step and after every
    iteration's Q update.

    Attributes:
        first_learned_at: ``(R,)`` int64, per run the first iteration t in [1, T] (1-based count
            of environment steps, the unit of ``iterations``) after whose update the greedy
            policy is optimal; 0 when the initial Q-table's already is; -1 when it never is.
        learned_at: ``(R,)`` int64, per run the iteration in [0, T] from which the greedy policy
            is optimal after every update up to T = ``iterations``: 1 + the last iteration at
            which it was not (0: optimal throughout); -1 when it is not optimal after iteration
            T (the run is censored at T).  Always ``learned_at >= first_learned_at`` where both
            are set.  Neither depends on batching (``first_run``) or the engine.
    """

    @property
    def runs(self) -> int:
        return int(self.rewards.shape[0])

    @property
    def iterations(self) -> int:
        return int(self.rewards.shape[1])

    def episodes(self):
        """One row per finished episode: a `pandas.DataFrame` with columns
        ``run, episode, first_iteration, last_iteration, length, return, average_reward,
        reached_terminal, improper_actions, success`` (iterations 0-based)."""
        from tableclean_suite.curves import episode_table

        return episode_table(self)




def validate_hyperparameters(runs, iterations, alpha, gamma, epsilon, max_itr, seed) -> None:
    """Raise ``ValueError`` naming the first out-of-range argument and its allowed range."""
    check_number("runs", runs, 1, 10**7, integer=True)
    check_number("iterations", iterations, 1, 10**8, integer=True)
    check_number("alpha", alpha, 0, 1, low_open=True)
    check_number("gamma", gamma, 0, 1)
    check_number("epsilon", epsilon, 0, 1)
    check_number("max_itr", max_itr, 1, 10**8, integer=True)
    check_number("seed", seed, 0, 2**63 - 1, integer=True)


def train(
    learner: str | TabularLearner = "q_learning",
    reward: str | RewardPattern = "r4",
    runs: int = 1000,
    iterations: int = 3000,
    alpha: float = 0.3,
    gamma: float = 0.3,
    epsilon: float = 0.1,
    max_itr: int = 500,
    seed: int = 0,
    model: TaskModel | None = None,
    backend: str = "symbolic",
    transitions: TransitionTable | str | None = None,
    engine: str = "compiled",
    first_run: int = 0,
    workers: int | None = None,
    physics_options: dict | None = None,
    progress: bool = False,
    task: "TaskModel | TaskSpec | str | None" = None,
    learner_options: dict | None = None,
    q_init: float | None = None,
    exploration: "str | Exploration | Mapping | None" = None,
    executor=None,
    checkpoint: int = 0,
    ties: str | None = None,
) -> TrainingResult:
    """Train ``runs`` independent learners for ``iterations`` environment steps each.

    Args:
        learner: registered name (``"q_learning"``, ``"sarsa"``, ``"expected_sarsa"``,
            or a user's) or a [`TabularLearner`][tableclean_suite.learners.rules.TabularLearner].
        reward: registered pattern name (``"r1"`` .. ``"r4"`` or a user's) or a
            [`RewardPattern`][tableclean_suite.rewards.RewardPattern].
        runs: independent runs (>= 1), batched.
        iterations: environment steps per run, counted across episodes (>= 1).
        alpha: learning rate in (0, 1].
        gamma: discount factor in [0, 1].
        epsilon: exploration rate in [0, 1]; random actions are uniform over the task's actions.
        max_itr: iterations after which an episode is truncated (>= 1).
        seed: non-negative integer; run ``i`` uses the key of (seed, first_run + i),
            so results do not depend on batching.
        model: deprecated (``DeprecationWarning``): the old name of ``task=``.
        backend: a registered backend name (``"symbolic"``, ``"calibrated"``, ``"physics"``).
        transitions: for ``"calibrated"``: a [`TransitionTable`][tableclean_suite.learners.transitions.TransitionTable] or a JSON path.
        engine: ``"compiled"`` (default) or ``"reference"`` (plain Python loop).  The compiled
            loop of the table backends trains the runs on ``numba.get_num_threads()`` threads
            (the calling thread's count: ``numba.set_num_threads``); the numbers never depend on it.
        first_run: index of the first run (to extend an experiment with more runs).
        workers: processes for the physics backend (default: CPU count).
        physics_options: keyword arguments for the physics step environment.
        progress: show a tqdm progress bar.
        task: the task: a registered spec name, a [`TaskSpec`][tableclean_suite.task.spec.TaskSpec], a ``.json`` path
            or a [`TaskModel`][tableclean_suite.task.model.TaskModel] (default: the ``paper`` spec).
        learner_options: the learner's update-rule parameters: ``q_lambda`` / ``sarsa_lambda``
            take ``lambda_`` (in [0, 1], default 0.9) and ``trace`` (``"replacing"``, default,
            or ``"accumulating"``); ``dyna_q`` takes ``planning_steps`` (integer in [0, 10000],
            default 5).  Others take none (``ValueError`` names what is allowed).
        q_init: initial value of every Q entry, a float in [-1e6, 1e6] (``rewards.MAX_REWARD``; default: the learner's,
            0.0 for the registered ones, the paper's); larger than the best return is optimistic.
        exploration: the behaviour policy, independent of the learner: a registered name
            (``"epsilon_greedy"`` default, ``"linear_decay"``, ``"exponential_decay"``,
            ``"visit_decay"``, ``"softmax"``), an [`Exploration`][tableclean_suite.learners.exploration.Exploration]
            or a mapping ``{"name": ..., **parameters}``.  Epsilon schedules start at ``epsilon``.
        executor: a [`tableclean_suite.executors`][tableclean_suite.executors] executor for the physics backend's runs
            (e.g. ``RayExecutor(address=...)``); default: ``workers`` local processes.
        checkpoint: also keep each run's Q-tables after this many iterations, an integer in
            [0, iterations] (0: none), in ``result.info["checkpoint_q"]`` ``(runs, S, A)``: the
            final Q-tables of the same call with ``iterations=checkpoint``, from the same pass.
            The built-in backends and both engines keep them; a user's backend that cannot
            leaves the key out.
        ties: the greedy choice's tie rule: ``"first"`` (the paper's: the first action in the task's
            order) or ``"random"`` (uniform among the tied actions, from a random stream of its
            own, so results still do not depend on batching); None (default): the learner's,
            ``"first"`` unless ``learner_options={"ties": ...}`` says otherwise.  Softmax
            exploration has no greedy choice to break; the learning times use the same rule.

    Returns:
        A [`TrainingResult`][tableclean_suite.learners.train.TrainingResult] with ``(runs, iterations)`` records and final Q-tables.

    Raises:
        tableclean_suite.task.model.UnlearnableTaskError: no terminal state can be reached from a start
            state (the table backends check it, after the resource guard).
        tableclean_suite.resources.ResourceError: the training would not fit or take too long; a user
            action's effect fails (``ActionEffectError``).
    """
    learner = get_learner(learner)
    reward = get_reward_pattern(reward)
    validate_hyperparameters(runs, iterations, alpha, gamma, epsilon, max_itr, seed)
    learner = configure_learner(learner, learner_options, q_init, exploration, epsilon, ties)
    check_number("first_run", first_run, 0, 2**62, integer=True)
    check_number("checkpoint", checkpoint, 0, iterations, integer=True)
    if engine not in ENGINES:
        raise ValueError(f"unknown engine {engine!r}; allowed: {', '.join(ENGINES)}")
    if model is not None:
        warnings.warn("train(model=...) is deprecated; pass the task as task=", DeprecationWarning, stacklevel=2)
        if task is not None:
            raise ValueError("give the task as task= or model=, not both")
        task = model
    model = as_task_model(task)
    chosen = get_backend(backend)  # ValueError names the registered backends
    options = {"transitions": transitions} if transitions is not None or chosen.name == "calibrated" else {}
    if physics_options is not None:
        options["physics_options"] = physics_options
    options = chosen.check_options(model, options)
    job = TrainingJob(
        learner=learner, reward=reward, model=model, runs=int(runs), iterations=int(iterations),
        alpha=float(alpha), gamma=float(gamma), epsilon=float(epsilon), max_itr=int(max_itr), seed=int(seed),
        first_run=int(first_run), engine=engine, workers=workers, options=options, progress=progress,
        executor=executor, checkpoint=int(checkpoint),
    )
    config = {
        "learner": learner.name,
        "learner_settings": learner.settings(),
        "reward": reward.name,
        "runs": job.runs,
        "iterations": job.iterations,
        "alpha": job.alpha,
        "gamma": job.gamma,
        "epsilon": job.epsilon,
        "max_itr": job.max_itr,
        "seed": job.seed,
        "first_run": job.first_run,
        "ties": learner.ties,
        "backend": backend,
        "model": repr(model),
        "task": model.spec.to_dict(),
    }
    records = chosen.train(job)
    unknown = np.full(job.runs, NOT_LEARNED, dtype=np.int64)
    learning = {name: unknown if getattr(records, name) is None else getattr(records, name)
                for name in ("first_learned_at", "learned_at")}
    return TrainingResult(**{**vars(records), **learning, "config": {**config, **records.config}})


def configure_learner(learner: TabularLearner, learner_options: dict | None, q_init: float | None,
                      exploration, epsilon: float, ties: str | None = None) -> TabularLearner:
    """``learner`` with ``train()``'s ``learner_options``, ``q_init``, ``exploration`` and ``ties`` applied and validated."""
    if learner_options is not None and not isinstance(learner_options, Mapping):
        raise ValueError(f"learner_options must be a dict of option -> value, got {learner_options!r}")
    if ties is not None:
        if learner_options and learner_options.get("ties", ties) != ties:
            raise ValueError(f"ties={ties!r} and learner_options ties={learner_options['ties']!r} disagree; give one")
        learner_options = {**(learner_options or {}), "ties": ties}
    chosen = None if exploration is None else as_exploration(exploration)
    learner = learner.configured(learner_options, q_init, chosen)
    learner.exploration.check(float(epsilon))
    return learner


def available_backends() -> list[str]:
    """Registered backend names (built-in and users')."""
    return backend_names()
