"""``train()``: the stable entry point for training tabular learners on a task.

The task is a [`TaskSpec`][tableclean_suite.task.spec.TaskSpec] (``task=``: a registered name,
a spec, a ``.json`` path or a [`TaskModel`][tableclean_suite.task.model.TaskModel]; default
``paper``).  Where the steps come from is a *backend* looked up by name in
[`tableclean_suite.backends`][tableclean_suite.backends] (``"symbolic"``, ``"calibrated"``, ``"physics"`` or a
user's).  The learner's hyper-parameters form a [`LearnerSettings`][tableclean_suite.learners.train.LearnerSettings]
record and the execution options a [`RunOptions`][tableclean_suite.learners.train.RunOptions] record; ``train()``
also takes each of their fields as a keyword.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from tableclean_suite.backends import BackendRecords, TrainingJob, get_backend
from tableclean_suite.learners.checks import check_number
from tableclean_suite.learners.exploration import Exploration, as_exploration
from tableclean_suite.learners.optimality import NOT_LEARNED
from tableclean_suite.learners.rules import TabularLearner, get_learner
from tableclean_suite.learners.transitions import TransitionTable
from tableclean_suite.rewards import RewardPattern, get_reward_pattern
from tableclean_suite.task import TaskModel, TaskSpec, as_task_model

ENGINES = ("compiled", "reference")


@dataclass
class TrainingResult(BackendRecords):
    """Everything one ``train()`` call recorded: the fields of
    [BackendRecords][tableclean_suite.backends.BackendRecords] (records, Q-tables, ``config``, ``info``),
    with the call's arguments in ``config``, and each run's learning time: the iterations after which its
    greedy policy is *optimal* ([optimality][tableclean_suite.learners.optimality]).

    Attributes:
        first_learned_at: ``(R,)`` int64, per run the first iteration t in [1, T] after whose update
            the greedy policy is optimal; 0 when the initial Q-table's already is; -1 when it never is.
        learned_at: ``(R,)`` int64, per run the iteration in [0, T] from which the greedy policy
            is optimal after every update up to T = ``iterations``; -1 when it is not optimal after
            iteration T (censored).  ``learned_at >= first_learned_at`` where both are set.
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
    LearnerSettings(alpha=alpha, gamma=gamma, epsilon=epsilon, max_itr=max_itr)
    check_number("seed", seed, 0, 2**63 - 1, integer=True)


@dataclass(frozen=True)
class LearnerSettings:
    """The learner's hyper-parameters of a [`train`][tableclean_suite.learners.train.train] call.

    Attributes:
        alpha: learning rate in (0, 1].
        gamma: discount factor in [0, 1].
        epsilon: exploration rate in [0, 1] (the start value of an epsilon schedule); random actions
            are uniform over the task's actions.
        max_itr: iterations after which an episode is truncated (>= 1).
        learner_options: the learner's update-rule parameters: ``q_lambda`` / ``sarsa_lambda``
            take ``lambda_`` (in [0, 1], default 0.9) and ``trace`` (``"replacing"``, default,
            or ``"accumulating"``); ``dyna_q`` takes ``planning_steps`` (integer in [0, 10000],
            default 5); any learner takes ``ties``.
        q_init: initial value of every Q entry, in [-1e6, 1e6]; None: the learner's (0.0 for the
            registered ones, the paper's).
        exploration: the behaviour policy: a registered name (``"epsilon_greedy"`` default,
            ``"linear_decay"``, ``"exponential_decay"``, ``"visit_decay"``, ``"softmax"``), an
            [`Exploration`][tableclean_suite.learners.exploration.Exploration] or a mapping
            ``{"name": ..., **parameters}``.
        ties: the greedy choice's tie rule: ``"first"`` (the paper's: the first action in the task's
            order) or ``"random"`` (uniform among the tied actions, from a stream of its own);
            None: the learner's.

    Raises:
        ValueError: a value out of its range (the learner-specific ones when ``train`` applies them).
    """

    alpha: float = 0.3
    gamma: float = 0.3
    epsilon: float = 0.1
    max_itr: int = 500
    learner_options: Mapping | None = None
    q_init: float | None = None
    exploration: str | Exploration | Mapping | None = None
    ties: str | None = None

    def __post_init__(self):
        check_number("alpha", self.alpha, 0, 1, low_open=True)
        check_number("gamma", self.gamma, 0, 1)
        check_number("epsilon", self.epsilon, 0, 1)
        check_number("max_itr", self.max_itr, 1, 10**8, integer=True)
        if self.learner_options is not None and not isinstance(self.learner_options, Mapping):
            raise ValueError(f"learner_options must be a dict of option -> value, got {self.learner_options!r}")

    def configure(self, learner: TabularLearner) -> TabularLearner:
        """``learner`` with ``learner_options``, ``q_init``, ``exploration`` and ``ties`` applied and validated."""
        options, ties = self.learner_options, self.ties
        if ties is not None:
            if options and options.get("ties", ties) != ties:
                raise ValueError(f"ties={ties!r} and learner_options ties={options['ties']!r} disagree; give one")
            options = {**(options or {}), "ties": ties}
        chosen = None if self.exploration is None else as_exploration(self.exploration)
        learner = learner.configured(options, self.q_init, chosen)
        learner.exploration.check(float(self.epsilon))
        return learner


