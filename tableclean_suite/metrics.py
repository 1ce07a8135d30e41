"""The paper's learning-speed quantities, defined precisely, as pure functions.

Inputs are [`TrainingResult`][tableclean_suite.learners.train.TrainingResult] records (R runs x T
iterations) or 1-D curves of length T ([`tableclean_suite.curves`][tableclean_suite.curves]).  The
iteration and episode counts are readings of the mean curves (the paper's definitions: first
touch, held reaching, average-reward convergence), with no interval; plateaus are the exact
asymptotes ([`tableclean_suite.asymptotes`][tableclean_suite.asymptotes]) or, without them, the
window mean.  Definitions: [`Summary`][tableclean_suite.metrics.Summary] and the *Learners and
statistics* docs page.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from tableclean_suite.curves import CurveSums, check_fraction, curve_sums

DEFAULT_THRESHOLD = 0.95
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

    The curves are read-only arrays; ``summary["name"]`` reads a field too.
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

    @property
    def iterations(self) -> int:
        """T, the length of every curve."""
        return len(self.success)

    def scalars(self) -> dict:
        """``{name: value}`` of the scalar fields, in `SUMMARY_SCALARS` order."""
        return {name: getattr(self, name) for name in SUMMARY_SCALARS}

    def curves(self) -> dict[str, np.ndarray]:
        """``{name: (T,) array}`` of the curves, in `CURVE_NAMES` order."""
        return {name: getattr(self, name) for name in CURVE_NAMES}

    def __contains__(self, name) -> bool:
        return name in SUMMARY_SCALARS or name in CURVE_NAMES

    def __getitem__(self, name: str):
        if name not in self:
            raise KeyError(f"{name!r} is not a Summary field; fields: {', '.join(SUMMARY_SCALARS + CURVE_NAMES)}")
        return getattr(self, name)


#: Scalar fields of [`Summary`][tableclean_suite.metrics.Summary] (the Table 3 columns), in table order.
SUMMARY_SCALARS = tuple(f.name for f in fields(Summary) if f.metadata["role"] == _SCALAR)
#: Scalar fields counted in iterations (integers, or None when never reached).
ITERATION_SCALARS = tuple(f.name for f in fields(Summary) if f.metadata["role"] == _SCALAR
                          and f.metadata["unit"] == "iterations")
#: Curve fields of [`Summary`][tableclean_suite.metrics.Summary], each ``(T,)``.
CURVE_NAMES = tuple(f.name for f in fields(Summary) if f.metadata["role"] == _CURVE)


def plateau(curve, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION) -> float:
    """Mean of the last ``plateau_fraction`` of ``curve`` (NaNs ignored)."""
    check_fraction("plateau_fraction", plateau_fraction)
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
    check_fraction("threshold", threshold)
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


def held_reaching(curves, levels, hold: int = DEFAULT_HOLD) -> np.ndarray:
    """First iteration count t (1-based) at which each row of ``curves`` reaches its level and
    stays at or above it for ``hold`` iterations (t .. t + hold - 1, all inside the window).

    Args:
        curves: ``(B, T)`` or ``(T,)`` curves (NaN counts as below the level).
        levels: ``(B,)`` or scalar levels.
        hold: iterations the curve must stay at or above the level, >= 1 (1: first touch).

    Returns:
        ``(B,)`` float64 iteration counts (``()`` for one curve), NaN where no t leaves a full hold
        inside the window or the level is not finite.
    """
    if int(hold) != hold or hold < 1:
        raise ValueError(f"hold must be an integer >= 1 (iterations), got {hold!r}")
    hold = int(hold)
    single = np.ndim(curves) == 1
    curves = np.atleast_2d(np.asarray(curves, dtype=float))
    levels = np.broadcast_to(np.asarray(levels, dtype=float), curves.shape[:1])
    length = curves.shape[1]
    if length < hold:
        found = np.full(len(curves), np.nan)
        return found[0] if single else found
    with np.errstate(invalid="ignore"):
        below = ~(curves >= levels[:, None])
    misses = np.concatenate([np.zeros((len(curves), 1)), np.cumsum(below, axis=1)], axis=1)
    clean = (misses[:, hold:] - misses[:, :length - hold + 1]) == 0  # (B, T - hold + 1): start t0 holds
    found = np.where(clean.any(axis=1) & np.isfinite(levels), np.argmax(clean, axis=1) + 1.0, np.nan)
    return found[0] if single else found


def early_minimum(curve, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION, top: float | None = None) -> int | None:
    """Index (0-based) of the curve's early extreme, NaNs ignored; None if there is none.

    With ``top`` (an asymptote): the point furthest from ``top`` before the curve first reaches it
    from its starting side (an early maximum for a falling curve).  Without: the minimum before
    the plateau window.
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
    """[`early_minimum`][tableclean_suite.metrics.early_minimum] with tops, row by row of ``(B, T)`` curves; -1 where undefined."""
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
    the first iteration count (1-based), at or after the early extreme ([`early_minimum`][tableclean_suite.metrics.early_minimum]),
    at which the curve has covered ``threshold`` of the way from the extreme to the top.

    Returns:
        ``(B,)`` float64 iteration counts, NaN where never reached or undefined.
    """
    check_fraction("threshold", threshold)
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
    covered ``threshold`` of the way from its early extreme ([`early_minimum`][tableclean_suite.metrics.early_minimum]) to its plateau
    (``top``, default the window mean, for which the extreme is the early minimum); None if never."""
    check_fraction("threshold", threshold)
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
    """Mean episodes finished by iteration count ``iteration`` (1-based), from [`episodes_curve`][tableclean_suite.curves.episodes_curve]."""
    if iteration is None:
        return None
    return float(episodes[iteration - 1])


def maximum(curve) -> float:
    """The curve's maximum, NaNs ignored (NaN if all are)."""
    curve = np.asarray(curve, dtype=float)
    return float(np.nanmax(curve)) if np.any(~np.isnan(curve)) else float("nan")


@dataclass(frozen=True)
class Plateaus:
    """The values the curves tend to (e.g. [`tableclean_suite.asymptotes`][tableclean_suite.asymptotes] averaged over runs).

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
PLATEAU_NAMES = ("success", "average_reward", "terminal", "greedy_success", "never_terminal")


def summarize(
    result, threshold: float = DEFAULT_THRESHOLD, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION,
    plateaus: Plateaus | None = None, support_fraction: float = 0.0, hold: int = DEFAULT_HOLD,
) -> Summary:
    """Table 3 quantities of one training result, plus the curves they came from.

    Args:
        result: a [`TrainingResult`][tableclean_suite.learners.train.TrainingResult], or the [`CurveSums`][tableclean_suite.curves.CurveSums]
            of one accumulated chunk by chunk (same numbers).
        threshold: fraction of the plateau that counts as reached, in (0, 1].
        plateau_fraction: final fraction of the window averaged as the window mean, in (0, 1].
        plateaus: the curves' asymptotes ([`Plateaus`][tableclean_suite.metrics.Plateaus]); None: the window means stand in
            for them (and then every figure moves with the window).
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
    held = float(held_reaching(success, threshold * top["success"], hold))
    held_at = None if math.isnan(held) else int(held)
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
        held_success_iterations=held_at,
        held_success_episodes=episodes_at(episodes, held_at),
        greedy_success_plateau=float(plateaus.greedy_success) if given else math.nan,
        never_terminal_share=float(plateaus.never_terminal) if given else math.nan,
        success=success,
        average_reward=average,
        terminal=terminal,
        episodes=episodes,
    )
