"""Exact analysis of policies on the task: success probabilities by dynamic programming.

The paper's ~84 % success plateau is the chance that epsilon-greedy exploration
avoids every improper action on the way to the terminal state.  Here that
chance is computed exactly, for any policy, over the model (or a measured
transition table), so learners' measured plateaus can be checked against it.
"""

from __future__ import annotations

import numpy as np

from tableclean_suite.learners.transitions import TransitionTable
from tableclean_suite.task import Outcome, TaskModel, TaskState


def greedy_policy(q: np.ndarray) -> np.ndarray:
    """Greedy actions of Q-tables ``(..., S, A)`` -> ``(..., S)`` int64, ties to the first action."""
    return np.argmax(np.asarray(q), axis=-1)


def action_probabilities(policy: np.ndarray, epsilon: float, n_actions: int) -> np.ndarray:
    """Epsilon-greedy action probabilities ``(..., S, n_actions)`` of a greedy ``policy`` ``(..., S)``."""
    if not 0.0 <= epsilon <= 1.0:
        raise ValueError(f"epsilon must be in [0, 1], got {epsilon!r}")
    policy = np.asarray(policy)
    probabilities = np.full(policy.shape + (n_actions,), epsilon / n_actions)
    np.put_along_axis(probabilities, policy[..., None], 1.0 - epsilon + epsilon / n_actions, axis=-1)
    return probabilities


def exact_success_probability(
    policy: np.ndarray,
    epsilon: float,
    max_itr: int,
    model: TaskModel | None = None,
    table: TransitionTable | None = None,
    starts: list[TaskState] | None = None,
) -> np.ndarray:
    """Probability that an episode succeeds (terminal within ``max_itr`` steps, no improper action).

    Args:
        policy: greedy action per state, shape ``(S,)`` or ``(R, S)`` for R policies (S = ``model.n_states``).
        epsilon: exploration rate in [0, 1] (random actions uniform over the task's actions).
        max_itr: episode length limit (>= 1).
        model: the task model (rules and start states); default ``TaskModel()``.
        table: transitions to use instead of the model's (e.g. calibrated).
        starts: start states (default the model's), weighted uniformly.

    Returns:
        Success probability per policy: shape ``()`` for one policy, ``(R,)`` for R.
    """
    if int(max_itr) != max_itr or max_itr < 1:
        raise ValueError(f"max_itr must be an integer >= 1, got {max_itr!r}")
    model = model if model is not None else TaskModel()
    table = table if table is not None else TransitionTable.from_model(model)
    starts = starts if starts is not None else model.start_states()
    policy = np.asarray(policy)
    single = policy.ndim == 1
    policy = np.atleast_2d(policy)
    if policy.shape[-1] != model.n_states:
        raise ValueError(f"policy has {policy.shape[-1]} states; task {model.spec.name!r} has {model.n_states}")
    table.check_model(model)
    pi = action_probabilities(policy, epsilon, model.n_actions)  # (R, S, A)
    probability = np.diff(table.cumulative, axis=2, prepend=0.0)  # (S, A, K)
    safe = probability * (table.outcome != Outcome.IMPROPER)
    finishing = (safe * (table.outcome == Outcome.TERMINAL)).sum(axis=2)  # (S, A)
    continuing = safe * (table.outcome != Outcome.TERMINAL)  # (S, A, K)
    value = np.zeros(policy.shape)  # P(success within k steps), k = 0
    for _ in range(int(max_itr)):
        future = (continuing[None] * value[:, table.next_state]).sum(axis=3)  # (R, S, A)
        updated = (pi * (finishing[None] + future)).sum(axis=2)
        if np.array_equal(updated, value):
            break
        value = updated
    codes = [s.index for s in starts]
    result = value[:, codes].mean(axis=1)
    return result[0] if single else result
