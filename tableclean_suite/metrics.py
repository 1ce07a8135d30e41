"""The paper's learning-speed quantities, defined precisely, as pure functions.

Inputs are :class:`~tableclean_suite.learners.TrainingResult` records (R runs x
T iterations) or 1-D curves of length T.  Definitions:

- An episode **succeeds** when it reaches the terminal state without any
  improper action during it.
- **Success rate** at iteration t: fraction of runs whose most recently finished
  episode (at or before t) succeeded; a run with no finished episode counts 0.
- **Average reward** at t: mean over runs of (return / length) of the most recently
  finished episode; runs with no finished episode are left out.  With a ``support_fraction``
  f > 0 a point is defined (not NaN) only once at least f of the runs have finished an
  episode, so that early points do not rest on a handful of runs (the harness uses 0.5).
- **Plateau**: with an *asymptote* (the harness's way, :mod:`tableclean_suite.asymptotes`):
  the exact value the curve tends to under each run's final policy, averaged over runs, which
  the window does not change.  Without one: the mean over the last ``plateau_fraction`` (25 %)
  of the window (the *window mean*, always reported as ``*_window_mean``), which moves with it.
- **Iterations to maximum success**: first t (1-based count) at which the success
  curve reaches ``threshold`` (95 %) of its plateau.
- **Average-reward convergence**: first t at or after the curve's early minimum
  where it has covered ``threshold`` of the way from that minimum to its plateau.  The early
  minimum is the minimum of the (supported) curve before it first reaches the plateau (with an
  asymptote), or before the plateau window (without one).
- **Maximum average reward**: the maximum of the (supported) curve.
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
        success_plateau: plateau of the success curve, a fraction in [0, 1] (the asymptote when
            :func:`summarize` was given one, else the window mean).
        max_average_reward: maximum of the (supported) average-reward curve (reward units per iteration).
        average_reward_plateau: plateau of the average-reward curve (reward units per iteration).
        terminal_plateau: plateau of the terminal curve, a fraction in [0, 1].
        success_window_mean: mean of the success curve's last ``plateau_fraction``, in [0, 1].
        average_reward_window_mean: mean of the average-reward curve's last ``plateau_fraction``.
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
    success_window_mean: float = _scalar("fraction")
    average_reward_window_mean: float = _scalar("reward per iteration")
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
        one_group = [a[None, :] for a in (self.success, self.terminal, self.average_sum, self.finished_runs,
                                          self.episodes)]  # views: the single group is this sums' arrays
        first_success = np.zeros(result.rewards.shape[0], dtype=np.int64)
        _grouped_curves(result.rewards, result.outcomes, result.episode_end, 0, *one_group, first_success)
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
    _check_fraction("support_fraction", support_fraction, low_open=False)
    finished_runs = np.asarray(finished_runs, dtype=float)
    return (finished_runs > 0) & (finished_runs >= support_fraction * np.asarray(runs, dtype=float))


def mean_curves(success, terminal, average_sum, finished_runs, episodes, runs, support_fraction: float = 0.0):
    """Curves from per-iteration sums over ``runs`` runs (arrays ``(..., T)``, ``runs`` broadcasting
    as ``(..., 1)``): ``{"success", "terminal", "average_reward", "episodes"}``; see :class:`CurveSums`."""
    runs = np.asarray(runs, dtype=float)
    defined = supported(finished_runs, runs, support_fraction)
    with np.errstate(invalid="ignore", divide="ignore"):
        average = np.where(defined, average_sum / np.maximum(finished_runs, 1.0), np.nan)
        return {"success": success / runs, "terminal": terminal / runs, "average_reward": average,
                "episodes": episodes / runs}


def curve_sums(result) -> CurveSums:
    """The :class:`CurveSums` of one :class:`TrainingResult`."""
    return CurveSums.zeros(result.rewards.shape[1]).add(result)


@numba.njit(cache=True)
def _grouped_curves(rewards, outcomes, episode_end, first_run, success, terminal, average_sum, finished_runs,
                    episodes, first_success):
    """One pass over ``(R, T)`` records, adding per iteration, run by run in order, the latest
    finished episode's success, terminal flag and average reward, the count of runs with a
    finished episode, and episodes finished so far into ``(G, T)`` float64 accumulators, run
    ``first_run + r`` adding to group ``(first_run + r) % G``; ``first_success[r]`` = iteration
    count (1-based) at which run r finished its first successful episode, 0 if it never did.

    Runs are added in order, so feeding runs 0..R-1 in several calls gives bit-identical sums."""
    n_runs, n_iterations = rewards.shape
    n_groups = success.shape[0]
    for r in range(n_runs):
        g = (first_run + r) % n_groups
        episode_return = 0.0
        length = 0
        improper = 0
        finished = 0
        latest_success = 0.0
        latest_terminal = 0.0
        latest_average = 0.0
        first_success[r] = 0
        for t in range(n_iterations):
            episode_return += rewards[r, t]
            length += 1
            if outcomes[r, t] == _IMPROPER:
                improper += 1
            if episode_end[r, t] != 0:
                finished += 1
                latest_terminal = 1.0 if episode_end[r, t] == _TERMINAL_END else 0.0
                latest_success = latest_terminal if improper == 0 else 0.0
                if latest_success > 0.0 and first_success[r] == 0:
                    first_success[r] = t + 1
                latest_average = episode_return / length
                episode_return = 0.0
                length = 0
                improper = 0
            success[g, t] += latest_success
            terminal[g, t] += latest_terminal
            episodes[g, t] += finished
            if finished > 0:
                average_sum[g, t] += latest_average
                finished_runs[g, t] += 1.0


@dataclass
class GroupedCurveSums:
    """:class:`CurveSums` kept per group of runs, for bootstrap intervals over runs.

    Run i adds to group ``i % G``; runs are independent, so the G group sums are independent and
    resampling groups resamples runs in blocks (:mod:`tableclean_suite.bench.statistics`).
    Memory is ``5 x G x T`` floats plus one integer per run, whatever the number of runs.

    Attributes (``(G, T)`` float64 unless said):
        success, terminal, average_sum, finished_runs, episodes: as in :class:`CurveSums`, per group.
        runs_per_group: ``(G,)`` float64, runs added to each group.
        first_success: per run added, in order, the iteration count (1-based, in [1, T]) at the end
            of its first successful episode, 0 if none within the window (int64 list of arrays).
    """

    success: np.ndarray
    terminal: np.ndarray
    average_sum: np.ndarray
    finished_runs: np.ndarray
    episodes: np.ndarray
    runs_per_group: np.ndarray
    first_success: list = field(default_factory=list)

    @classmethod
    def zeros(cls, iterations: int, groups: int) -> "GroupedCurveSums":
        """Empty sums for ``groups`` (>= 1) groups of curves of length ``iterations`` (>= 1)."""
        if iterations < 1 or groups < 1:
            raise ValueError(f"iterations and groups must be >= 1, got {iterations!r}, {groups!r}")
        return cls(*(np.zeros((int(groups), int(iterations))) for _ in range(5)), np.zeros(int(groups)))

    @property
    def runs(self) -> int:
        return int(self.runs_per_group.sum())

    @property
    def groups(self) -> int:
        return int(self.success.shape[0])

    @property
    def iterations(self) -> int:
        return int(self.success.shape[1])

    def add(self, result) -> "GroupedCurveSums":
        """Add the runs of a :class:`TrainingResult`, the next ones in run order; returns self."""
        runs, iterations = result.rewards.shape
        if iterations != self.iterations:
            raise ValueError(f"result has {iterations} iterations, the sums {self.iterations}")
        first = np.zeros(runs, dtype=np.int64)
        _grouped_curves(result.rewards, result.outcomes, result.episode_end, self.runs, self.success, self.terminal,
                        self.average_sum, self.finished_runs, self.episodes, first)
        self.runs_per_group += np.bincount((self.runs + np.arange(runs)) % self.groups, minlength=self.groups)
        self.first_success.append(first)
        return self

    def first_success_iterations(self) -> np.ndarray:
        """``(R,)`` float64: iterations to each run's first successful episode, NaN if none."""
        first = np.concatenate(self.first_success) if self.first_success else np.zeros(0, dtype=np.int64)
        return np.where(first > 0, first, np.nan).astype(float)

    def totals(self) -> CurveSums:
        """The :class:`CurveSums` of all runs (sums over groups)."""
        return CurveSums(self.success.sum(0), self.terminal.sum(0), self.average_sum.sum(0),
                         self.finished_runs.sum(0), self.episodes.sum(0), self.runs)


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
    curve, threshold: float = DEFAULT_THRESHOLD, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION,
    top: float | None = None,
) -> int | None:
    """First iteration count t (1-based) with ``curve[t-1] >= threshold * plateau``; None if never.

    ``top`` is the plateau (e.g. the asymptote); default the window mean of ``curve``.
    """
    _check_fraction("threshold", threshold)
    curve = np.asarray(curve, dtype=float)
    top = plateau(curve, plateau_fraction) if top is None else float(top)
    return first_reaching(curve, threshold * top)


