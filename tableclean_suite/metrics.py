"""The paper's learning-speed quantities, defined precisely, as pure functions.

Inputs are :class:`~tableclean_suite.learners.TrainingResult` records (R runs x
T iterations) or 1-D curves of length T.  Definitions:

- An episode **succeeds** when it reaches the terminal state without any
  improper action during it.
- **Success rate** at iteration t: fraction of runs whose most recently finished
  episode (at or before t) succeeded; a run with no finished episode counts 0.
- **Average reward** at t: mean over runs of (return / length) of the most recently
  finished episode; runs with no finished episode are left out (NaN if none).
- **Plateau**: mean over the last ``plateau_fraction`` (25 %) of the window.
- **Iterations to maximum success**: first t (1-based count) at which the success
  curve reaches ``threshold`` (95 %) of its plateau.
- **Average-reward convergence**: first t at or after the curve's early minimum
  (its minimum before the plateau window) where it has covered ``threshold`` of
  the way from that minimum to its plateau.
- **Episodes** at t: mean over runs of episodes finished by t.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numba
import numpy as np

from tableclean_suite.task import Outcome

DEFAULT_THRESHOLD = 0.95
DEFAULT_PLATEAU_FRACTION = 0.25
_TERMINAL_END = 1  # kernel.EPISODE_TERMINAL
_IMPROPER = int(Outcome.IMPROPER)

_SCALAR, _CURVE = "scalar", "curve"


def _scalar(unit: str):
    return field(metadata={"role": _SCALAR, "unit": unit})


def _curve(unit: str):
    return field(metadata={"role": _CURVE, "unit": unit}, repr=False)


@dataclass(frozen=True, eq=False)
class Summary:
    """The Table 3 quantities of one trained cell, and the curves they came from.

    Scalars (``None`` when the curve never reaches its level; NaN when no episode finished):

    Attributes:
        max_success_iterations: iterations (1-based count) until the success curve first reaches
            ``threshold`` of its plateau, in [1, T], or None.
        max_success_episodes: mean episodes finished by then, >= 0, or None.
        reward_convergence_iterations: iterations (1-based count) until the average-reward curve
            has covered ``threshold`` of the way from its early minimum to its plateau, or None.
        reward_convergence_episodes: mean episodes finished by then, >= 0, or None.
        success_plateau: plateau of the success curve, a fraction in [0, 1].
        max_average_reward: maximum of the average-reward curve (reward units per iteration).
        average_reward_plateau: plateau of the average-reward curve (reward units per iteration).
        terminal_plateau: plateau of the terminal curve, a fraction in [0, 1].
        success: ``(T,)`` success rate per iteration, in [0, 1].
        average_reward: ``(T,)`` average reward per iteration (NaN until some run finished an episode).
        terminal: ``(T,)`` fraction of runs whose latest episode reached the terminal state.
        episodes: ``(T,)`` mean episodes finished by each iteration.

    The curves are read-only arrays.  ``summary["name"]`` reads a field too (code written when
    :func:`summarize` returned a dict keeps working).
    """

    max_success_iterations: int | None = _scalar("iterations")
    max_success_episodes: float | None = _scalar("episodes")
    reward_convergence_iterations: int | None = _scalar("iterations")
    reward_convergence_episodes: float | None = _scalar("episodes")
    success_plateau: float = _scalar("fraction")
    max_average_reward: float = _scalar("reward per iteration")
    average_reward_plateau: float = _scalar("reward per iteration")
    terminal_plateau: float = _scalar("fraction")
    success: np.ndarray = _curve("fraction")
    average_reward: np.ndarray = _curve("reward per iteration")
    terminal: np.ndarray = _curve("fraction")
    episodes: np.ndarray = _curve("episodes")

    def __post_init__(self):
        lengths = set()
        for name in CURVE_NAMES:
            curve = np.array(getattr(self, name), dtype=np.float64)
            if curve.ndim != 1:
                raise ValueError(f"Summary.{name} must be a 1-D curve, got shape {curve.shape}")
            curve.setflags(write=False)
            object.__setattr__(self, name, curve)
            lengths.add(len(curve))
        if len(lengths) > 1:
            raise ValueError(f"Summary curves differ in length: {sorted(lengths)}")

    @property
    def iterations(self) -> int:
        """T, the length of every curve."""
        return len(self.success)

    def scalars(self) -> dict:
        """``{name: value}`` of the scalar fields, in :data:`SUMMARY_SCALARS` order."""
        return {name: getattr(self, name) for name in SUMMARY_SCALARS}

    def curves(self) -> dict[str, np.ndarray]:
        """``{name: (T,) array}`` of the curves, in :data:`CURVE_NAMES` order."""
        return {name: getattr(self, name) for name in CURVE_NAMES}

    def __contains__(self, name) -> bool:
        return name in SUMMARY_SCALARS or name in CURVE_NAMES

    def __getitem__(self, name: str):
        if name not in self:
            raise KeyError(f"{name!r} is not a Summary field; fields: {', '.join(SUMMARY_SCALARS + CURVE_NAMES)}")
        return getattr(self, name)


#: Scalar fields of :class:`Summary` (the Table 3 columns), in table order.
SUMMARY_SCALARS = tuple(f.name for f in fields(Summary) if f.metadata["role"] == _SCALAR)
#: Scalar fields counted in iterations (integers, or None when never reached).
ITERATION_SCALARS = tuple(f.name for f in fields(Summary) if f.metadata["role"] == _SCALAR
                          and f.metadata["unit"] == "iterations")
#: Curve fields of :class:`Summary`, each ``(T,)``.
CURVE_NAMES = tuple(f.name for f in fields(Summary) if f.metadata["role"] == _CURVE)


def _episode_arrays(result):
    """Per finished episode: run, last iteration, previous end, return, length, improper count, terminal."""
    ends = result.episode_end != 0
    run_index, last = np.nonzero(ends)
    same_run = np.r_[False, run_index[1:] == run_index[:-1]]
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
    same_run = np.r_[False, run_index[1:] == run_index[:-1]]
    episode_number = np.zeros(len(run_index), dtype=np.int64)
    for i in range(1, len(run_index)):
        episode_number[i] = episode_number[i - 1] + 1 if same_run[i] else 0
    return pd.DataFrame(
        {
            "run": run_index,
            "episode": episode_number,
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


def _forward_fill(result, values_at_ends, before_first):
    """Spread per-episode values over iterations: value of the latest episode ended at or before t."""
    runs, iterations = result.episode_end.shape
    ends = result.episode_end != 0
    run_index, last = np.nonzero(ends)
    grid = np.full((runs, iterations), np.nan)
    grid[run_index, last] = values_at_ends
    latest = np.where(ends, np.arange(iterations)[None, :], -1)
    latest = np.maximum.accumulate(latest, axis=1)
    filled = np.take_along_axis(grid, np.maximum(latest, 0), axis=1)
    return np.where(latest >= 0, filled, before_first)


def success_matrix(result) -> np.ndarray:
    """``(R, T)`` float: 1.0 if the run's latest finished episode succeeded, else 0.0."""
    _, _, _, _, _, improper, terminal = _episode_arrays(result)
    return _forward_fill(result, (terminal & (improper == 0)).astype(float), 0.0)


