"""Per-run learning time's statistics for the scaling study (the method in full: docs/scaling.md).

The response is ``TrainingResult.learned_at`` ([train][tableclean_suite.learners.train]), -1 for a
run censored at the budget T (`learning_times`: +inf).  Every run of a cell shares T, so the
Kaplan-Meier median is the sample's lower median with censored runs at +inf (`lower_median`).
Intervals are percentile intervals of seeds-then-runs resamples (`seeds_then_runs`); local slopes
are d log(time) / d log(states) between consecutive sizes (`local_slopes`); growth exponents are a
maximum-likelihood fit of log(time) = a + k log(states) + e with right-censored (Tobit) terms and a
profile-likelihood interval of k (`fit_censored_power_law`).
"""

from __future__ import annotations

import math

import numpy as np

from tableclean_suite.intervals import DEFAULT_CONFIDENCE as CONFIDENCE  # level of every interval, in (0, 1)

#: The ordering the paper reports for Q-learning's iterations to maximum success (fewest first).
PAPER_ORDER = ("r4", "r2", "r1", "r3")
#: Smallest residual standard deviation the fit allows (log units), so a perfect fit stays finite.
MIN_LOG_SIGMA = math.log(1e-3)
#: Largest (e^20 in log units: beyond any data), so a search that strays there stays finite.
MAX_LOG_SIGMA = 20.0
#: Fewest reached points for a fitted exponent (and an interval: one more).
MIN_FIT_POINTS = 2
#: An exponent is reported only when at most this share of a fit's cells is censored.
MAX_CENSORED_SHARE_FOR_FIT = 0.5


def learning_times(learned_at) -> np.ndarray:
    """``(...)`` float64 learning times from ``learned_at`` codes: the code itself where >= 0, +inf
    where -1 (not learned by the end of the budget)."""
    codes = np.asarray(learned_at)
    return np.where(codes < 0, np.inf, codes).astype(np.float64)


def lower_median(times: np.ndarray, axis: int = -1) -> np.ndarray:
    """The lower median along ``axis`` (+inf entries sort last): the Kaplan-Meier median of times
    censored only at a common budget (module docstring)."""
    return np.quantile(times, 0.5, axis=axis, method="inverted_cdf")


def seeds_then_runs(seeds: int, runs: int, resamples: int, rng: np.random.Generator):
    """Index arrays of ``resamples`` seeds-then-runs resamples of an ``(S, R)`` array: ``(B, S, 1)``
    seeds drawn with replacement and ``(B, S, R)`` runs drawn with replacement within each drawn
    seed; [`pooled_resamples`][tableclean_suite.bench.scaling.statistics.pooled_resamples] applies them."""
    chosen = rng.integers(0, seeds, size=(resamples, seeds))
    return chosen[:, :, None], rng.integers(0, runs, size=(resamples, seeds, runs))


def pooled_resamples(values: np.ndarray, index) -> np.ndarray:
    """``(B, S * R)``: ``values`` (``(S, R)``) resampled by
    [`seeds_then_runs`][tableclean_suite.bench.scaling.statistics.seeds_then_runs]' ``index``, seeds pooled."""
    resampled = np.asarray(values)[index]
    return resampled.reshape(resampled.shape[0], -1)