def first_reaching(curve, level: float, start: int = 0) -> int | None:
    """First iteration count t (1-based, > ``start``) with ``curve[t-1] >= level``; None if never
    or if ``level`` is not finite."""
    if not math.isfinite(level):
        return None
    hits = np.nonzero(np.asarray(curve, dtype=float)[start:] >= level)[0]
    return start + int(hits[0]) + 1 if len(hits) else None


def early_minimum(curve, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION, top: float | None = None) -> int | None:
    """Index (0-based) of the curve's early extreme, NaNs ignored; None if there is none.

    With ``top`` (an asymptote): the point furthest from ``top`` among the defined points before
    the curve first reaches ``top`` from its starting side (the whole curve if it never does):
    the early minimum of a curve that rises to ``top``, the early maximum of one that starts above
    it and falls.  The window does not change it.  Without ``top``: the minimum before the plateau
    window (the last ``plateau_fraction``).
    """
    curve = np.asarray(curve, dtype=float)
    if top is None:
        window = max(1, math.ceil(len(curve) * plateau_fraction))
        early = curve[: max(1, len(curve) - window)]
        return None if np.all(np.isnan(early)) else int(np.nanargmin(early))
    index = _extremes(curve[None, :], np.array([float(top)]))[0]
    return None if index < 0 else int(index)


