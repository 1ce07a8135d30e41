"""The scaling study's statistics: plateau verdicts, bootstrap intervals, growth exponents, reward order.

Quantities follow :mod:`tableclean_suite.metrics`: "maximum success" is the first iteration
at which the mean success curve reaches ``THRESHOLD`` of its plateau, the plateau the mean
over the final ``PLATEAU_FRACTION`` of the window.  Intervals are a percentile bootstrap over
run indices; the growth exponent is a least-squares slope on log-log axes with a t interval.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from tableclean_suite.bench.statistics import weighted_group_sums

if TYPE_CHECKING:
    from tableclean_suite.bench.scaling.study import CellRecords

#: Fraction of the plateau that counts as "maximum success" (metrics' default).
THRESHOLD = 0.95
#: Final fraction of the window averaged as the plateau (metrics' default).
PLATEAU_FRACTION = 0.25
#: A plateau window whose second half beats its first half by more than this (success fraction)
#: is still rising: the cell did not reach its plateau within the window.
PLATEAU_RISE_TOLERANCE = 0.02
#: Below this plateau (success fraction) "95 % of the plateau" is reached at once and means nothing.
MIN_PLATEAU = 0.01

#: Bootstrap resamples of the runs per cell.
DEFAULT_RESAMPLES = 1000
#: Level of every interval, in (0, 1).
CONFIDENCE = 0.95
#: The ordering the paper reports for Q-learning's iterations to maximum success (fewest first).
PAPER_ORDER = ("r4", "r2", "r1", "r3")


def plateau_rise(curve: np.ndarray, plateau_fraction: float = PLATEAU_FRACTION) -> float:
    """Mean of the plateau window's second half minus its first half (success fraction units)."""
    window = max(2, math.ceil(len(curve) * plateau_fraction))
    tail = np.asarray(curve, dtype=float)[-window:]
    half = len(tail) // 2
    return float(np.nanmean(tail[half:]) - np.nanmean(tail[:half]))


def plateau_verdict(curve: np.ndarray) -> tuple[bool, str]:
    """``(reached, reason)``: whether the success ``curve`` (``(T,)``) settled on a usable plateau."""
    from tableclean_suite import metrics

    top = metrics.plateau(curve, PLATEAU_FRACTION)
    rise = plateau_rise(curve)
    if not math.isfinite(top) or top < MIN_PLATEAU:
        return False, f"plateau {top:.3f} < {MIN_PLATEAU}"
    if rise > PLATEAU_RISE_TOLERANCE:
        return False, f"still rising by {rise:.3f} over the plateau window"
    return True, ""


def resample_counts(runs: int, resamples: int, seed: int) -> np.ndarray:
    """``(B, R)`` int: how often each run index is drawn in each bootstrap resample."""
    rng = np.random.default_rng(seed)
    return rng.multinomial(runs, np.full(runs, 1.0 / runs), size=resamples)


def bootstrap_cell(records: "CellRecords", counts: np.ndarray) -> dict:
    """Percentile intervals (``CONFIDENCE``) over run resamples of the cell's three figures.

    Args:
        records: the cell's grid samples, ``(R, G)``.
        counts: ``(B, R)`` resample counts of :func:`resample_counts`.

    Returns:
        ``{"iterations": (low, high), "episodes": (low, high), "plateau": (low, high)}``; the
        iteration ends are 1-based counts on the grid.
    """
    runs = records.success.shape[0]
    weights = counts.astype(np.float64) / runs
    success = weighted_group_sums(weights, records.success)  # (B, G); thread-count independent bits
    episodes = weighted_group_sums(weights, records.episodes)
    top = weighted_group_sums(weights, records.run_plateau)  # (B,): each run's full-resolution plateau-window mean
    hit = success >= THRESHOLD * top[:, None]
    first = np.where(hit.any(axis=1), np.argmax(hit, axis=1), len(records.grid) - 1)
    iterations = records.grid[first] + 1.0
    reached_episodes = episodes[np.arange(len(first)), first]
    tails = (100 * (1 - CONFIDENCE) / 2, 100 * (1 + CONFIDENCE) / 2)
    return {name: tuple(float(v) for v in np.percentile(values, tails))
            for name, values in (("iterations", iterations), ("episodes", reached_episodes), ("plateau", top))}


def fit_growth_exponent(x, y, confidence: float = CONFIDENCE) -> dict:
    """Least squares of ``log y`` on ``log x``: ``y ~ c * x ** exponent``.

    Args:
        x, y: positive sizes and values; pairs with a non-finite or non-positive member are skipped.
        confidence: level of the slope's interval, in (0, 1).

    Returns:
        ``{"exponent", "low", "high", "points"}``: the slope, its t interval (NaN with fewer
        than 3 points) and the number of points used (exponent NaN with fewer than 2).
    """
    from scipy import stats

    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    usable = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    points = int(usable.sum())
    if points < 2 or np.ptp(np.log(x[usable])) == 0:
        return {"exponent": math.nan, "low": math.nan, "high": math.nan, "points": points}
    fit = stats.linregress(np.log(x[usable]), np.log(y[usable]))
    if points < 3:
        return {"exponent": float(fit.slope), "low": math.nan, "high": math.nan, "points": points}
    half = stats.t.ppf((1 + confidence) / 2, points - 2) * fit.stderr
    return {"exponent": float(fit.slope), "low": float(fit.slope - half), "high": float(fit.slope + half),
            "points": points}


def order_holds(values: dict, order=PAPER_ORDER) -> bool | None:
    """Whether ``values[order[0]] < values[order[1]] < ...``; None if one is missing or NaN."""
    chosen = [values.get(name, math.nan) for name in order]
    if any(v is None or not math.isfinite(v) for v in chosen):
        return None
    return all(a < b for a, b in zip(chosen, chosen[1:]))
