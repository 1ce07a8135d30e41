"""The paper's learning-speed quantities (Table 3), as pure functions.

Inputs are [`TrainingResult`][tableclean_suite.learners.train.TrainingResult] records (R runs x T
iterations) or 1-D curves of length T ([curves][tableclean_suite.curves]).  Iteration and episode
counts are readings of the mean curves (first touch, held reaching, average-reward convergence),
with no interval; plateaus are the exact asymptotes ([asymptotes][tableclean_suite.asymptotes]) or,
without them, the window mean.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from tableclean_suite.curves import CurveSums, check_fraction, curve_sums
from tableclean_suite.executors.base import check_count

#: Fraction of the plateau that counts as reached, in (0, 1].
DEFAULT_THRESHOLD = 0.95
#: Final fraction of the window whose mean is the window mean, in (0, 1].
DEFAULT_PLATEAU_FRACTION = 0.25
#: Iterations the success curve must stay at or above its level for "held" reaching (longer than
#: the paper's fastest figure, 140).
DEFAULT_HOLD = 200

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
            [`summarize`][tableclean_suite.metrics.summarize] was given one, else the window mean).
        max_average_reward: maximum of the (supported) average-reward curve (reward units per iteration).
        average_reward_plateau: plateau of the average-reward curve (reward units per iteration).
        terminal_plateau: plateau of the terminal curve, a fraction in [0, 1].
        success_window_mean: mean of the success curve's last ``plateau_fraction``, in [0, 1].
        average_reward_window_mean: mean of the average-reward curve's last ``plateau_fraction``.
        held_success_iterations: iterations (1-based count) until the success curve reaches
            ``threshold`` of its plateau and stays there for ``hold`` iterations, or None.
        held_success_episodes: mean episodes finished by then, >= 0, or None.
        greedy_success_plateau: exact success of the runs' final greedy policies (epsilon = 0),
            mean over runs, in [0, 1] (NaN without asymptotes).
        never_terminal_share: fraction of runs that never reached the terminal state in the
            window, in [0, 1] (NaN without asymptotes).
        success: ``(T,)`` success rate per iteration, in [0, 1].
        average_reward: ``(T,)`` average reward per iteration (NaN until some run finished an episode).
        terminal: ``(T,)`` fraction of runs whose latest episode reached the terminal state.
        episodes: ``(T,)`` mean episodes finished by each iteration.

    The curves are read-only arrays.
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
    held_success_iterations: int | None = _scalar("iterations")
    held_success_episodes: float | None = _scalar("episodes")
    greedy_success_plateau: float = _scalar("fraction")
    never_terminal_share: float = _scalar("fraction")
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

    def scalars(self) -> dict:
        """``{name: value}`` of the scalar fields, in `SUMMARY_SCALARS` order."""
        return {name: getattr(self, name) for name in SUMMARY_SCALARS}

    def curves(self) -> dict[str, np.ndarray]:
        """``{name: (T,) array}`` of the curves, in `CURVE_NAMES` order."""
        return {name: getattr(self, name) for name in CURVE_NAMES}


#: Scalar fields of [`Summary`][tableclean_suite.metrics.Summary] (the Table 3 columns), in table order.
SUMMARY_SCALARS = tuple(f.name for f in fields(Summary) if f.metadata["role"] == _SCALAR)
#: Scalar fields counted in iterations (integers, or None when never reached).
ITERATION_SCALARS = tuple(f.name for f in fields(Summary) if f.metadata["role"] == _SCALAR
                          and f.metadata["unit"] == "iterations")
#: Curve fields of [`Summary`][tableclean_suite.metrics.Summary], each ``(T,)``.
CURVE_NAMES = tuple(f.name for f in fields(Summary) if f.metadata["role"] == _CURVE)


def plateau_start(window: int, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION) -> int:
    """0-based first iteration of the last ``plateau_fraction`` of a window of ``window`` iterations (at least one)."""
    return window - max(1, math.ceil(window * plateau_fraction))


def plateau(curve, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION) -> float:
    """Mean of the last ``plateau_fraction`` (in (0, 1]) of ``curve``, NaNs ignored (NaN if all are)."""
    check_fraction("plateau_fraction", plateau_fraction)
    curve = np.asarray(curve, dtype=float)
    tail = curve[plateau_start(len(curve), plateau_fraction):]
    return float(np.nanmean(tail)) if np.any(~np.isnan(tail)) else float("nan")


def iterations_to_max_success(
    curve, threshold: float = DEFAULT_THRESHOLD, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION,
    top: float | None = None,
) -> int | None:
    """First iteration count t (1-based) with ``curve[t-1] >= threshold * top``; None if never.

    ``top`` is the plateau (e.g. the asymptote); default the window mean of ``curve``.
    """
    check_fraction("threshold", threshold)
    top = plateau(curve, plateau_fraction) if top is None else float(top)
    return first_reaching(curve, threshold * top)


def first_reaching(curve, level: float, start: int = 0, hold: int = 1) -> int | None:
    """First iteration count t (1-based, > ``start``) from which ``curve`` stays at or above ``level``
    for ``hold`` iterations (t .. t + hold - 1, all inside the window; NaN counts as below).

    ``hold`` is an integer >= 1 (1: the first touch).  None if no such t or ``level`` is not finite.
    """
    check_count("hold", hold, 1)
    hold = int(hold)
    above = np.asarray(curve, dtype=float)[start:] >= level
    if not math.isfinite(level) or len(above) < hold:
        return None
    misses = np.r_[0, np.cumsum(~above)]
    held = np.nonzero(misses[hold:] == misses[:len(above) - hold + 1])[0]
    return start + int(held[0]) + 1 if len(held) else None


def early_minimum(curve, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION, top: float | None = None) -> int | None:
    """Index (0-based) of the curve's early extreme, NaNs ignored; None if there is none.

    With ``top`` (an asymptote): the point furthest from ``top`` before the curve first reaches it
    from its starting side (an early maximum for a falling curve).  Without: the minimum before
    the plateau window.
    """
    curve = np.asarray(curve, dtype=float)
    if top is None:
        early = curve[: max(1, plateau_start(len(curve), plateau_fraction))]
        return None if np.all(np.isnan(early)) else int(np.nanargmin(early))
    defined = np.nonzero(~np.isnan(curve))[0]
    if not len(defined):
        return None
    first = int(defined[0])
    with np.errstate(invalid="ignore"):
        deviation = (1.0 if curve[first] > top else -1.0) * (curve[first:] - float(top))
        crossed = np.nonzero(deviation <= 0)[0]
    before = deviation[: max(int(crossed[0]), 1) if len(crossed) else len(deviation)]
    return first + int(np.argmax(np.where(np.isnan(before), -np.inf, before)))


def reward_convergence_iteration(
    curve, threshold: float = DEFAULT_THRESHOLD, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION,
    top: float | None = None,
) -> int | None:
    """First iteration count t (1-based), at or after the early extreme
    ([`early_minimum`][tableclean_suite.metrics.early_minimum]), where the curve has covered
    ``threshold`` of the way from that extreme to its plateau (``top``, default the window mean, for
    which the extreme is the early minimum); None if never."""
    check_fraction("threshold", threshold)
    curve = np.asarray(curve, dtype=float)
    extreme = early_minimum(curve, plateau_fraction, top)
    given = top is not None
    top = float(top) if given else plateau(curve, plateau_fraction)
    if extreme is None or not math.isfinite(top):
        return None
    value = curve[extreme]
    level = value + threshold * (top - value)
    if given and value > top:  # a falling curve: the first point at or below the level
        return first_reaching(-curve, -level, extreme)
    return first_reaching(curve, level, extreme)


@dataclass(frozen=True)
class Plateaus:
    """The values the curves tend to (e.g. [asymptotes][tableclean_suite.asymptotes] averaged over runs).

    Attributes:
        success: success rate, in [0, 1].
        average_reward: average reward, reward units per iteration.
        terminal: fraction of episodes reaching the terminal state, in [0, 1].
        greedy_success: success of the final greedy policies (epsilon = 0), in [0, 1] (NaN: unknown).
        never_terminal: fraction of runs that never reached the terminal state, in [0, 1] (NaN: unknown).
    """

    success: float
    average_reward: float
    terminal: float
    greedy_success: float = math.nan
    never_terminal: float = math.nan


#: The per-run quantities behind [`Plateaus`][tableclean_suite.metrics.Plateaus] (one field each), in field order.
PLATEAU_NAMES = tuple(f.name for f in fields(Plateaus))


def summarize(
    result, threshold: float = DEFAULT_THRESHOLD, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION,
    plateaus: Plateaus | None = None, support_fraction: float = 0.0, hold: int = DEFAULT_HOLD,
) -> Summary:
    """Table 3 quantities of one training result, plus the curves they came from.

    Args:
        result: a [`TrainingResult`][tableclean_suite.learners.train.TrainingResult], or the
            [`CurveSums`][tableclean_suite.curves.CurveSums] of one accumulated chunk by chunk (same numbers).
        threshold: fraction of the plateau that counts as reached, in (0, 1].
        plateau_fraction: final fraction of the window averaged as the window mean, in (0, 1].
        plateaus: the curves' asymptotes ([`Plateaus`][tableclean_suite.metrics.Plateaus]); None: the
            window means stand in for them (and then every figure moves with the window).
        support_fraction: fraction of runs, in [0, 1], that must have finished an episode before
            an average-reward point counts (0: one run is enough).
        hold: iterations the success curve must stay at its level for ``held_success_iterations``.

    Returns:
        A [`Summary`][tableclean_suite.metrics.Summary].
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
    held_at = first_reaching(success, threshold * top["success"], hold=hold)
    reward_at = reward_convergence_iteration(average, threshold, plateau_fraction,
                                             top["average_reward"] if given else None)

    def episodes_at(iteration):
        return None if iteration is None else float(episodes[iteration - 1])

    return Summary(
        max_success_iterations=success_at,
        max_success_episodes=episodes_at(success_at),
        reward_convergence_iterations=reward_at,
        reward_convergence_episodes=episodes_at(reward_at),
        success_plateau=top["success"],
        max_average_reward=float(np.nanmax(average)) if np.any(~np.isnan(average)) else math.nan,
        average_reward_plateau=top["average_reward"],
        terminal_plateau=top["terminal"],
        success_window_mean=window["success"],
        average_reward_window_mean=window["average_reward"],
        held_success_iterations=held_at,
        held_success_episodes=episodes_at(held_at),
        greedy_success_plateau=float(plateaus.greedy_success) if given else math.nan,
        never_terminal_share=float(plateaus.never_terminal) if given else math.nan,
        success=success,
        average_reward=average,
        terminal=terminal,
        episodes=episodes,
    )
