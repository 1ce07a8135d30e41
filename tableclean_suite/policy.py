"""Greedy policies of Q-tables and their epsilon-greedy action probabilities (used by
[`tableclean_suite.analysis`][tableclean_suite.analysis] and [`tableclean_suite.asymptotes`][tableclean_suite.asymptotes])."""

from __future__ import annotations

import numpy as np


def greedy_policy(q: np.ndarray) -> np.ndarray:
    """Greedy actions of Q-tables ``(..., S, A)`` -> ``(..., S)`` int64, ties to the first action."""
    return np.argmax(np.asarray(q), axis=-1)


def action_probabilities(policy: np.ndarray, epsilon, n_actions: int) -> np.ndarray:
    """Epsilon-greedy action probabilities ``(..., S, n_actions)`` of a greedy ``policy`` ``(..., S)``.

    ``epsilon``: in [0, 1], a number or an array broadcastable to ``policy`` (per-state epsilon).
    """
    epsilon = np.asarray(epsilon, dtype=np.float64)
    if not np.all((epsilon >= 0.0) & (epsilon <= 1.0)):
        raise ValueError(f"epsilon must be in [0, 1], got {epsilon.tolist()!r}")
    policy = np.asarray(policy)
    rate = np.broadcast_to(epsilon, policy.shape)[..., None]
    probabilities = np.broadcast_to(rate / n_actions, policy.shape + (n_actions,)).copy()
    np.put_along_axis(probabilities, policy[..., None], 1.0 - rate + rate / n_actions, axis=-1)
    return probabilities
