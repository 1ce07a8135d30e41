"""Learning curves from training records: per iteration, averaged over runs.

Success rate, terminal rate and average reward at iteration t read each run's most recently
finished episode (the average reward leaves out runs with none, and is NaN until
``support_fraction`` of the runs have one); episodes at t count finished episodes.  Definitions:
the *Learners and statistics* docs page.  [`CurveSums`][tableclean_suite.curves.CurveSums]
accumulates the per-iteration sums (and sums of squares) chunk by chunk of runs in one compiled
pass (memory ``6 x T`` whatever R).
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


def _episode_arrays(result):
    """Per finished episode: run, last iteration, previous end, return, length, improper count, terminal."""
    ends = result.episode_end != 0
    run_index, last = np.nonzero(ends)
    same_run = np.r_[False, run_index[1:] == run_index[:-1]][:len(run_index)]  # no episode: empty
    previous_end = np.where(same_run, np.r_[-1, last[:-1]], -1)
    cum_reward = np.cumsum(result.rewards, axis=1)
    cum_improper = np.cumsum(result.outcomes == Outcome.IMPROPER, axis=1)

    def span(cumulative):
        before = np.where(previous_end >= 0, cumulative[run_index, np.maximum(previous_end, 0)], 0)
        return cumulative[run_index, last] - before

    episode_return = span(cum_reward)
    improper = span(cum_improper)
    length = last - previous_end
    terminal = result.episode_end[run_index, last] == _TERMINAL_END
    return run_index, last, previous_end, episode_return, length, improper, terminal


def episode_table(result):
    """One row per finished episode (pandas DataFrame); see ``TrainingResult.episodes``."""
    import pandas as pd

    run_index, last, previous_end, episode_return, length, improper, terminal = _episode_arrays(result)
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

    Memory is ``6 x T`` floats whatever the number of runs, so a cell's curves can be built from
    ``train(runs=chunk, first_run=lo, ...)`` calls without keeping their records.  Runs must be
    added in order (0, 1, ...) for the sums to be bit-identical to a single pass.

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
    finished_runs: np.ndarray
    episodes: np.ndarray
    runs: int = 0
    average_square: np.ndarray | None = None  # after ``runs``: positional construction keeps its meaning

    def __post_init__(self):
        if self.average_square is None:
            self.average_square = np.zeros_like(self.average_sum, dtype=np.float64)

    @classmethod
    def zeros(cls, iterations: int) -> "CurveSums":
        """Empty sums for curves of length ``iterations`` (>= 1)."""
        if iterations < 1:
            raise ValueError(f"iterations must be >= 1, got {iterations!r}")
        return cls(*(np.zeros(int(iterations)) for _ in range(5)), average_square=np.zeros(int(iterations)))

    @property
    def iterations(self) -> int:
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
        return mean_curves(self.success, self.terminal, self.average_sum, self.finished_runs, self.episodes,
                           self.runs, support_fraction)


def supported(finished_runs, runs, support_fraction: float) -> np.ndarray:
    """Where the average reward is defined: at least one run, and at least ``support_fraction`` of
    the ``runs`` (any shape broadcasting with ``finished_runs``), have finished an episode."""
    check_fraction("support_fraction", support_fraction, low_open=False)
    finished_runs = np.asarray(finished_runs, dtype=float)
    return (finished_runs > 0) & (finished_runs >= support_fraction * np.asarray(runs, dtype=float))


def mean_curves(success, terminal, average_sum, finished_runs, episodes, runs, support_fraction: float = 0.0):
    """Curves from per-iteration sums over ``runs`` runs (arrays ``(..., T)``, ``runs`` broadcasting
    as ``(..., 1)``): ``{"success", "terminal", "average_reward", "episodes"}``; see [`CurveSums`][tableclean_suite.curves.CurveSums]."""
    runs = np.asarray(runs, dtype=float)
    defined = supported(finished_runs, runs, support_fraction)
    with np.errstate(invalid="ignore", divide="ignore"):
        average = np.where(defined, average_sum / np.maximum(finished_runs, 1.0), np.nan)
        return {"success": success / runs, "terminal": terminal / runs, "average_reward": average,
                "episodes": episodes / runs}


def curve_sums(result) -> CurveSums:
    """The [`CurveSums`][tableclean_suite.curves.CurveSums] of one `TrainingResult`."""
    return CurveSums.zeros(result.rewards.shape[1]).add(result)


@numba.njit(cache=True)
def _curve_sums(rewards, outcomes, episode_end, success, terminal, average_sum, average_square, finished_runs,
                episodes):
    """One pass over ``(R, T)`` records, adding per iteration, run by run in order, the latest
    finished episode's success, terminal flag, average reward and its square, the count of runs
    with a finished episode, and episodes finished so far into ``(T,)`` float64 accumulators.

    Runs are added in order, so feeding runs 0..R-1 in several calls gives bit-identical sums."""
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
    """The per-iteration curves ``success``, ``terminal``, ``average_reward``, ``episodes``, each ``(T,)``.

    Computed in one compiled pass without ``(R, T)`` temporaries (the harness's hot path).
    """
    return curve_sums(result).curves()


def episodes_curve(result) -> np.ndarray:
    """Mean over runs of episodes finished by each iteration, shape ``(T,)``."""
    return learning_curves(result)["episodes"]