def terminal_matrix(result) -> np.ndarray:
    """``(R, T)`` float: 1.0 if the latest finished episode reached the terminal state (improper or not)."""
    _, _, _, _, _, _, terminal = _episode_arrays(result)
    return _forward_fill(result, terminal.astype(float), 0.0)


def average_reward_matrix(result) -> np.ndarray:
    """``(R, T)``: return / length of the latest finished episode (NaN before the first)."""
    _, _, _, episode_return, length, _, _ = _episode_arrays(result)
    return _forward_fill(result, episode_return / length, np.nan)


@numba.njit(cache=True)
def _latest_episode_curves(rewards, outcomes, episode_end, success, terminal, average_sum, finished_runs, episodes):
    """One pass over ``(R, T)`` records, adding per iteration, run by run in order, the latest
    finished episode's success, terminal flag and average reward, the count of runs with a
    finished episode, and episodes finished so far into the ``(T,)`` float64 accumulators.

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
                finished_runs[t] += 1.0


@dataclass
class CurveSums:
    """Per-iteration sums over runs, from which the curves follow; fed chunk by chunk of runs.

    Memory is ``5 x T`` floats whatever the number of runs, so a cell's curves can be built from
    ``train(runs=chunk, first_run=lo, ...)`` calls without keeping their records.  Runs must be
    added in order (0, 1, ...) for the sums to be bit-identical to a single pass.

    Attributes (all ``(T,)`` float64 except ``runs``):
        success: sum over runs of the latest finished episode's success (0 or 1).
        terminal: sum over runs of whether the latest finished episode reached the terminal state.
        average_sum: sum, over runs with a finished episode, of its return / length.
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

    @classmethod
    def zeros(cls, iterations: int) -> "CurveSums":
        """Empty sums for curves of length ``iterations`` (>= 1)."""
        if iterations < 1:
            raise ValueError(f"iterations must be >= 1, got {iterations!r}")
        return cls(*(np.zeros(int(iterations)) for _ in range(5)))

    @property
    def iterations(self) -> int:
        return len(self.success)

    def add(self, result) -> "CurveSums":
        """Add the runs of a :class:`TrainingResult` (the next ones in run order); returns self."""
        if result.rewards.shape[1] != self.iterations:
            raise ValueError(f"result has {result.rewards.shape[1]} iterations, the sums {self.iterations}")
        _latest_episode_curves(result.rewards, result.outcomes, result.episode_end, self.success,
                               self.terminal, self.average_sum, self.finished_runs, self.episodes)
        self.runs += int(result.rewards.shape[0])
        return self

    def curves(self) -> dict[str, np.ndarray]:
        """The curves ``success``, ``terminal``, ``average_reward``, ``episodes``, each ``(T,)``."""
        if self.runs < 1:
            raise ValueError("no runs added yet")
        with np.errstate(invalid="ignore", divide="ignore"):
            average = np.where(self.finished_runs > 0, self.average_sum / np.maximum(self.finished_runs, 1.0), np.nan)
        return {"success": self.success / self.runs, "terminal": self.terminal / self.runs,
                "average_reward": average, "episodes": self.episodes / self.runs}


