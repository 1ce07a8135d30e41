"""Per-run ``(R, T)`` curves computed from the episode arrays with numpy: the oracle the compiled
``tableclean_suite.curves.CurveSums`` pass is checked against."""

import numpy as np

from tableclean_suite.curves import _episode_arrays


def _forward_fill(result, values_at_ends, before_first):
    """Spread per-episode values over iterations: value of the latest episode ended at or before t."""
    runs, iterations = result.episode_end.shape
    ends = result.episode_end != 0
    run_index, last = np.nonzero(ends)
    grid = np.full((runs, iterations), np.nan)
    grid[run_index, last] = values_at_ends
    latest = np.maximum.accumulate(np.where(ends, np.arange(iterations)[None, :], -1), axis=1)
    filled = np.take_along_axis(grid, np.maximum(latest, 0), axis=1)
    return np.where(latest >= 0, filled, before_first)


def success_matrix(result) -> np.ndarray:
    """``(R, T)`` float: 1.0 if the run's latest finished episode succeeded, else 0.0."""
    _, _, _, _, _, improper, terminal = _episode_arrays(result)
    return _forward_fill(result, (terminal & (improper == 0)).astype(float), 0.0)


def terminal_matrix(result) -> np.ndarray:
    """``(R, T)`` float: 1.0 if the latest finished episode reached the terminal state (improper or not)."""
    return _forward_fill(result, _episode_arrays(result)[6].astype(float), 0.0)


def average_reward_matrix(result) -> np.ndarray:
    """``(R, T)``: return / length of the latest finished episode (NaN before the first)."""
    _, _, _, episode_return, length, _, _ = _episode_arrays(result)
    return _forward_fill(result, episode_return / length, np.nan)
