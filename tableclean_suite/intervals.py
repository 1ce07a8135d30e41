"""Confidence intervals over independent, identically distributed runs.

[interval_estimates][tableclean_suite.intervals.interval_estimates] is the one bootstrap API
(rliable-shaped: a statistic of each entry of a dict of per-run scores, ``scipy.stats.bootstrap``;
a tuple of arrays is a set of strata); beside it the exact binomial interval
([clopper_pearson][tableclean_suite.intervals.clopper_pearson]), the normal interval of a mean
curve ([mean_band][tableclean_suite.intervals.mean_band]) and the probability of improvement.  An
interval of a statistic of R runs targets that statistic of the runs' distribution.
"""

from __future__ import annotations

import math

import numpy as np

from tableclean_suite.executors.base import check_count

#: Two-sided confidence of the intervals.
DEFAULT_CONFIDENCE = 0.95
#: Bootstrap resamples per interval (every command's default).
DEFAULT_REPS = 1000
#: Bootstrap interval methods ``scipy.stats.bootstrap`` offers that the API accepts.
METHODS = ("percentile", "bca")


def check_confidence(confidence: float) -> float:
    """``confidence`` as a float; ``ValueError`` naming it unless it lies in (0, 1)."""
    if not 0.0 < float(confidence) < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    return float(confidence)


def _samples(values) -> tuple[np.ndarray, ...]:
    """An entry of ``scores`` as a tuple of 1-D arrays (one per stratum): integers stay integers
    (e.g. run indices), anything else becomes float64."""
    samples = tuple(np.asarray(s) if np.asarray(s).dtype.kind in "iu" else np.asarray(s, dtype=np.float64)
                    for s in (values if isinstance(values, tuple) else (values,)))
    for sample in samples:
        if sample.ndim != 1:
            raise ValueError(f"per-run scores must be 1-D arrays (one value per run), got shape {sample.shape}")
    return samples


def interval_estimates(scores: dict, func, confidence: float = DEFAULT_CONFIDENCE, reps: int = DEFAULT_REPS,
                       method: str = "percentile", rng: np.random.Generator | None = None
                       ) -> tuple[dict[str, float], dict[str, tuple[float, float]]]:
    """Point estimates and bootstrap intervals over runs of ``func`` of each entry of ``scores``.

    Args:
        scores: ``{name: (R,) array}`` per-run scores, or ``{name: ((R1,), (R2,), ...)}`` strata
            resampled separately (``func`` then takes one array per stratum).
        func: the statistic, vectorised as ``scipy.stats.bootstrap`` needs it:
            ``func(*samples, axis=-1)`` reduces the last axis (e.g. ``np.mean``).
        confidence: two-sided confidence, in (0, 1).
        reps: bootstrap resamples, >= 1.
        method: ``"percentile"`` or ``"bca"`` (bias-corrected and accelerated).
        rng: the resamples' generator (None: ``np.random.default_rng(0)``); entries draw from it
            in the order of ``scores``, so a seeded generator gives the same intervals anywhere.

    Returns:
        ``(points, intervals)``: ``{name: float}`` and ``{name: (low, high)}``.  The interval is
        ``(v, v)`` when every run of every stratum has the same value v (no spread to resample),
        and ``(nan, nan)`` when a stratum has fewer than 2 runs or the point is not finite.
    """
    confidence = check_confidence(confidence)
    check_count("reps", reps, 1)
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    from scipy import stats

    rng = np.random.default_rng(0) if rng is None else rng
    points, intervals = {}, {}
    for name, values in scores.items():
        samples = _samples(values)
        point = float(func(*samples, axis=-1))
        points[name] = point
        if not math.isfinite(point) or min(len(s) for s in samples) < 2:
            intervals[name] = (math.nan, math.nan)
        elif all(np.all(s == s[0]) for s in samples):
            intervals[name] = (point, point)
        else:
            result = stats.bootstrap(samples, func, n_resamples=int(reps), confidence_level=confidence,
                                     method=method, vectorized=True, rng=rng)
            interval = result.confidence_interval
            intervals[name] = (float(interval.low), float(interval.high))
    return points, intervals


