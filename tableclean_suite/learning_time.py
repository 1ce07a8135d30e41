"""How long each run takes to learn the task, summarised over runs with censoring.

A run's learning time is ``TrainingResult.learned_at`` (iterations; -1: not optimal at the budget
T, right-censored at T).  [learning_time_summary][tableclean_suite.learning_time.learning_time_summary]
gives the Kaplan-Meier median and quartiles with their Brookmeyer-Crowley intervals, the restricted
mean (RMST) with a bootstrap interval over runs, and the censored share with its Clopper-Pearson
interval.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass

import numpy as np

from tableclean_suite import intervals

#: The survival levels of the quartiles: first quartile, median, third quartile.
QUARTILE_LEVELS = {"q1": 0.75, "median": 0.5, "q3": 0.25}
#: How the pointwise band of the survival curve is built (``scipy.stats`` method name).
BAND_METHOD = "log-log"


@dataclass(frozen=True)
class LearningTime:
    """Per-run learning times of R runs with budget T, summarised.

    Times are in iterations (environment steps); +inf means beyond the budget; NaN: no runs.

    Attributes:
        runs: R, the runs summarised (censored included), >= 0.
        budget: T, the iterations each run trained.
        median, median_low, median_high: the Kaplan-Meier median and its interval.
        q1, q1_low, q1_high: the first quartile (a quarter of the runs have learned) and its interval.
        q3, q3_low, q3_high: the third quartile and its interval.
        rmst, rmst_low, rmst_high: the restricted mean time to the budget, in [0, T], and its interval.
        censored_share, censored_low, censored_high: the fraction of runs censored at T, in
            [0, 1], and its Clopper-Pearson interval.
        confidence: the intervals' two-sided confidence.
    """

    runs: int
    budget: int
    median: float
    median_low: float
    median_high: float
    q1: float
    q1_low: float
    q1_high: float
    q3: float
    q3_low: float
    q3_high: float
    rmst: float
    rmst_low: float
    rmst_high: float
    censored_share: float
    censored_low: float
    censored_high: float
    confidence: float

    def as_dict(self) -> dict:
        """``{field: value}`` in field order."""
        return asdict(self)


def censored_times(learned_at, budget: int) -> tuple[np.ndarray, np.ndarray]:
    """``(times, censored)``, float64 and bool ``(R,)``: each run's time, the budget for a censored run.

    Raises:
        ValueError: naming the bad value, unless ``learned_at`` is 1-D with every entry -1 (censored)
            or an integer in [0, ``budget``], and ``budget`` an integer >= 1.
    """
    values = np.asarray(learned_at)
    if values.ndim != 1:
        raise ValueError(f"learned_at must be a 1-D array (one time per run), got shape {values.shape}")
    if int(budget) != budget or budget < 1:
        raise ValueError(f"budget must be an integer >= 1 (iterations), got {budget!r}")
    bad = values[(values != np.round(values)) | (values < -1) | (values > budget)]
    if bad.size:
        raise ValueError(f"learned_at holds {bad[0]!r}: allowed are -1 (not learned by the budget) and integers "
                         f"in [0, {int(budget)}]")
    censored = values < 0
    return np.where(censored, int(budget), values.astype(np.int64)).astype(np.float64), censored


def survival(learned_at, budget: int):
    """The Kaplan-Meier estimate of S(t) = P(learning time > t): ``scipy.stats.ecdf``'s result
    (its ``sf`` evaluates and bands it) for runs censored at ``budget``."""
    from scipy import stats

    times, censored = censored_times(learned_at, budget)
    return stats.ecdf(stats.CensoredData(uncensored=times[~censored], right=times[censored]))


def survival_curve(learned_at, budget: int, confidence: float = intervals.DEFAULT_CONFIDENCE
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(S, low, high)``, each ``(T,)``: the Kaplan-Meier curve S(t) = P(learning time > t), the
    share of runs not yet optimal for good, at t = 1 .. T, and its pointwise ``confidence`` band."""
    at = np.arange(1, int(budget) + 1)
    return _survival_band(learned_at, budget, intervals.check_confidence(confidence), at)[1:]


def _survival_band(learned_at, budget: int, confidence: float, at=None):
    """``(at, S, low, high)`` at the times ``at`` (default: the curve's own steps): the Kaplan-Meier
    fit and its pointwise log-log band, which is the curve itself where undefined (S = 0 or 1)."""
    fit = survival(learned_at, budget).sf
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        band = fit.confidence_interval(confidence, method=BAND_METHOD)
    at = fit.quantiles if at is None else at
    curve, low, high = fit.evaluate(at), band.low.evaluate(at), band.high.evaluate(at)
    return at, curve, np.where(np.isnan(low), curve, low), np.where(np.isnan(high), curve, high)


def _crossing(times: np.ndarray, probabilities: np.ndarray, level: float) -> float:
    """The first time at which a right-continuous step survival curve is <= ``level`` (+inf if never)."""
    with np.errstate(invalid="ignore"):
        hits = np.nonzero(probabilities <= level + 1e-12)[0]
    return float(times[hits[0]]) if len(hits) else math.inf


def learning_time_summary(learned_at, budget: int, confidence: float = intervals.DEFAULT_CONFIDENCE,
                          reps: int = intervals.DEFAULT_REPS, method: str = "percentile",
                          rng: np.random.Generator | None = None) -> LearningTime:
    """The [`LearningTime`][tableclean_suite.learning_time.LearningTime] summary of per-run learning
    times (all NaN but ``runs`` and ``budget`` when R = 0).

    Args:
        learned_at: ``(R,)`` integers, -1 (censored at the budget) or in [0, ``budget``]
            (``TrainingResult.learned_at``).
        budget: T, the iterations each run trained, >= 1.
        confidence: two-sided confidence of every interval, in (0, 1).
        reps, method, rng: the RMST's bootstrap
            ([`interval_estimates`][tableclean_suite.intervals.interval_estimates]).
    """
    confidence = intervals.check_confidence(confidence)
    times, censored = censored_times(learned_at, budget)
    runs = len(times)
    if runs == 0:
        return LearningTime(0, int(budget), *([math.nan] * 15), confidence)
    steps, *curves = _survival_band(learned_at, budget, confidence)
    quantiles = {name: tuple(_crossing(steps, curve, level) for curve in curves)
                 for name, level in QUARTILE_LEVELS.items()}
    points, bounds = intervals.mean_intervals({"rmst": times}, {"rmst": (0.0, float(budget))}, confidence, reps,
                                              method, rng)
    share_low, share_high = intervals.clopper_pearson(int(censored.sum()), runs, confidence)
    return LearningTime(runs, int(budget), *quantiles["median"], *quantiles["q1"], *quantiles["q3"],
                        points["rmst"], *bounds["rmst"], float(censored.mean()), share_low, share_high, confidence)
