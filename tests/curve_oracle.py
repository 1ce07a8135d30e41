"""Per-run ``(R, T)`` curves computed from the episode table with numpy: the oracle the compiled
``tableclean_suite.curves.CurveSums`` pass is checked against."""

import numpy as np

from tableclean_suite.curves import episode_table


def _forward_fill(result, column: str, before_first: float) -> np.ndarray:
    """Spread an episode-table column over iterations: the value of the latest episode ended at or before t."""
    runs, iterations = result.episode_end.shape
    ends = result.episode_end != 0
    run_index, last = np.nonzero(ends)
    grid = np.full((runs, iterations), np.nan)
    grid[run_index, last] = episode_table(result)[column].to_numpy(dtype=float)
    latest = np.maximum.accumulate(np.where(ends, np.arange(iterations)[None, :], -1), axis=1)
    filled = np.take_along_axis(grid, np.maximum(latest, 0), axis=1)
    return np.where(latest >= 0, filled, before_first)


def success_matrix(result) -> np.ndarray:
    """``(R, T)`` float: 1.0 if the run's latest finished episode succeeded, else 0.0."""
    return _forward_fill(result, "success", 0.0)


def terminal_matrix(result) -> np.ndarray:
    """``(R, T)`` float: 1.0 if the latest finished episode reached the terminal state (improper or not)."""
    return _forward_fill(result, "reached_terminal", 0.0)


def average_reward_matrix(result) -> np.ndarray:
    """``(R, T)``: return / length of the latest finished episode (NaN before the first)."""
    return _forward_fill(result, "average_reward", np.nan)