def curve_sums(result) -> CurveSums:
    """The :class:`CurveSums` of one :class:`TrainingResult`."""
    return CurveSums.zeros(result.rewards.shape[1]).add(result)


def learning_curves(result) -> dict[str, np.ndarray]:
    """The per-iteration curves ``success``, ``terminal``, ``average_reward``, ``episodes``, each ``(T,)``.

    Same definitions as the ``*_matrix`` functions averaged over runs, computed in
    one compiled pass without ``(R, T)`` temporaries (the harness's hot path).
    """
    return curve_sums(result).curves()


def success_curve(result) -> np.ndarray:
    """Success rate per iteration, shape ``(T,)``, in [0, 1]."""
    return learning_curves(result)["success"]


def terminal_curve(result) -> np.ndarray:
    """Fraction of runs whose latest episode reached the terminal state, shape ``(T,)``."""
    return learning_curves(result)["terminal"]


def average_reward_curve(result) -> np.ndarray:
    """Average reward per iteration, shape ``(T,)`` (NaN until some run finished an episode)."""
    return learning_curves(result)["average_reward"]


def episodes_curve(result) -> np.ndarray:
    """Mean over runs of episodes finished by each iteration, shape ``(T,)``."""
    return learning_curves(result)["episodes"]


def _check_fraction(name, value, low_open=True):
    if not (0.0 < value <= 1.0) if low_open else not (0.0 <= value <= 1.0):
        raise ValueError(f"{name} must be in (0, 1], got {value!r}")


