"""``train()``: the stable entry point for training tabular learners on the task.

Backends:
- ``"symbolic"`` (default): the task model's deterministic table, compiled and
  batched over runs (fast).
- ``"calibrated"``: a :class:`TransitionTable` measured from physics
  (``benchmarks.calibrate``), also compiled.
- ``"physics"``: skills executed in MuJoCo, one step at a time, runs spread over
  worker processes (see :mod:`tableclean_suite.physics_backend`).

``engine="reference"`` runs the symbolic/calibrated backends through the plain
per-step Python loop instead of the compiled one (same numbers, much slower).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tableclean_suite.learners import kernel, reference
from tableclean_suite.learners.rng import run_keys
from tableclean_suite.learners.rules import TabularLearner, get_learner
from tableclean_suite.learners.transitions import TransitionTable
from tableclean_suite.rewards import RewardPattern, get_reward_pattern
from tableclean_suite.task import N_ACTIONS, N_STATES, TaskModel

BACKENDS = ("symbolic", "calibrated", "physics")
ENGINES = ("compiled", "reference")
#: Runs trained per compiled call; only affects progress granularity and peak memory, never the numbers.
RUNS_PER_CHUNK = 256
_RECORD_FIELDS = ("rewards", "outcomes", "states", "actions", "episode_end")


@dataclass
class TrainingResult:
    """Everything one ``train()`` call recorded.

    Attributes (R = runs, T = iterations):
        rewards: ``(R, T)`` float64, the reward of every iteration.
        outcomes: ``(R, T)`` int8 :class:`~tableclean_suite.task.Outcome` codes.
        states: ``(R, T)`` int8 state code before each iteration's action.
        actions: ``(R, T)`` int8 :class:`~tableclean_suite.task.Action` codes.
        episode_end: ``(R, T)`` int8, 0 = episode continues, 1 = reached the terminal
            state, 2 = truncated at ``max_itr`` (``kernel.EPISODE_*``).
        q: ``(R, 24, 4)`` float64 final Q-tables.
        config: the arguments that produced it (JSON-serialisable).
        info: backend diagnostics, e.g. ``info["physics"]``: skill executions, failures,
            faults by kind, restages, control steps and wall time of the physics backend.
    """

    rewards: np.ndarray
    outcomes: np.ndarray
    states: np.ndarray
    actions: np.ndarray
    episode_end: np.ndarray
    q: np.ndarray
    config: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)

    @property
    def runs(self) -> int:
        return int(self.rewards.shape[0])

    @property
    def iterations(self) -> int:
        return int(self.rewards.shape[1])

    def episodes(self):
        """One row per finished episode: a :class:`pandas.DataFrame` with columns
        ``run, episode, first_iteration, last_iteration, length, return, average_reward,
        reached_terminal, improper_actions, success`` (iterations 0-based)."""
        from tableclean_suite.metrics import episode_table

        return episode_table(self)


def _check_number(name, value, low, high, low_open=False, integer=False):
    allowed = f"{'(' if low_open else '['}{low}, {high}]"
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number in {allowed}, got {value!r}")
    if integer and int(value) != value:
        raise ValueError(f"{name} must be an integer in {allowed}, got {value!r}")
    if not math.isfinite(float(value)) or value < low or value > high or (low_open and value == low):
        raise ValueError(f"{name} must be in {allowed}, got {value!r}")


def validate_hyperparameters(runs, iterations, alpha, gamma, epsilon, max_itr, seed) -> None:
    """Raise ``ValueError`` naming the first out-of-range argument and its allowed range."""
    _check_number("runs", runs, 1, 10**7, integer=True)
    _check_number("iterations", iterations, 1, 10**8, integer=True)
    _check_number("alpha", alpha, 0, 1, low_open=True)
    _check_number("gamma", gamma, 0, 1)
    _check_number("epsilon", epsilon, 0, 1)
    _check_number("max_itr", max_itr, 1, 10**8, integer=True)
    _check_number("seed", seed, 0, 2**63 - 1, integer=True)


def _empty_records(runs: int, iterations: int) -> dict[str, np.ndarray]:
    records = {name: np.zeros((runs, iterations), dtype=np.int8) for name in _RECORD_FIELDS}
    records["rewards"] = np.zeros((runs, iterations), dtype=np.float64)
    return records


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
) -> TrainingResult:
    """Train ``runs`` independent learners for ``iterations`` environment steps each.

    Args:
        learner: registered name (``"q_learning"``, ``"sarsa"``, ``"expected_sarsa"``,
            or a user's) or a :class:`TabularLearner`.
        reward: registered pattern name (``"r1"`` .. ``"r4"`` or a user's) or a
            :class:`RewardPattern`.
        runs: independent runs (>= 1), batched.
        iterations: environment steps per run, counted across episodes (>= 1).
        alpha: learning rate in (0, 1].
        gamma: discount factor in [0, 1].
        epsilon: exploration rate in [0, 1]; random actions are uniform over all four.
        max_itr: iterations after which an episode is truncated (>= 1).
        seed: non-negative integer; run ``i`` uses the key of (seed, first_run + i),
            so results do not depend on batching.
        model: the task model (rules, start states); default ``TaskModel()``.
        backend: ``"symbolic"``, ``"calibrated"`` or ``"physics"``.
        transitions: for ``"calibrated"``: a :class:`TransitionTable` or a JSON path.
        engine: ``"compiled"`` (default) or ``"reference"`` (plain Python loop).
        first_run: index of the first run (to extend an experiment with more runs).
        workers: processes for the physics backend (default: CPU count).
        physics_options: keyword arguments for the physics step environment.
        progress: show a tqdm progress bar.

    Returns:
        A :class:`TrainingResult` with ``(runs, iterations)`` records and final Q-tables.
    """
    learner = get_learner(learner)
    reward = get_reward_pattern(reward)
    validate_hyperparameters(runs, iterations, alpha, gamma, epsilon, max_itr, seed)
    _check_number("first_run", first_run, 0, 2**62, integer=True)
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; allowed: {', '.join(BACKENDS)}")
    if engine not in ENGINES:
        raise ValueError(f"unknown engine {engine!r}; allowed: {', '.join(ENGINES)}")
    model = model if model is not None else TaskModel()
    if not isinstance(model, TaskModel):
        raise TypeError(f"model must be a TaskModel, got {type(model).__name__}")
    runs, iterations, max_itr, seed, first_run = int(runs), int(iterations), int(max_itr), int(seed), int(first_run)
    config = {
        "learner": learner.name,
        "reward": reward.name,
        "runs": runs,
        "iterations": iterations,
        "alpha": float(alpha),
        "gamma": float(gamma),
        "epsilon": float(epsilon),
        "max_itr": max_itr,
        "seed": seed,
        "first_run": first_run,
        "backend": backend,
        "model": repr(model),
    }
    hyper = dict(alpha=float(alpha), gamma=float(gamma), epsilon=float(epsilon), max_itr=max_itr)

    if backend == "physics":
        from tableclean_suite.physics_backend import train_physics

        records = train_physics(
            learner, reward, model, runs, iterations, seed, first_run, workers, physics_options or {}, progress, **hyper
        )
        stats = records.pop("stats")
        return TrainingResult(**records, config=config, info={"physics": stats})

    if backend == "calibrated":
        if transitions is None:
            raise ValueError("backend='calibrated' needs transitions= (a TransitionTable or a JSON path)")
        table = transitions if isinstance(transitions, TransitionTable) else TransitionTable.from_json(transitions, model)
        config["transitions"] = table.source
    else:
        if transitions is not None:
            raise ValueError("transitions= is only used with backend='calibrated'")
        table = TransitionTable.from_model(model)

    if engine == "reference":
        env = reference.ModelStepEnv(model) if backend == "symbolic" else reference.TableStepEnv(model, table)
        per_run = [
            reference.train_run(env, learner, reward, iterations, seed=seed, run=first_run + r, **hyper)
            for r in _progress(range(runs), progress, "runs")
        ]
        records = {name: np.stack([run[name] for run in per_run]) for name in (*_RECORD_FIELDS, "q")}
        return TrainingResult(**records, config=config)

    records = _empty_records(runs, iterations)
    q = np.zeros((runs, N_STATES, N_ACTIONS), dtype=np.float64)
    keys = run_keys(seed, first_run, runs)
    starts = np.array([s.index for s in model.start_states()], dtype=np.int64)
    values = reward.outcome_values()
    loop_value = 0.0 if reward.looping_penalty is None else reward.looping_penalty
    chunks = range(0, runs, RUNS_PER_CHUNK)
    for lo in _progress(chunks, progress, f"{learner.name}/{reward.name}"):
        hi = min(lo + RUNS_PER_CHUNK, runs)
        kernel.train_batch(
            table.next_state, table.outcome, table.cumulative, starts, values, loop_value, reward.looping_code,
            learner.td_target, learner.on_policy, hyper["alpha"], hyper["gamma"], hyper["epsilon"], max_itr,
            keys[lo:hi], q[lo:hi], *(records[name][lo:hi] for name in _RECORD_FIELDS),
        )
    return TrainingResult(**records, q=q, config=config)


def _progress(iterable, enabled: bool, description: str):
    if not enabled:
        return iterable
    from tqdm.auto import tqdm

    return tqdm(iterable, desc=description, leave=False)