def _sides(curves: np.ndarray, tops: np.ndarray):
    """Per row of ``(B, T)`` curves: first defined index (-1 if none) and the side the curve starts
    on relative to its top (+1 above, -1 at or below)."""
    defined = ~np.isnan(curves)
    first = np.where(defined.any(axis=1), np.argmax(defined, axis=1), -1)
    start = curves[np.arange(len(curves)), np.maximum(first, 0)]
    return first, np.where(start > tops, 1.0, -1.0)


def _extremes(curves: np.ndarray, tops: np.ndarray) -> np.ndarray:
    """:func:`early_minimum` with tops, row by row of ``(B, T)`` curves; -1 where undefined."""
    first, side = _sides(curves, tops)
    t = np.arange(curves.shape[1])[None, :]
    with np.errstate(invalid="ignore"):
        deviation = side[:, None] * (curves - tops[:, None])
        crossed = (deviation <= 0) & (t >= first[:, None])
    crossing = np.where(crossed.any(axis=1), np.argmax(crossed, axis=1), curves.shape[1])
    segment = (t >= first[:, None]) & (t < np.maximum(crossing, first + 1)[:, None]) & ~np.isnan(curves)
    extreme = np.argmax(np.where(segment, deviation, -np.inf), axis=1)
    return np.where(first >= 0, extreme, -1)