def clopper_pearson(successes: int, trials: int, confidence: float = DEFAULT_CONFIDENCE,
                    alternative: str = "two-sided") -> tuple[float, float]:
    """The exact (Clopper-Pearson) interval of a binomial proportion ``successes / trials``.

    ``alternative`` is ``scipy.stats.binomtest``'s: ``"greater"`` gives the one-sided ``(lower
    bound, 1)``, ``"less"`` ``(0, upper bound)``.  It covers the probability that one run has the
    property counted with at least ``confidence``, whatever that probability.  ``(nan, nan)``
    without trials.
    """
    confidence = check_confidence(confidence)
    if trials < 1:
        return math.nan, math.nan
    from scipy import stats

    interval = stats.binomtest(int(successes), int(trials), alternative=alternative).proportion_ci(confidence,
                                                                                                   method="exact")
    return float(interval.low), float(interval.high)


def mean_band(sums, squares, counts, confidence: float = DEFAULT_CONFIDENCE) -> tuple[np.ndarray, np.ndarray]:
    """Per-iteration normal intervals of a mean curve over runs, from sums over runs.

    At each iteration the curve is the mean of ``counts`` independent bounded per-run values;
    the interval is ``mean +- z * s / sqrt(n)`` with ``s`` the sample standard deviation from
    the sums and sums of squares (central limit theorem; its target is the expected value of one
    run's value at that iteration).

    Args:
        sums, squares, counts: ``(T,)`` sums, sums of squares and numbers of the per-run values.

    Returns:
        ``(low, high)``, each ``(T,)``; NaN where fewer than 2 values.
    """
    from statistics import NormalDist

    z = NormalDist().inv_cdf(0.5 + check_confidence(confidence) / 2)
    sums, squares, counts = (np.asarray(a, dtype=np.float64) for a in (sums, squares, counts))
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = sums / counts
        variance = np.maximum(squares - counts * mean ** 2, 0.0) / (counts - 1)
        half = z * np.sqrt(variance / counts)
    defined = counts >= 2
    return np.where(defined, mean - half, np.nan), np.where(defined, mean + half, np.nan)


def probability_of_improvement(x, y, higher_is_better: bool = True, margin: float = 0.0) -> float:
    """P(a run of X beats a run of Y by more than ``margin``) + P(they tie) / 2, over all pairs.

    rliable's definition for ``margin = 0``.  With a practical-equivalence ``margin`` (>= 0, in
    the score's units) a pair is a tie when ``|x - y| <= margin``.  Equal values always tie.
    """
    return float(_Improvement(x, y, higher_is_better, margin)(np.arange(len(x)), np.arange(len(y))))


class _Improvement:
    """[`probability_of_improvement`][tableclean_suite.intervals.probability_of_improvement] of resamples
    given as run *indices* into fixed X and Y, by counting y ranks (exact integers, any order),
    never forming the pairs; index arrays' leading axes broadcast as ``scipy.stats.bootstrap`` passes them."""

    def __init__(self, x, y, higher_is_better: bool, margin: float):
        if not margin >= 0:
            raise ValueError(f"margin must be a number >= 0 (score units), got {margin!r}")
        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        if not higher_is_better:
            x, y = -x, -y
        distinct = np.unique(y)
        self.width = len(distinct) + 1
        self.y_rank = np.searchsorted(distinct, y) + 1
        with np.errstate(invalid="ignore"):
            self.beaten = np.searchsorted(distinct, x - margin, side="left")  # ranks of y < x - margin
            self.not_above = np.searchsorted(distinct, x + margin, side="right")  # ranks of y <= x + margin

    def __call__(self, ix, iy, axis=-1):
        ix, iy = np.moveaxis(np.asarray(ix), axis, -1), np.moveaxis(np.asarray(iy), axis, -1)
        lead = np.broadcast_shapes(ix.shape[:-1], iy.shape[:-1])
        nx, ny = ix.shape[-1], iy.shape[-1]
        ix = np.broadcast_to(ix, (*lead, nx)).reshape(-1, nx)
        iy = np.broadcast_to(iy, (*lead, ny)).reshape(-1, ny)
        rows = len(iy)
        codes = self.y_rank[iy] + np.arange(0, rows * self.width, self.width)[:, None]
        counts = np.bincount(codes.ravel(), minlength=rows * self.width).reshape(rows, self.width)
        below = np.cumsum(counts, axis=1, dtype=np.int32)  # below[b, k]: y of resample b among the k smallest
        beaten = np.take_along_axis(below, self.beaten[ix], axis=1)
        not_above = np.take_along_axis(below, self.not_above[ix], axis=1)
        # wins + ties / 2 = (beaten + not_above) / 2: integer sums, exact in any order
        return ((beaten.sum(axis=1, dtype=np.int64) + not_above.sum(axis=1, dtype=np.int64)) * 0.5
                / (nx * ny)).reshape(lead)