def percentile_bounds(replicates, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """The percentile interval of ``replicates`` (+inf allowed; NaN ignored), as ``(low, high)``."""
    values = np.asarray(replicates, dtype=np.float64)
    values = values[~np.isnan(values)]
    if values.size == 0:
        return math.nan, math.nan
    low, high = np.quantile(values, [(1 - confidence) / 2, (1 + confidence) / 2], method="inverted_cdf")
    return float(low), float(high)


def local_slopes(sizes, medians, replicates, confidence: float = CONFIDENCE) -> list[dict]:
    """Slopes of log(median time) against log(size) between consecutive sizes.

    Args:
        sizes: ``(K,)`` increasing sizes (> 0), e.g. states reachable from the start.
        medians: ``(K,)`` median times (+inf = censored).
        replicates: ``(K, B)`` bootstrap medians of each cell
            ([`seeds_then_runs`][tableclean_suite.bench.scaling.statistics.seeds_then_runs] resamples).

    Returns:
        ``K - 1`` dicts ``{"from", "to", "slope", "low", "high"}``; NaN slope where either median is
        censored, an infinite end where the resamples of either cell are censored.
    """
    log_x = np.log(np.asarray(sizes, dtype=np.float64))
    slopes = []
    with np.errstate(divide="ignore", invalid="ignore"):  # inf - inf (both censored): NaN, dropped
        log_m = np.log(np.maximum(np.asarray(medians, dtype=np.float64), 1.0))
        log_r = np.log(np.maximum(np.asarray(replicates, dtype=np.float64), 1.0))
        for k in range(len(log_x) - 1):
            run = log_x[k + 1] - log_x[k]
            slope = float((log_m[k + 1] - log_m[k]) / run) if run > 0 else math.nan
            if math.isfinite(slope):
                low, high = percentile_bounds((log_r[k + 1] - log_r[k]) / run, confidence)
            else:
                slope = low = high = math.nan
            slopes.append({"from": sizes[k], "to": sizes[k + 1], "slope": slope, "low": low, "high": high})
    return slopes


def order_verdict(replicates: dict, order=PAPER_ORDER, confidence: float = CONFIDENCE) -> str | None:
    """Whether median times follow ``order`` (fewest first), judged pair by consecutive pair.

    Args:
        replicates: ``{reward: (B,) bootstrap medians}`` of independently trained cells.

    Returns:
        ``"holds"`` when every consecutive pair's log ratio has an interval below 0 (a censored
        median counts as larger than any finite one), ``"fails"`` when some pair's interval lies
        above 0, ``"tie"`` otherwise (some pair undecided, none reversed); None if a pattern is
        missing.  Each call makes ``len(order) - 1`` comparisons.
    """
    if any(name not in replicates for name in order):
        return None
    decided = []
    for first, second in zip(order, order[1:]):
        a, b = np.asarray(replicates[first], dtype=float), np.asarray(replicates[second], dtype=float)
        with np.errstate(invalid="ignore"):  # both censored: a tie
            faster = np.where(np.isinf(a) & np.isinf(b), 0.0, np.sign(b - a))  # +1: first strictly faster
        level = 1 - (1 - confidence) / 2
        decided.append("yes" if np.mean(faster > 0) >= level else "no" if np.mean(faster < 0) >= level else "tie")
    if "no" in decided:
        return "fails"
    return "holds" if all(d == "yes" for d in decided) else "tie"


def log_standard_error(value: float, low: float, high: float, confidence: float = CONFIDENCE) -> float:
    """A point's standard error on the log scale from its interval: (log high - log low) / (2 z);
    one-sided from the point when the top is infinite; NaN without a finite positive point and low."""
    from scipy import stats

    z = stats.norm.ppf((1 + confidence) / 2)
    if not (math.isfinite(value) and value > 0 and math.isfinite(low) and low > 0):
        return math.nan
    if not math.isfinite(high):
        return (math.log(value) - math.log(low)) / z
    return (math.log(high) - math.log(low)) / (2 * z)


def _negative_log_likelihood(params, log_x, log_y, se, censored):
    from scipy import stats

    intercept, slope, log_sigma = params
    scale = np.hypot(math.exp(min(max(log_sigma, MIN_LOG_SIGMA), MAX_LOG_SIGMA)), se)  # finite where the search strays
    mean = intercept + slope * log_x
    density = stats.norm.logpdf(log_y[~censored], mean[~censored], scale[~censored]).sum()
    survival = stats.norm.logsf(log_y[censored], mean[censored], scale[censored]).sum()
    return -(density + survival)


def _best_fit(log_x, log_y, se, censored, slope=None):
    """``(negative log-likelihood, params)`` at the maximum, optionally with the slope fixed."""
    from scipy import optimize

    reached = ~censored
    start_slope, start_intercept = np.polyfit(log_x[reached], log_y[reached], 1) if reached.sum() >= 2 else (0.0, 0.0)
    spread = np.std(log_y[reached] - start_intercept - start_slope * log_x[reached]) if reached.sum() > 2 else 0.5
    start_log_sigma = math.log(max(float(spread), 1e-2))
    if slope is None:
        objective = lambda p: _negative_log_likelihood(p, log_x, log_y, se, censored)  # noqa: E731
        start = [start_intercept, start_slope, start_log_sigma]
    else:
        objective = lambda p: _negative_log_likelihood([p[0], slope, p[1]], log_x, log_y, se, censored)  # noqa: E731
        start = [float(np.mean(log_y[reached] - slope * log_x[reached])) if reached.any() else 0.0, start_log_sigma]
    best = None
    for method in ("Nelder-Mead", "Powell"):
        fit = optimize.minimize(objective, start, method=method, options={"maxiter": 20000, "xatol": 1e-8,
                                                                        "fatol": 1e-10} if method == "Nelder-Mead"
                                else {"maxiter": 20000})
        if best is None or fit.fun < best.fun:
            best = fit
        start = list(best.x)
    return float(best.fun), np.asarray(best.x)


def fit_censored_power_law(x, y, censored, se, confidence: float = CONFIDENCE) -> dict:
    """Fit ``y ~ c * x ** k`` with right-censored points and per-point uncertainty (module docstring).

    Args:
        x: sizes (> 0), e.g. reachable states.
        y: times (> 0); for a censored point, the censoring bound (the budget).
        censored: bool per point, True where the true value exceeds ``y``.
        se: each reached point's standard error of log y
            ([`log_standard_error`][tableclean_suite.bench.scaling.statistics.log_standard_error]; NaN = 0).
        confidence: level of the exponent's profile-likelihood interval.

    Returns:
        ``{"exponent", "low", "high", "points", "censored", "sigma"}``: the fitted k, its interval
        (NaN when it cannot be bracketed, or with fewer than 3 points), the points used (reached
        and censored), how many were censored and the fitted residual standard deviation (log
        units).  Exponent NaN with fewer than `MIN_FIT_POINTS` reached points or when more
        than `MAX_CENSORED_SHARE_FOR_FIT` of the points are censored.
    """
    from scipy import optimize, stats

    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    censored, se = np.asarray(censored, dtype=bool), np.nan_to_num(np.asarray(se, dtype=float), nan=0.0)
    usable = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    x, y, censored, se = x[usable], y[usable], censored[usable], se[usable]
    result = {"exponent": math.nan, "low": math.nan, "high": math.nan, "points": int(len(x)),
              "censored": int(censored.sum()), "sigma": math.nan}
    reached = ~censored
    if (reached.sum() < MIN_FIT_POINTS or np.ptp(np.log(x)) == 0
            or censored.sum() > MAX_CENSORED_SHARE_FOR_FIT * len(x)):
        return result
    log_x, log_y = np.log(x), np.log(y)
    best, params = _best_fit(log_x, log_y, se, censored)
    slope = float(params[1])
    result.update(exponent=slope, sigma=math.exp(min(max(params[2], MIN_LOG_SIGMA), MAX_LOG_SIGMA)))
    if len(x) < MIN_FIT_POINTS + 1:
        return result
    cut = stats.chi2.ppf(confidence, 1) / 2

    def excess(k):
        return _best_fit(log_x, log_y, se, censored, slope=k)[0] - best - cut

    bounds = []
    for direction in (-1.0, 1.0):
        step, found = 0.05, math.nan
        for _ in range(40):
            edge = slope + direction * step
            if excess(edge) > 0:
                found = optimize.brentq(excess, *sorted((slope, edge)), xtol=1e-4)
                break
            step *= 1.6
        bounds.append(found)
    result.update(low=bounds[0], high=bounds[1])
    return result