def convergence_iterations(curves: np.ndarray, tops: np.ndarray, threshold: float = DEFAULT_THRESHOLD) -> np.ndarray:
    """Average-reward convergence of each row of ``(B, T)`` curves towards its top ``(B,)``:
    the first iteration count (1-based), at or after the early extreme (:func:`early_minimum`),
    at which the curve has covered ``threshold`` of the way from the extreme to the top.

    Returns:
        ``(B,)`` float64 iteration counts, NaN where never reached or undefined.
    """
    _check_fraction("threshold", threshold)
    curves, tops = np.atleast_2d(np.asarray(curves, dtype=float)), np.atleast_1d(np.asarray(tops, dtype=float))
    extreme = _extremes(curves, tops)
    _, side = _sides(curves, tops)
    rows = np.arange(len(curves))
    value = curves[rows, np.maximum(extreme, 0)]
    level = value + threshold * (tops - value)
    with np.errstate(invalid="ignore"):
        hit = (np.arange(curves.shape[1])[None, :] >= extreme[:, None]) & (side[:, None] * (curves - level[:, None]) <= 0)
    found = hit.any(axis=1) & (extreme >= 0) & np.isfinite(tops)
    return np.where(found, np.argmax(hit, axis=1) + 1.0, np.nan)


def reward_convergence_iteration(
    curve, threshold: float = DEFAULT_THRESHOLD, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION,
    top: float | None = None,
) -> int | None:
    """First iteration count t (1-based), at or after the early extreme, where the curve has
    covered ``threshold`` of the way from its early extreme (:func:`early_minimum`) to its plateau
    (``top``, default the window mean, for which the extreme is the early minimum); None if never."""
    _check_fraction("threshold", threshold)
    curve = np.asarray(curve, dtype=float)
    if top is not None:
        found = convergence_iterations(curve[None, :], np.array([float(top)]), threshold)[0]
        return None if np.isnan(found) else int(found)
    lowest = early_minimum(curve, plateau_fraction)
    top = plateau(curve, plateau_fraction)
    if lowest is None or not math.isfinite(top):
        return None
    level = curve[lowest] + threshold * (top - curve[lowest])
    return first_reaching(curve, level, lowest)


def episodes_at(episodes: np.ndarray, iteration: int | None) -> float | None:
    """Mean episodes finished by iteration count ``iteration`` (1-based), from :func:`episodes_curve`."""
    if iteration is None:
        return None
    return float(episodes[iteration - 1])


def maximum(curve) -> float:
    """The curve's maximum, NaNs ignored (NaN if all are)."""
    curve = np.asarray(curve, dtype=float)
    return float(np.nanmax(curve)) if np.any(~np.isnan(curve)) else float("nan")


@dataclass(frozen=True)
class Plateaus:
    """The values the curves tend to (e.g. :mod:`tableclean_suite.asymptotes` averaged over runs).

    Attributes:
        success: success rate, in [0, 1].
        average_reward: average reward, reward units per iteration.
        terminal: fraction of episodes reaching the terminal state, in [0, 1].
    """

    success: float
    average_reward: float
    terminal: float


def summarize(
    result, threshold: float = DEFAULT_THRESHOLD, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION,
    plateaus: Plateaus | None = None, support_fraction: float = 0.0,
) -> Summary:
    """Table 3 quantities of one training result, plus the curves they came from.

    Args:
        result: a :class:`~tableclean_suite.learners.TrainingResult`, or the :class:`CurveSums`
            of one accumulated chunk by chunk (same numbers).
        threshold: fraction of the plateau that counts as reached, in (0, 1].
        plateau_fraction: final fraction of the window averaged as the window mean, in (0, 1].
        plateaus: the curves' asymptotes (:class:`Plateaus`); None: the window means stand in
            for them (and then every figure moves with the window).
        support_fraction: fraction of runs, in [0, 1], that must have finished an episode before
            an average-reward point counts (0: one run is enough).

    Returns:
        A :class:`Summary`.
    """
    sums = result if isinstance(result, CurveSums) else curve_sums(result)
    curves = sums.curves(support_fraction)
    success, average, episodes, terminal = (
        curves["success"], curves["average_reward"], curves["episodes"], curves["terminal"]
    )
    window = {name: plateau(curves[name], plateau_fraction) for name in ("success", "average_reward", "terminal")}
    top = window if plateaus is None else {name: float(getattr(plateaus, name)) for name in window}
    given = plateaus is not None
    success_at = iterations_to_max_success(success, threshold, plateau_fraction, top["success"])
    reward_at = reward_convergence_iteration(average, threshold, plateau_fraction,
                                             top["average_reward"] if given else None)
    return Summary(
        max_success_iterations=success_at,
        max_success_episodes=episodes_at(episodes, success_at),
        reward_convergence_iterations=reward_at,
        reward_convergence_episodes=episodes_at(episodes, reward_at),
        success_plateau=top["success"],
        max_average_reward=maximum(average),
        average_reward_plateau=top["average_reward"],
        terminal_plateau=top["terminal"],
        success_window_mean=window["success"],
        average_reward_window_mean=window["average_reward"],
        success=success,
        average_reward=average,
        terminal=terminal,
        episodes=episodes,
    )


