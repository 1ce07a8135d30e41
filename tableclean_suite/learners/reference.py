"""The training loop in plain Python, one step at a time (Algorithm 1 as written).

It runs any *step environment*: an object with ``reset(draw) -> state`` and
``step(state, action, draw) -> (next_state, outcome)`` (codes), such as the task
model itself (:class:`ModelStepEnv`), a measured transition table
(:class:`TableStepEnv`) or skills in physics.  On the symbolic model it produces
exactly the arrays of the compiled :func:`~.kernel.train_batch` (same random
draws, same arithmetic); it is the baseline of ``benchmarks.speed`` and the
loop of the physics backend.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from tableclean_suite.learners.kernel import EPISODE_CONTINUES, EPISODE_TERMINAL, EPISODE_TRUNCATED, NO_STATE
from tableclean_suite.learners.rng import (
    STREAM_EXPLORE,
    STREAM_RANDOM_ACTION,
    STREAM_START,
    STREAM_TRANSITION,
    run_key,
    uniform_py,
)
from tableclean_suite.learners.rules import TabularLearner
from tableclean_suite.learners.transitions import TransitionTable
from tableclean_suite.rewards import RewardPattern
from tableclean_suite.task import Outcome, TaskModel


class StepEnv(Protocol):
    """What the reference loop steps: a task model (for the sizes) and reset/step over codes."""

    model: TaskModel

    def reset(self, draw: float) -> int:
        """Start an episode; ``draw`` in [0, 1) picks among start states. Returns the state code."""

    def step(self, state: int, action: int, draw: float) -> tuple[int, int]:
        """Apply ``action``; ``draw`` in [0, 1) is for stochastic successors. Returns (next state, outcome)."""


class ModelStepEnv:
    """The task model as a step environment (pure Python rules, no tables)."""

    def __init__(self, model: TaskModel):
        self.model = model

    def reset(self, draw: float) -> int:
        return self.model.sample_start(draw).index

    def step(self, state: int, action: int, draw: float) -> tuple[int, int]:
        next_state, outcome = self.model.step(state, action)
        return next_state.index, int(outcome)


class TableStepEnv(ModelStepEnv):
    """A transition table (e.g. calibrated from physics) as a step environment."""

    def __init__(self, model: TaskModel, table: TransitionTable):
        super().__init__(model)
        self.table = table

    def step(self, state: int, action: int, draw: float) -> tuple[int, int]:
        return self.table.sample(state, action, draw)


def _epsilon_greedy(q_row, epsilon: float, explore_draw: float, action_draw: float) -> int:
    n_actions = len(q_row)
    if explore_draw < epsilon:
        return min(int(action_draw * n_actions), n_actions - 1)
    best = 0
    for a in range(1, n_actions):
        if q_row[a] > q_row[best]:
            best = a
    return best


def train_run(
    env: StepEnv,
    learner: TabularLearner,
    reward: RewardPattern,
    iterations: int,
    alpha: float,
    gamma: float,
    epsilon: float,
    max_itr: int,
    seed: int,
    run: int,
    on_step=None,
) -> dict[str, np.ndarray]:
    """Train one run for ``iterations`` steps; returns its record arrays and Q-table.

    Returns a dict with ``rewards`` (T,) float64, ``outcomes``/``states``/
    ``actions``/``episode_end`` (T,) of ``env.model.record_dtype`` and ``q``
    ``(n_states, n_actions)`` float64.
    ``on_step(t)`` is called after every iteration (progress bars).
    """
    key = run_key(seed, run)
    model = env.model
    q = [[0.0] * model.n_actions for _ in range(model.n_states)]
    dtype = model.record_dtype
    record = {name: np.zeros(iterations, dtype=dtype) for name in ("outcomes", "states", "actions", "episode_end")}
    record["rewards"] = np.zeros(iterations, dtype=np.float64)
    state = previous = pending = NO_STATE
    length = 0
    for t in range(iterations):
        if state == NO_STATE:
            state = env.reset(uniform_py(key, t, STREAM_START))
            previous = pending = NO_STATE
            length = 0
        if pending != NO_STATE:
            action = pending
        else:
            action = _epsilon_greedy(
                q[state], epsilon, uniform_py(key, t, STREAM_EXPLORE), uniform_py(key, t, STREAM_RANDOM_ACTION)
            )
        nxt, outcome = env.step(state, action, uniform_py(key, t, STREAM_TRANSITION))
        r = reward.reward(outcome, state, nxt, previous)
        length += 1
        terminal = outcome == Outcome.TERMINAL
        pending = NO_STATE
        if learner.on_policy and not terminal:
            pending = _epsilon_greedy(
                q[nxt], epsilon, uniform_py(key, t + 1, STREAM_EXPLORE), uniform_py(key, t + 1, STREAM_RANDOM_ACTION)
            )
        target = learner.target(np.asarray(q[nxt]), pending, r, gamma, epsilon, terminal)
        q[state][action] += alpha * (target - q[state][action])
        record["rewards"][t] = r
        record["outcomes"][t] = outcome
        record["states"][t] = state
        record["actions"][t] = action
        if terminal:
            record["episode_end"][t] = EPISODE_TERMINAL
            state = NO_STATE
        elif length >= max_itr:
            record["episode_end"][t] = EPISODE_TRUNCATED
            state = NO_STATE
        else:
            record["episode_end"][t] = EPISODE_CONTINUES
            previous, state = state, nxt
        if on_step is not None:
            on_step(t)
    record["q"] = np.asarray(q, dtype=np.float64)
    return record