@dataclass(frozen=True)
class RunOptions:
    """How a [`train`][tableclean_suite.learners.train.train] call runs; none of these changes the numbers.

    Attributes:
        engine: ``"compiled"`` (default: the batched loop, on ``numba.get_num_threads()`` threads)
            or ``"reference"`` (one step at a time from Python; the same arrays).
        first_run: index of the first run, >= 0: run ``i`` uses the key of (seed, first_run + i).
        workers: processes for the physics backend (default: CPU count).
        executor: a [`tableclean_suite.executors`][tableclean_suite.executors] executor for the physics
            backend's runs (e.g. ``RayExecutor(address=...)``); default: ``workers`` local processes.
        progress: show a tqdm progress bar.
        checkpoint: also keep each run's Q-tables after this many iterations, in [0, iterations]
            (0: none), in ``result.info["checkpoint_q"]`` ``(runs, S, A)``.
        transitions: for ``"calibrated"``: a [`TransitionTable`][tableclean_suite.learners.transitions.TransitionTable]
            or a JSON path.
        physics_options: keyword arguments of the physics backend's step environment.

    Raises:
        ValueError: an unknown engine, or ``first_run`` / ``checkpoint`` not a non-negative integer.
    """

    engine: str = "compiled"
    first_run: int = 0
    workers: int | None = None
    executor: Any = None
    progress: bool = False
    checkpoint: int = 0
    transitions: TransitionTable | str | None = None
    physics_options: dict | None = None

    def __post_init__(self):
        if self.engine not in ENGINES:
            raise ValueError(f"unknown engine {self.engine!r}; allowed: {', '.join(ENGINES)}")
        check_number("first_run", self.first_run, 0, 2**62, integer=True)
        check_number("checkpoint", self.checkpoint, 0, 10**8, integer=True)


SETTINGS_FIELDS = tuple(f.name for f in fields(LearnerSettings))
OPTIONS_FIELDS = tuple(f.name for f in fields(RunOptions))


