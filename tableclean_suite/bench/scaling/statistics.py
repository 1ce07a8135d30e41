"""The scaling study's statistics: the fixed yardstick, its bootstrap, the censored growth fit, the order.

**The yardstick** (fixed per spec, not per result): the iterations until the mean success curve
reaches, and stays at or above until the window's end, ``YARDSTICK_FRACTION`` (90 %) of the
*optimal policy's exact* epsilon-greedy success on that spec (``SpecInfo.optimal_success``).
The curve is read in blocks (:func:`block_edges`): a block's value is the mean success over its
iterations and runs, and the figure is the end of the first block from which every block to the
window's end is at or above the level.  A cell whose last block is below it is **censored**:
it did not get there within its window (its iterations exceed the window).

**Intervals** are the code base's one bootstrap (:mod:`tableclean_suite.bench.statistics`):
multinomial resamples of the runs (:func:`~tableclean_suite.bench.statistics.uniform_multinomial`),
each figure recomputed from the resampled sums by the same function as the point (the point is
the all-ones resample), :func:`~tableclean_suite.bench.statistics.percentile_interval` with the
point, so every interval holds its point.  A resample that never reaches the level counts as
+infinity (the interval's top is then infinite: "beyond the window").

**Growth exponents** (:func:`fit_censored_power_law`): log(iterations) = a + k log(states) + e,
fitted by maximum likelihood with e normal of variance sigma^2 + s_i^2, where s_i is the point's
own standard error on the log scale (from its bootstrap interval: (log high - log low) / (2 z));
a censored cell contributes P(log iterations > log window) (a Tobit / right-censored likelihood),
so censored cells pull the fit up instead of being dropped.  The 95 % interval of k is the profile
likelihood interval (likelihood ratio against chi^2(1)), found with ``scipy.optimize.brentq``.
"""

from __future__ import annotations

import math

import numpy as np

from tableclean_suite.bench.statistics import (DEFAULT_CONFIDENCE, percentile_interval, uniform_multinomial,
                                               weighted_group_sums)

#: The yardstick's level: this fraction of the optimal policy's exact success.
YARDSTICK_FRACTION = 0.9
#: Bootstrap resamples of the runs per cell.
DEFAULT_RESAMPLES = 1000
#: Level of every interval, in (0, 1).
CONFIDENCE = DEFAULT_CONFIDENCE
#: The ordering the paper reports for Q-learning's iterations to maximum success (fewest first).
PAPER_ORDER = ("r4", "r2", "r1", "r3")
#: Evenly spaced block edges over the window (2 % of the window each late in training: at the
#: paper's 12 000 iterations a block holds ~20 episodes per run, so a block mean over 100 runs has a
#: standard error near 0.01 and "held to the end" is not undone by one noisy block) ...
LINEAR_BLOCKS = 50
#: ... joined with this many geometrically spaced edges (fine blocks early, where curves rise).
GEOMETRIC_BLOCKS = 300
#: Smallest residual standard deviation the fit allows (log units), so a perfect fit stays finite.
MIN_LOG_SIGMA = math.log(1e-3)
#: Fewest reached points for a fitted exponent (and an interval: one more).
MIN_FIT_POINTS = 2


def block_edges(window: int, linear: int = LINEAR_BLOCKS, geometric: int = GEOMETRIC_BLOCKS) -> np.ndarray:
    """``(G,)`` int64 0-based *last* iterations of the blocks, increasing, ending at ``window - 1``.

    Block g covers iterations ``edges[g - 1] + 1 .. edges[g]`` (block 0 starts at 0): the union of
    ``linear`` evenly spaced and ``geometric`` geometrically spaced cut points (G <= their sum).
    """
    even = np.ceil(np.arange(1, linear + 1) * window / linear)
    spread = np.ceil(np.geomspace(1, window, geometric))
    return np.unique(np.clip(np.r_[even, spread], 1, window).astype(np.int64) - 1)


def block_widths(edges: np.ndarray) -> np.ndarray:
    """``(G,)`` iterations in each block of :func:`block_edges`."""
    return np.diff(np.r_[-1, edges]).astype(np.float64)


def resample_counts(runs: int, resamples: int, seed: int) -> np.ndarray:
    """``(B, R)`` int64: how often each run is drawn in each resample (the bench bootstrap's draws)."""
    return uniform_multinomial(np.random.default_rng(seed), runs, runs, resamples)


def held_to_end(curves: np.ndarray, levels) -> np.ndarray:
    """Per row of ``(B, G)`` block curves: the first block index from which every block to the end
    is at or above the row's level; -1 where the last block is below it (censored)."""
    curves = np.atleast_2d(np.asarray(curves, dtype=float))
    levels = np.broadcast_to(np.asarray(levels, dtype=float), curves.shape[:1])
    with np.errstate(invalid="ignore"):
        above = curves >= levels[:, None]
    suffix = np.flip(np.logical_and.accumulate(np.flip(above, axis=1), axis=1), axis=1)  # above from g to the end
    first = np.argmax(suffix, axis=1)
    return np.where(suffix[:, -1], first, -1)


