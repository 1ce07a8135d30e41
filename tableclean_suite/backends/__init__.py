"""Training backends: where a learner's steps come from, behind one small interface.

``train(backend="...")`` looks a backend up here by name.  Built in:

- ``"symbolic"``: the task model's deterministic transitions, compiled and batched;
- ``"calibrated"``: a transition table measured from physics, compiled and batched;
- ``"physics"``: skills executed in MuJoCo.

A backend is imported on first use.  Users add one with
[`register_backend`][tableclean_suite.backends.register_backend]: any object with
[`TrainingBackend`][tableclean_suite.backends.TrainingBackend]'s methods.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

#: Name -> ``"module:attribute"`` of the backend object, or the object itself.
_BACKENDS: dict[str, Any] = {
    "symbolic": "tableclean_suite.backends.tabular:SYMBOLIC",
    "calibrated": "tableclean_suite.backends.tabular:CALIBRATED",
    "physics": "tableclean_suite.physics_backend:PHYSICS",
}


#: ``BackendRecords.info`` key of the Q-tables after ``TrainingJob.checkpoint`` iterations
#: (``(R, S, A)``; for double Q the average of its two tables, as ``q``).
CHECKPOINT_Q = "checkpoint_q"


@dataclass(frozen=True)
class TrainingJob:
    """Everything one ``train()`` call asks of a backend (validated by ``train``).

    Attributes:
        learner: the [`TabularLearner`][tableclean_suite.learners.rules.TabularLearner].
        reward: the [`RewardPattern`][tableclean_suite.rewards.RewardPattern].
        model: the [`TaskModel`][tableclean_suite.task.model.TaskModel] (sizes, rules, starts).
        runs, iterations: records are ``(runs, iterations)``.
        alpha, gamma, epsilon: learning rate (0, 1], discount [0, 1], exploration [0, 1].
        max_itr: iterations after which an episode is truncated.
        seed, first_run: run ``i`` uses the random key of ``(seed, first_run + i)``.
        engine: ``"compiled"`` or ``"reference"`` (plain per-step Python loop).
        workers: processes or threads, where the backend uses them (never changes numbers).
        options: backend-specific keyword arguments (e.g. ``transitions``).
        progress: show a progress bar on stderr.
        executor: a [`tableclean_suite.executors`][tableclean_suite.executors] executor for backends that spread work
            over processes or a cluster (the physics backend); None: the backend's default.
        checkpoint: also keep the Q-tables after this many iterations, in [1, iterations]
            (0: none); a backend that can puts them in ``info[CHECKPOINT_Q]`` ``(R, S, A)`` (the
            built-in ones, on both engines), one that cannot leaves them out.
    """

    learner: Any
    reward: Any
    model: Any
    runs: int
    iterations: int
    alpha: float
    gamma: float
    epsilon: float
    max_itr: int
    seed: int
    first_run: int = 0
    engine: str = "compiled"
    workers: int | None = None
    options: dict = field(default_factory=dict)
    progress: bool = False
    executor: Any = None
    checkpoint: int = 0

    @property
    def hyperparameters(self) -> dict:
        """``alpha, gamma, epsilon, max_itr`` as keyword arguments."""
        return dict(alpha=self.alpha, gamma=self.gamma, epsilon=self.epsilon, max_itr=self.max_itr)


@dataclass
class BackendRecords:
    """What a backend returns, and (with the call's config merged in) what ``train()`` returns.

    Attributes (R = runs, T = iterations):
        rewards: ``(R, T)`` float64, the reward of every iteration.
        outcomes: ``(R, T)`` [`Outcome`][tableclean_suite.task.state.Outcome] codes.
        states: ``(R, T)`` state code before each iteration's action.
        actions: ``(R, T)`` action index (the task's action order).
        episode_end: ``(R, T)``, 0 = episode continues, 1 = reached the terminal
            state, 2 = truncated at ``max_itr`` (``kernel.EPISODE_*``).
        q: ``(R, S, A)`` float64 final Q-tables (S states, A actions of the task).
        config: the arguments that produced it (JSON-serialisable); a backend adds its own keys.
        info: backend diagnostics, e.g. ``info["physics"]``: skill executions, failures,
            faults by kind, restages, control steps and wall time of the physics backend.
        first_learned_at, learned_at: ``(R,)`` int64 learning times in iterations
            ([`tableclean_suite.learners.optimality`][tableclean_suite.learners.optimality]; -1: never / censored), or None when
            the backend cannot judge them (``train()`` then reports -1).

    The integer records use the task's ``record_dtype``: int8 for the paper's 24 states,
    wider where the spec needs it.
    """

    rewards: np.ndarray
    outcomes: np.ndarray
    states: np.ndarray
    actions: np.ndarray
    episode_end: np.ndarray
    q: np.ndarray
    config: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)
    first_learned_at: np.ndarray | None = None
    learned_at: np.ndarray | None = None


class TrainingBackend(Protocol):
    """A source of learner steps."""

    name: str
    #: Optional (default False): training the first k iterations reproduces the first k iterations
    #: of a longer run bit for bit, cheaply; the harness then measures settling (tableclean_suite.settling).
    deterministic_prefix: bool

    def check_options(self, model, options: dict) -> dict:
        """Validate backend options (before any training); returns them normalised, or raises ``ValueError``."""

    def train(self, job: TrainingJob) -> BackendRecords:
        """Run ``job`` and return its records."""


def backend_names() -> list[str]:
    """Registered backend names."""
    return list(_BACKENDS)


def register_backend(name: str, backend: Any, overwrite: bool = False) -> None:
    """Add a backend (an object with ``check_options`` and ``train``, or a ``"module:attribute"`` path)."""
    if name in _BACKENDS and not overwrite:
        raise ValueError(f"backend {name!r} is already registered; pass overwrite=True to replace it")
    _BACKENDS[name] = backend


def get_backend(name: str) -> TrainingBackend:
    """The backend registered as ``name`` (imported on first use); ``ValueError`` names the allowed ones."""
    if name not in _BACKENDS:
        raise ValueError(f"unknown backend {name!r}; allowed: {', '.join(_BACKENDS)}")
    backend = _BACKENDS[name]
    if isinstance(backend, str):
        module, attribute = backend.split(":")
        backend = getattr(importlib.import_module(module), attribute)
        _BACKENDS[name] = backend
    return backend