def plateau(curve, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION) -> float:
    """Mean of the last ``plateau_fraction`` of ``curve`` (NaNs ignored)."""
    _check_fraction("plateau_fraction", plateau_fraction)
    curve = np.asarray(curve, dtype=float)
    window = max(1, math.ceil(len(curve) * plateau_fraction))
    tail = curve[-window:]
    return float(np.nanmean(tail)) if np.any(~np.isnan(tail)) else float("nan")


def iterations_to_max_success(
    curve, threshold: float = DEFAULT_THRESHOLD, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION
) -> int | None:
    """First iteration count t (1-based) with ``curve[t-1] >= threshold * plateau``; None if never."""
    _check_fraction("threshold", threshold)
    curve = np.asarray(curve, dtype=float)
    level = threshold * plateau(curve, plateau_fraction)
    if not math.isfinite(level):
        return None
    hits = np.nonzero(curve >= level)[0]
    return int(hits[0]) + 1 if len(hits) else None


def reward_convergence_iteration(
    curve, threshold: float = DEFAULT_THRESHOLD, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION
) -> int | None:
    """First iteration count t (1-based), at or after the early minimum, where the curve has
    covered ``threshold`` of the way from its early minimum to its plateau; None if never."""
    _check_fraction("threshold", threshold)
    curve = np.asarray(curve, dtype=float)
    top = plateau(curve, plateau_fraction)
    window = max(1, math.ceil(len(curve) * plateau_fraction))
    early = curve[: max(1, len(curve) - window)]
    if not math.isfinite(top) or np.all(np.isnan(early)):
        return None
    lowest = int(np.nanargmin(early))
    level = early[lowest] + threshold * (top - early[lowest])
    hits = np.nonzero(curve[lowest:] >= level)[0]
    return lowest + int(hits[0]) + 1 if len(hits) else None


def episodes_at(episodes: np.ndarray, iteration: int | None) -> float | None:
    """Mean episodes finished by iteration count ``iteration`` (1-based), from :func:`episodes_curve`."""
    if iteration is None:
        return None
    return float(episodes[iteration - 1])


def summarize(
    result, threshold: float = DEFAULT_THRESHOLD, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION
) -> Summary:
    """Table 3 quantities of one training result, plus the curves they came from.

    Args:
        result: a :class:`~tableclean_suite.learners.TrainingResult`, or the :class:`CurveSums`
            of one accumulated chunk by chunk (same numbers).
        threshold: fraction of the plateau that counts as reached, in (0, 1].
        plateau_fraction: final fraction of the window averaged as the plateau, in (0, 1].

    Returns:
        A :class:`Summary`.
    """
    sums = result if isinstance(result, CurveSums) else curve_sums(result)
    curves = sums.curves()
    success, average, episodes, terminal = (
        curves["success"], curves["average_reward"], curves["episodes"], curves["terminal"]
    )
    success_at = iterations_to_max_success(success, threshold, plateau_fraction)
    reward_at = reward_convergence_iteration(average, threshold, plateau_fraction)
    return Summary(
        max_success_iterations=success_at,
        max_success_episodes=episodes_at(episodes, success_at),
        reward_convergence_iterations=reward_at,
        reward_convergence_episodes=episodes_at(episodes, reward_at),
        success_plateau=plateau(success, plateau_fraction),
        max_average_reward=float(np.nanmax(average)) if np.any(~np.isnan(average)) else float("nan"),
        average_reward_plateau=plateau(average, plateau_fraction),
        terminal_plateau=plateau(terminal, plateau_fraction),
        success=success,
        average_reward=average,
        terminal=terminal,
        episodes=episodes,
    )