def cell_figures(weights: np.ndarray, block_success: np.ndarray, widths: np.ndarray, edges: np.ndarray,
                 episodes: np.ndarray, tail_success: np.ndarray, never_terminal: np.ndarray, level: float) -> dict:
    """The cell's figures for each row of run ``weights`` (``(B, R)``; all ones = the point).

    Args:
        block_success: ``(R, G)`` successful iterations of each run in each block.
        widths, edges: the blocks (:func:`block_widths`, :func:`block_edges`).
        episodes: ``(R, G)`` episodes each run finished by each block's end.
        tail_success: ``(R,)`` each run's success averaged over the window's last quarter.
        never_terminal: ``(R,)`` 1.0 for a run that never reached the terminal state.
        level: the yardstick's success level, in [0, 1].

    Returns:
        ``{"yardstick_iterations", "yardstick_episodes", "success_window_mean",
        "never_terminal_share": (B,)}``: iterations (end of the first block held to the end; +inf
        when censored), mean episodes by then (NaN when censored), the window mean of the
        success curve and the share of runs that never reached the terminal state.
    """
    weights = np.asarray(weights, dtype=np.float64)
    runs = weights.sum(axis=1)
    curves = weighted_group_sums(weights, block_success) / (runs[:, None] * widths[None, :])
    first = held_to_end(curves, level)
    reached = first >= 0
    index = np.maximum(first, 0)
    episodes_at = weighted_group_sums(weights, episodes)[np.arange(len(weights)), index] / runs
    return {
        "yardstick_iterations": np.where(reached, edges[index] + 1.0, np.inf),
        "yardstick_episodes": np.where(reached, episodes_at, np.nan),
        "success_window_mean": weighted_group_sums(weights, tail_success) / runs,
        "never_terminal_share": weighted_group_sums(weights, never_terminal) / runs,
    }


def bootstrap_cell(counts: np.ndarray, confidence: float = CONFIDENCE, **arrays) -> dict:
    """Point estimates and intervals of :func:`cell_figures` (``arrays`` are its keyword arguments).

    Returns:
        ``{figure: (point, low, high)}``; a censored point has NaN bounds (nothing to bound), and a
        reached point whose resamples sometimes do not reach has an infinite top.
    """
    runs = counts.shape[1]
    point = cell_figures(np.ones((1, runs)), **arrays)
    replicates = cell_figures(counts, **arrays)
    result = {}
    for name, values in replicates.items():
        value = float(point[name][0])
        if math.isfinite(value):
            low, high = _interval_with_censoring(np.where(np.isnan(values), np.inf, values), value, confidence)
        else:
            low = high = math.nan
        result[name] = (value, low, high)
    return result


def _interval_with_censoring(values: np.ndarray, point: float, confidence: float) -> tuple[float, float]:
    """:func:`percentile_interval` of replicates some of which are +inf (censored): they count as
    larger than every finite one, and an end that falls among them is +inf."""
    finite = values[np.isfinite(values)]
    if len(finite) == len(values):
        return percentile_interval(values, confidence, point)
    largest = max(float(finite.max()) if len(finite) else point, point)
    stand_in = 2.0 * abs(largest) + 1.0
    low, high = percentile_interval(np.where(np.isfinite(values), values, stand_in), confidence, point)
    return (low if low <= largest else math.inf), (high if high <= largest else math.inf)


def log_standard_error(value: float, low: float, high: float, confidence: float = CONFIDENCE) -> float:
    """A point's standard error on the log scale from its interval: (log high - log low) / (2 z);
    one-sided from the point when the top is infinite; 0 when the interval is a point."""
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
    scale = np.sqrt(np.exp(2 * max(log_sigma, MIN_LOG_SIGMA)) + se ** 2)
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
        y: iterations (> 0); for a censored point, the censoring bound (the window).
        censored: bool per point, True where the true value exceeds ``y``.
        se: each reached point's standard error of log y (:func:`log_standard_error`; NaN = 0).
        confidence: level of the exponent's profile-likelihood interval.

    Returns:
        ``{"exponent", "low", "high", "points", "censored", "sigma"}``: the fitted k, its interval
        (NaN when it cannot be bracketed, or with fewer than 3 points), the points used (reached
        and censored), how many were censored and the fitted residual standard deviation (log
        units).  Exponent NaN with fewer than :data:`MIN_FIT_POINTS` reached points.
    """
    from scipy import optimize, stats

    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    censored, se = np.asarray(censored, dtype=bool), np.nan_to_num(np.asarray(se, dtype=float), nan=0.0)
    usable = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    x, y, censored, se = x[usable], y[usable], censored[usable], se[usable]
    result = {"exponent": math.nan, "low": math.nan, "high": math.nan, "points": int(len(x)),
              "censored": int(censored.sum()), "sigma": math.nan}
    reached = ~censored
    if reached.sum() < MIN_FIT_POINTS or np.ptp(np.log(x)) == 0:
        return result
    log_x, log_y = np.log(x), np.log(y)
    best, params = _best_fit(log_x, log_y, se, censored)
    slope = float(params[1])
    result.update(exponent=slope, sigma=float(math.exp(max(params[2], MIN_LOG_SIGMA))))
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


def order_holds(values: dict, order=PAPER_ORDER) -> bool | None:
    """Whether ``values[order[0]] < values[order[1]] < ...``; None if one is missing or NaN
    (an infinite value, a censored cell, sorts last)."""
    chosen = [values.get(name, math.nan) for name in order]
    if any(v is None or (isinstance(v, float) and math.isnan(v)) for v in chosen):
        return None
    return all(a < b for a, b in zip(chosen, chosen[1:]))