def batch_scalars(sums: dict, runs: np.ndarray, plateaus: dict, threshold: float = DEFAULT_THRESHOLD,
                  plateau_fraction: float = DEFAULT_PLATEAU_FRACTION, support_fraction: float = 0.0,
                  keep=None, episode_sums=None) -> tuple[dict, dict]:
    """:func:`summarize` of B sets of sums at once (e.g. bootstrap replicates), same definitions.

    Args:
        sums: ``{"success", "average_sum", "finished_runs": (B, T)}`` and, unless ``episode_sums``
            is given, ``"episodes": (B, T)``.
        runs: ``(B,)`` runs behind each set.
        plateaus: ``{"success", "average_reward", "terminal": (B,)}`` asymptotes.
        keep: iteration indices of the curves to return (default all).
        episode_sums: ``f(indices (B,) int) -> (B,)`` episode sums of each set at its index (so
            that the ``(B, T)`` episode sums need not be built).

    Returns:
        ``({scalar: (B,) float64, NaN where None}, {"success", "average_reward": (B, len(keep))}``.
    """
    runs = np.asarray(runs, dtype=float)
    rows = np.arange(len(runs))
    if episode_sums is None:
        episode_sums = lambda index: sums["episodes"][rows, index]  # noqa: E731
    with np.errstate(invalid="ignore", divide="ignore"):
        average = np.where(supported(sums["finished_runs"], runs[:, None], support_fraction),
                           sums["average_sum"] / np.maximum(sums["finished_runs"], 1.0), np.nan)
    curves = {"success": sums["success"] / runs[:, None], "average_reward": average}
    tops = {name: np.asarray(plateaus[name], dtype=float) for name in ("success", "average_reward", "terminal")}
    window = max(1, math.ceil(curves["success"].shape[1] * plateau_fraction))

    def window_mean(curve):
        tail = curve[:, -window:]
        defined = ~np.isnan(tail)
        with np.errstate(invalid="ignore"):
            return np.where(defined.any(axis=1), np.nansum(tail, axis=1) / np.maximum(defined.sum(axis=1), 1), np.nan)

    with np.errstate(invalid="ignore"):
        reached = curves["success"] >= (threshold * tops["success"])[:, None]
    success_at = np.where(reached.any(axis=1) & np.isfinite(tops["success"]), np.argmax(reached, axis=1) + 1.0, np.nan)
    reward_at = convergence_iterations(curves["average_reward"], tops["average_reward"], threshold)

    def episodes(at):
        return np.where(np.isnan(at), np.nan, episode_sums(np.nan_to_num(at, nan=1).astype(int) - 1) / runs)

    defined = ~np.isnan(average)
    scalars = {
        "max_success_iterations": success_at,
        "max_success_episodes": episodes(success_at),
        "reward_convergence_iterations": reward_at,
        "reward_convergence_episodes": episodes(reward_at),
        "success_plateau": tops["success"],
        "max_average_reward": np.where(defined.any(axis=1), np.max(np.where(defined, average, -np.inf), axis=1),
                                       np.nan),
        "average_reward_plateau": tops["average_reward"],
        "terminal_plateau": tops["terminal"],
        "success_window_mean": window_mean(curves["success"]),
        "average_reward_window_mean": window_mean(average),
    }
    keep = slice(None) if keep is None else keep
    return scalars, {"success": curves["success"][:, keep], "average_reward": average[:, keep]}