def train(
    learner: str | TabularLearner = "q_learning",
    reward: str | RewardPattern = "r4",
    runs: int = 1000,
    iterations: int = 3000,
    *,
    seed: int = 0,
    task: TaskModel | TaskSpec | str | None = None,
    backend: str = "symbolic",
    settings: LearnerSettings | None = None,
    options: RunOptions | None = None,
    **keywords,
) -> TrainingResult:
    """Train ``runs`` independent learners for ``iterations`` environment steps each.

    Args:
        learner: registered name (``"q_learning"``, ``"sarsa"``, ``"expected_sarsa"``,
            or a user's) or a [`TabularLearner`][tableclean_suite.learners.rules.TabularLearner].
        reward: registered pattern name (``"r1"`` .. ``"r4"`` or a user's) or a
            [`RewardPattern`][tableclean_suite.rewards.RewardPattern].
        runs: independent runs (>= 1), batched.
        iterations: environment steps per run, counted across episodes (>= 1).
        seed: non-negative integer; run ``i`` uses the key of (seed, first_run + i),
            so results do not depend on batching.
        task: a registered spec name, a [`TaskSpec`][tableclean_suite.task.spec.TaskSpec], a ``.json`` path
            or a [`TaskModel`][tableclean_suite.task.model.TaskModel] (default: the ``paper`` spec).
        backend: a registered backend name (``"symbolic"``, ``"calibrated"``, ``"physics"``).
        settings: the learner's hyper-parameters, a [`LearnerSettings`][tableclean_suite.learners.train.LearnerSettings].
        options: how the call runs, a [`RunOptions`][tableclean_suite.learners.train.RunOptions].
        **keywords: any field of either record (``alpha=``, ``epsilon=``, ``engine=``, ...), overriding the
            record's; ``model=`` is a deprecated (``DeprecationWarning``) name of ``task=``.

    Returns:
        A [`TrainingResult`][tableclean_suite.learners.train.TrainingResult] with ``(runs, iterations)`` records and final Q-tables.

    Raises:
        TypeError: an unknown keyword (the message lists the allowed ones).
        ValueError: a value out of its range, an unknown name (learner, reward, backend, engine).
        tableclean_suite.task.model.UnlearnableTaskError: no terminal state can be reached from a start
            state (the table backends check it, after the resource guard).
        tableclean_suite.resources.ResourceError: the training would not fit or take too long; a user
            action's effect fails (``ActionEffectError``).
    """
    settings, options, task = _records(settings, options, task, keywords)
    learner = get_learner(learner)
    reward = get_reward_pattern(reward)
    validate_hyperparameters(runs, iterations, settings.alpha, settings.gamma, settings.epsilon, settings.max_itr, seed)
    learner = settings.configure(learner)
    check_number("checkpoint", options.checkpoint, 0, iterations, integer=True)
    model = as_task_model(task)
    chosen = get_backend(backend)  # ValueError names the registered backends
    backend_options = {}
    if options.transitions is not None or chosen.name == "calibrated":
        backend_options["transitions"] = options.transitions
    if options.physics_options is not None:
        backend_options["physics_options"] = options.physics_options
    job = TrainingJob(
        learner=learner, reward=reward, model=model, runs=int(runs), iterations=int(iterations),
        alpha=float(settings.alpha), gamma=float(settings.gamma), epsilon=float(settings.epsilon),
        max_itr=int(settings.max_itr), seed=int(seed), first_run=int(options.first_run), engine=options.engine,
        workers=options.workers, options=chosen.check_options(model, backend_options), progress=options.progress,
        executor=options.executor, checkpoint=int(options.checkpoint),
    )
    numbers = ("runs", "iterations", "alpha", "gamma", "epsilon", "max_itr", "seed", "first_run")
    config = {"learner": learner.name, "learner_settings": learner.settings(), "reward": reward.name,
              **{name: getattr(job, name) for name in numbers}, "ties": learner.ties, "backend": backend,
              "model": repr(model), "task": model.spec.to_dict()}
    records = chosen.train(job)
    unknown = np.full(job.runs, NOT_LEARNED, dtype=np.int64)
    learning = {name: unknown if getattr(records, name) is None else getattr(records, name)
                for name in ("first_learned_at", "learned_at")}
    return TrainingResult(**{**vars(records), **learning, "config": {**config, **records.config}})


def _records(settings, options, task, keywords: dict):
    """``train()``'s records with its loose keywords applied, and the task (``model=`` resolved)."""
    keywords = dict(keywords)
    model = keywords.pop("model", None)
    if model is not None:
        warnings.warn("train(model=...) is deprecated; pass the task as task=", DeprecationWarning, stacklevel=3)
        if task is not None:
            raise ValueError("give the task as task= or model=, not both")
        task = model
    unknown = sorted(set(keywords) - set(SETTINGS_FIELDS) - set(OPTIONS_FIELDS))
    if unknown:
        allowed = ("learner", "reward", "runs", "iterations", "seed", "task", "backend", "settings", "options",
                   *SETTINGS_FIELDS, *OPTIONS_FIELDS)
        raise TypeError(f"train() got unexpected keyword argument(s) {', '.join(unknown)}; allowed: "
                        f"{', '.join(allowed)}")
    settings = replace(settings or LearnerSettings(), **{k: v for k, v in keywords.items() if k in SETTINGS_FIELDS})
    options = replace(options or RunOptions(), **{k: v for k, v in keywords.items() if k in OPTIONS_FIELDS})
    return settings, options, task
