"""Learning curves from training records: per iteration, averaged over runs.

Success rate, terminal rate and average reward at iteration t read each run's most recently
finished episode (the average reward leaves out runs with none, and is NaN until
``support_fraction`` of the runs have one); episodes at t count finished episodes.
[`CurveSums`][tableclean_suite.curves.CurveSums] accumulates the per-iteration sums chunk by chunk
of runs in one compiled pass.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from tableclean_suite.task import Outcome

_TERMINAL_END = 1  # kernel.EPISODE_TERMINAL
_IMPROPER = int(Outcome.IMPROPER)


def check_fraction(name: str, value: float, low_open: bool = True) -> None:
    """``ValueError`` naming ``name`` unless ``value`` is in (0, 1] (``low_open``) or [0, 1]."""
    if not (0.0 < value <= 1.0) if low_open else not (0.0 <= value <= 1.0):
        raise ValueError(f"{name} must be in {'(0, 1]' if low_open else '[0, 1]'}, got {value!r}")


def episode_table(result):
    """One row per finished episode of a `TrainingResult` (pandas DataFrame; see ``TrainingResult.episodes``)."""
    import pandas as pd

    run_index, last = np.nonzero(result.episode_end != 0)
    same_run = np.r_[False, run_index[1:] == run_index[:-1]][:len(run_index)]  # no episode: empty
    previous_end = np.where(same_run, np.r_[-1, last[:-1]], -1)

    def span(cumulative):  # per episode: the sum of a per-iteration quantity over its iterations
        before = np.where(previous_end >= 0, cumulative[run_index, np.maximum(previous_end, 0)], 0)
        return cumulative[run_index, last] - before

    episode_return = span(np.cumsum(result.rewards, axis=1))
    improper = span(np.cumsum(result.outcomes == Outcome.IMPROPER, axis=1))
    length = last - previous_end
    terminal = result.episode_end[run_index, last] == _TERMINAL_END
    return pd.DataFrame(
        {
            "run": run_index,
            "episode": pd.Series(run_index).groupby(run_index).cumcount().to_numpy(dtype=np.int64),
            "first_iteration": previous_end + 1,
            "last_iteration": last,
            "length": length,
            "return": episode_return,
            "average_reward": episode_return / length,
            "reached_terminal": terminal,
            "improper_actions": improper,
            "success": terminal & (improper == 0),
        }
    )


@dataclass
class CurveSums:
    """Per-iteration sums over runs, from which the curves follow; fed chunk by chunk of runs.

    Memory is ``6 x T`` floats whatever the number of runs.  Runs must be added in order (0, 1, ...)
    for the sums to be bit-identical to a single pass.

    Attributes (all ``(T,)`` float64 except ``runs``):
        success: sum over runs of the latest finished episode's success (0 or 1).
        terminal: sum over runs of whether the latest finished episode reached the terminal state.
        average_sum: sum, over runs with a finished episode, of its return / length.
        average_square: the same sum of (return / length) squared (for the curve's interval).
        finished_runs: number of runs with at least one finished episode.
        episodes: sum over runs of episodes finished so far.
        runs: runs added so far (>= 0).
    """

    success: np.ndarray
    terminal: np.ndarray
    average_sum: np.ndarray
    average_square: np.ndarray
    finished_runs: np.ndarray
    episodes: np.ndarray
    runs: int = 0

    @classmethod
    def zeros(cls, iterations: int) -> "CurveSums":
        """Empty sums for curves of length ``iterations`` (>= 1)."""
        if iterations < 1:
            raise ValueError(f"iterations must be >= 1, got {iterations!r}")
        return cls(*(np.zeros(int(iterations)) for _ in range(6)))

    @property
    def iterations(self) -> int:
        """T, the length of every curve."""
        return len(self.success)

    def add(self, result) -> "CurveSums":
        """Add the runs of a `TrainingResult` (the next ones in run order); returns self."""
        if result.rewards.shape[1] != self.iterations:
            raise ValueError(f"result has {result.rewards.shape[1]} iterations, the sums {self.iterations}")
        _curve_sums(result.rewards, result.outcomes, result.episode_end, self.success, self.terminal,
                    self.average_sum, self.average_square, self.finished_runs, self.episodes)
        self.runs += int(result.rewards.shape[0])
        return self

    def curves(self, support_fraction: float = 0.0) -> dict[str, np.ndarray]:
        """The curves ``success``, ``terminal``, ``average_reward``, ``episodes``, each ``(T,)``.

        Args:
            support_fraction: the average reward at t is NaN unless at least this fraction of
                the runs (in [0, 1]) have finished an episode by t (0: one run is enough).
        """
        if self.runs < 1:
            raise ValueError("no runs added yet")
        defined = supported(self.finished_runs, self.runs, support_fraction)
        with np.errstate(invalid="ignore", divide="ignore"):
            average = np.where(defined, self.average_sum / np.maximum(self.finished_runs, 1.0), np.nan)
        return {"success": self.success / self.runs, "terminal": self.terminal / self.runs,
                "average_reward": average, "episodes": self.episodes / self.runs}


def supported(finished_runs, runs, support_fraction: float) -> np.ndarray:
    """Where the average reward is defined: at least one run, and at least ``support_fraction`` (in
    [0, 1]) of the ``runs``, have finished an episode; ``finished_runs`` is ``(T,)``."""
    check_fraction("support_fraction", support_fraction, low_open=False)
    finished_runs = np.asarray(finished_runs, dtype=float)
    return (finished_runs > 0) & (finished_runs >= support_fraction * float(runs))


def curve_sums(result) -> CurveSums:
    """The [`CurveSums`][tableclean_suite.curves.CurveSums] of one `TrainingResult`."""
    return CurveSums.zeros(result.rewards.shape[1]).add(result)


@numba.njit(cache=True)
def _curve_sums(rewards, outcomes, episode_end, success, terminal, average_sum, average_square, finished_runs,
                episodes):
    """Add ``(R, T)`` records, run by run in order, into the ``(T,)`` float64 sums of
    [`CurveSums`][tableclean_suite.curves.CurveSums]."""
    n_runs, n_iterations = rewards.shape
    for r in range(n_runs):
        episode_return = 0.0
        length = 0
        improper = 0
        finished = 0
        latest_success = 0.0
        latest_terminal = 0.0
        latest_average = 0.0
        for t in range(n_iterations):
            episode_return += rewards[r, t]
            length += 1
            if outcomes[r, t] == _IMPROPER:
                improper += 1
            if episode_end[r, t] != 0:
                finished += 1
                latest_terminal = 1.0 if episode_end[r, t] == _TERMINAL_END else 0.0
                latest_success = latest_terminal if improper == 0 else 0.0
                latest_average = episode_return / length
                episode_return = 0.0
                length = 0
                improper = 0
            success[t] += latest_success
            terminal[t] += latest_terminal
            episodes[t] += finished
            if finished > 0:
                average_sum[t] += latest_average
                average_square[t] += latest_average * latest_average
                finished_runs[t] += 1.0


def learning_curves(result) -> dict[str, np.ndarray]:
    """The per-iteration curves ``success``, ``terminal``, ``average_reward``, ``episodes``, each ``(T,)``."""
    return curve_sums(result).curves()