def unseen_share(runs: int, confidence: float = DEFAULT_CONFIDENCE) -> float:
    """The largest share of all runs that ``runs`` independent runs can all have missed, at ``confidence``.

    ``1 - ((1 - confidence) / 2) ** (1 / runs)``: the exact (Clopper-Pearson) upper bound on the
    probability of an outcome seen in none of the runs (about 3.7 / ``runs`` at 95 %), which a
    bootstrap of the sample cannot reach.
    """
    check_count("runs", runs, 1)
    return 1.0 - ((1.0 - check_confidence(confidence)) / 2.0) ** (1.0 / runs)


def widened_for_unseen_runs(low: float, high: float, values, limits: tuple[float, float],
                            confidence: float = DEFAULT_CONFIDENCE) -> tuple[float, float]:
    """An interval ``(low, high)`` of the mean of per-run ``values`` (shape ``(R,)``, each within
    ``limits``), widened by what runs absent from the sample could move that mean.

    With s = [unseen_share][tableclean_suite.intervals.unseen_share], the ends move by
    ``s x (min(values) - limits[0])`` down and ``s x (limits[1] - max(values))`` up, within ``limits``.
    """
    values = np.asarray(values, dtype=np.float64)
    share = unseen_share(len(values), confidence)
    bottom, top = limits
    return (max(bottom, low - share * (float(values.min()) - bottom)),
            min(top, high + share * (top - float(values.max()))))


def mean_intervals(scores: dict, limits: dict, confidence: float = DEFAULT_CONFIDENCE, reps: int = DEFAULT_REPS,
                   method: str = "percentile", rng: np.random.Generator | None = None
                   ) -> tuple[dict[str, float], dict[str, tuple[float, float]]]:
    """``(points, intervals)`` of the mean over runs of each ``(R,)`` entry of ``scores``: the bootstrap
    interval ([`interval_estimates`][tableclean_suite.intervals.interval_estimates] of ``np.mean``)
    widened for unseen runs ([`widened_for_unseen_runs`][tableclean_suite.intervals.widened_for_unseen_runs])
    within ``limits[name]``, ``(low, high)`` bounds on one run's value."""
    points, bounds = interval_estimates(scores, np.mean, confidence, reps, method, rng)
    return points, {name: widened_for_unseen_runs(*bounds[name], values, limits[name], confidence)
                    for name, values in scores.items()}


def improvement_estimate(x, y, higher_is_better: bool = True, margin: float = 0.0,
                         confidence: float = DEFAULT_CONFIDENCE, reps: int = DEFAULT_REPS,
                         method: str = "percentile", rng: np.random.Generator | None = None
                         ) -> tuple[float, float, float]:
    """``(P, low, high)``: [`probability_of_improvement`][tableclean_suite.intervals.probability_of_improvement]
    with a stratified bootstrap interval (X's runs and Y's runs resampled separately), each end moved
    out by the share of pairs that runs of a kind absent from both samples could take part in
    ([unseen_share][tableclean_suite.intervals.unseen_share] of X plus that of Y), within [0, 1].
    The interval targets the probability that a new run of X beats a new run of Y (ties half)."""
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    runs = (np.arange(len(x)), np.arange(len(y)))  # resampled as run indices
    points, intervals = interval_estimates({"p": runs}, _Improvement(x, y, higher_is_better, margin), confidence,
                                           reps, method, rng)
    # runs of X or Y of a kind neither sample holds take part in at most a share sx + sy of the pairs
    unseen = unseen_share(len(x), confidence) + unseen_share(len(y), confidence)
    low, high = intervals["p"]
    return points["p"], max(0.0, low - unseen), min(1.0, high + unseen)
