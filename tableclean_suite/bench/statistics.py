"""Intervals, IQMs and probabilities of improvement for the harness's tables and figures.

**Intervals on Table 3-4 numbers and curve bands** (percentile bootstrap over runs, in blocks).
Runs are independent; run i is summed into group ``i % G`` as it trains
(:class:`~tableclean_suite.metrics.GroupedCurveSums`, G = :func:`bootstrap_groups`, 100 at the
defaults, i.e. blocks of 10 of the 1000 runs), so memory stays ``G x T`` however many runs.  A
replicate draws G groups with replacement (multinomial counts, seeded), rebuilds the mean curves
and the mean asymptote from the drawn groups' sums and recomputes every Table 3 number from them
with the same definitions (:func:`tableclean_suite.metrics.batch_scalars`, all replicates at once).  The interval is the
(2.5 %, 97.5 %) percentile of :data:`DEFAULT_SAMPLES` replicates; curve bands are the same
percentiles per iteration.  "Max average reward" is the exception: a replicate contributes its
curve's value at the iteration where the point curve peaks, not its own maximum (which picks the
replicate's noise, is biased upward, and left the point below the interval).  A number that some replicates leave undefined (never reached) gets
its interval from the replicates that define it and is flagged by NaN bounds when fewer than
half do.

**Per-run scores** (exact per run): the asymptotic success of the run's final policy
(:mod:`tableclean_suite.asymptotes`) and the iterations to its first successful episode.  Their
**IQM** (mean of the middle 50 %, ``scipy.stats.trim_mean(x, 0.25)`` as rliable) comes with a
percentile bootstrap interval over runs (``scipy.stats.bootstrap``).  Runs that never succeed
count as +infinity for the IQM of first-success iterations; the IQM is NaN when more than 25 %
of the runs never succeed (it would rest on them).

**Probability of improvement** of X over Y (rliable's, with a practical-equivalence margin m):
P(x > y + m) + P(|x - y| <= m) / 2 for a run x of X and a run y of Y (signs flipped when lower is
better), with a stratified bootstrap interval (runs of X and of Y resampled separately).  m is
:data:`EQUIVALENCE_MARGINS`: one percentage point for success asymptotes, 0 for iteration counts.

**Every interval holds its point by construction**: it is the percentile interval of the
bootstrap replicates of the *same estimator* as the point (Table 3's numbers are recomputed from
the resampled sums with :func:`tableclean_suite.metrics.batch_scalars`, the function whose
unit-weight case is the point), extended to the point where the replicates lie wholly on one side
of it (:func:`percentile_interval`).  Not BCa: BCa's bias correction can itself move both ends
past the point when most replicates lie on one side, which is the case to be handled.
"""

from __future__ import annotations

import hashlib
import threading
from dataclasses import dataclass, field

import numba
import numpy as np

from tableclean_suite import metrics
from tableclean_suite.learners.threads import run_in_threads
from tableclean_suite.metrics import SUMMARY_SCALARS, GroupedCurveSums
from tableclean_suite.settling import Settling

#: Bootstrap replicates per interval.
DEFAULT_SAMPLES = 500
#: Two-sided coverage of the intervals.
DEFAULT_CONFIDENCE = 0.95
#: Groups of runs the curve bootstrap resamples (fewer when runs are fewer or the window is long).
MAX_GROUPS = 100
#: Fewest groups for which curve intervals are computed (below: NaN intervals).
MIN_GROUPS = 20
#: Memory allowed for the grouped sums of one cell, bytes (5 float64 arrays of G x T).
GROUP_BYTES = 256_000_000
#: Replicates rebuilt at once (bounds the replicate curves' memory: 5 x batch x T floats).
REPLICATE_BATCH = 100
#: Curve bands are kept at most at this many iterations (every k-th beyond).
BAND_POINTS = 1000
#: Fraction of the runs trimmed at each end by the IQM.
IQM_TRIM = 0.25
#: Fraction of replicates that must define a number for its interval to be given.
MIN_DEFINED = 0.5
#: Curves that get bands (the ones the figures draw).
BAND_CURVES = ("success", "average_reward")
#: Per-run scores: name -> whether higher is better.
RUN_SCORES = {"success_asymptote": True, "first_success_iterations": False}
#: Practical-equivalence margin of each per-run score for probabilities of improvement (score
#: units): runs whose success asymptotes differ by at most one percentage point tie (the settling
#: tolerance; the default cells' asymptotes differ by ~0.04 pp between converged runs, exploration
#: noise, not learning); iteration counts are integers and tie only when equal.
EQUIVALENCE_MARGINS = {"success_asymptote": 0.01, "first_success_iterations": 0.0}
#: Weight of a tied pair in a probability of improvement.
HALF = 0.5


#: numpy's binomial sampler inverts the CDF when n * min(p, 1 - p) is at most this (else BTPE).
_INVERSION_LIMIT = 30.0
#: numpy's inversion gives up (and redraws) past mean + this many standard deviations (roughly).
_INVERSION_SPREAD = 10.0
#: Largest (categories x (draws + 1)) table of inversion set-ups :func:`uniform_multinomial` keeps.
SETUP_TABLE_ENTRIES = 4_000_000
#: Shapes whose tables are kept at once (a run uses two: runs x runs and groups x groups).
SETUP_TABLES = 2
#: Those tables, per thread (comparisons may be drawn in a thread while cells are bootstrapped).
_setup_tables = threading.local()


@numba.njit(cache=True, nogil=True)
def _uniform_multinomial(rng, n, d, size, category_p, use_table, qn_table, bound_table, out, row, column, left):
    """Fill ``out`` as ``rng.multinomial(n, np.full(d, 1.0 / d), size)`` does, from row ``row``,
    category ``column`` with ``left`` draws not yet assigned in that row, by numpy's own algorithm
    (``random_multinomial``: a binomial per category on what is left, inverted from the CDF as
    ``random_binomial_inversion``), drawing the same numbers from ``rng``.

    ``out`` is ``(size, d)`` int64 zeros; ``category_p[j]`` the probability of category ``j`` given
    the draws left (:func:`uniform_multinomial`).  The binomial's set-up (P(X = 0) = q**n and the
    inversion bound) depends only on (category, draws left), so with ``use_table`` it is kept in
    ``qn_table``/``bound_table`` (``(d, n + 1)``, NaN = not yet computed) instead of recomputed per
    draw.

    Returns:
        ``(-1, 0, 0)`` when ``out`` is complete, else ``(row, column, left)`` of a binomial numpy
        draws with BTPE instead (never met by n = d uniform draws in practice): the caller draws
        it with numpy and calls again from the next category (numba's copy of BTPE took a first
        process ~3 s to compile).
    """
    for i in range(row, size):
        if i > row:
            column = 0
            left = n
        for j in range(column, d - 1):
            p = category_p[j]
            x = 0
            if left != 0 and p != 0.0:
                flip = p > 0.5
                r = 1.0 - p if flip else p
                if r * left > _INVERSION_LIMIT:
                    return i, j, left
                q = 1.0 - r
                qn = qn_table[j, left] if use_table else np.nan
                if qn != qn:
                    qn = np.exp(left * np.log(q))
                    mean = left * r
                    bound = min(left, mean + _INVERSION_SPREAD * np.sqrt(mean * q + 1))
                    if use_table:
                        qn_table[j, left] = qn
                        bound_table[j, left] = bound
                else:
                    bound = bound_table[j, left]
                px = qn
                u = rng.random()
                while u > px:
                    x += 1
                    if x > bound:
                        x = 0
                        px = qn
                        u = rng.random()
                    else:
                        u -= px
                        px = ((left - x + 1) * r * px) / (x * q)
                if flip:
                    x = left - x
            out[i, j] = x
            left -= x
            if left <= 0:
                break
        if left > 0:
            out[i, d - 1] = left
    return -1, 0, 0


def uniform_multinomial(rng: np.random.Generator, n: int, d: int, size: int) -> np.ndarray:
    """``rng.multinomial(n, np.full(d, 1.0 / d), size=size)`` (int64 ``(size, d)``), bit for bit and
    leaving ``rng`` in the same state, about twice as fast (see :func:`_uniform_multinomial`)."""
    n, d, size = int(n), int(d), int(size)
    out = np.zeros((size, d), dtype=np.int64)
    share = 1.0 / d
    category_p = np.empty(d)
    remaining = 1.0
    for j in range(d):  # numpy's pix[j] / remaining_p, the same operations in the same order
        category_p[j] = share / remaining
        remaining -= share
    use_table = d * (n + 1) <= SETUP_TABLE_ENTRIES
    key = (n, d)
    tables = _setup_tables.__dict__.setdefault("by_shape", {})
    if use_table and key not in tables:
        if len(tables) >= SETUP_TABLES:
            tables.clear()
        tables[key] = (np.full((d, n + 1), np.nan), np.zeros((d, n + 1)))
    qn_table, bound_table = tables[key] if use_table else (np.empty((1, 1)), np.empty((1, 1)))
    row, column, left = 0, 0, n
    while True:
        row, column, left = _uniform_multinomial(rng, n, d, size, category_p, use_table, qn_table, bound_table,
                                                 out, row, column, left)
        if row < 0:
            return out
        x = int(rng.binomial(left, category_p[column]))  # numpy's BTPE, as its multinomial draws it
        out[row, column] = x
        left -= x
        column += 1
        if column == d - 1 or left <= 0:  # the row is complete: the rest to the last category
            if left > 0:
                out[row, d - 1] = left
            row, column, left = row + 1, 0, n
            if row == size:
                return out


def bootstrap_groups(runs: int, iterations: int) -> int:
    """G, the number of run groups: at most :data:`MAX_GROUPS`, at most ``runs``, and within
    :data:`GROUP_BYTES` for 5 arrays of ``G x iterations`` float64."""
    fits = GROUP_BYTES // (5 * 8 * max(1, int(iterations)))
    return int(max(1, min(MAX_GROUPS, runs, fits)))


def bootstrap_rng(seed: int, label: str) -> np.random.Generator:
    """A generator for one cell's bootstrap: seeded by the run's seed and the cell's label."""
    digest = int.from_bytes(hashlib.sha256(label.encode()).digest()[:8], "little")
    return np.random.default_rng([int(seed), digest])


def percentile_interval(samples, confidence: float = DEFAULT_CONFIDENCE, point: float | None = None
                        ) -> tuple[float, float]:
    """``(low, high)``: the central ``confidence`` percentile interval of ``samples`` (NaNs ignored;
    NaN bounds when fewer than :data:`MIN_DEFINED` of them are defined), extended to ``point``.

    With ``point`` (the estimate the replicates bootstrap, computed by the same estimator) the
    interval is the smallest one holding both the percentile interval and the point, so every
    reported number lies inside its interval by construction.  The extension happens where the
    replicates' distribution sits wholly on one side of the point (first-crossing times and the
    episodes read off them are discrete and biased in resamples); it only widens the interval.
    :func:`extended_side` says whether it did.
    """
    samples = np.asarray(samples, dtype=float)
    defined = samples[~np.isnan(samples)]
    if len(samples) == 0 or len(defined) < MIN_DEFINED * len(samples):
        return float("nan"), float("nan")
    tail = 50.0 * (1.0 - confidence)
    low, high = (float(v) for v in np.percentile(defined, [tail, 100.0 - tail]))
    if point is not None and np.isfinite(point):
        low, high = min(low, float(point)), max(high, float(point))
    return low, high


def extended_side(samples, point, confidence: float = DEFAULT_CONFIDENCE) -> bool:
    """Whether :func:`percentile_interval` had to extend the percentile interval of ``samples`` to
    hold ``point`` (False when either is undefined)."""
    low, high = percentile_interval(samples, confidence)
    return bool(np.isfinite(point) and np.isfinite(low) and not low <= point <= high)


def trim_mean(values: np.ndarray, proportion: float = IQM_TRIM, axis: int = -1) -> np.ndarray:
    """``scipy.stats.trim_mean(values, proportion, axis)`` for float arrays, the same operations
    (partition at both cuts, mean of the middle) without importing :mod:`scipy.stats` (~1 s)."""
    values = np.asarray(values, dtype=float)
    count = values.shape[axis]
    low = int(proportion * count)
    high = count - low
    middle = np.partition(values, (low, high - 1), axis)
    kept = [slice(None)] * middle.ndim
    kept[axis] = slice(low, high)
    return np.mean(middle[tuple(kept)], axis=axis)


def iqm(values) -> float:
    """Interquartile mean: mean of the middle 50 % (``trim_mean(values, 0.25)``); +inf values count
    as largest, and the IQM is NaN if they reach into the middle 50 %."""
    values = np.sort(np.asarray(values, dtype=float))
    if len(values) == 0:
        return float("nan")
    result = float(trim_mean(values, IQM_TRIM))
    return result if np.isfinite(result) else float("nan")


def _iqm_axis(values, axis=-1):
    values = np.sort(np.asarray(values, dtype=float), axis=axis)
    result = trim_mean(values, IQM_TRIM, axis=axis)
    return np.where(np.isfinite(result), result, np.nan)


def iqm_interval(values, confidence: float = DEFAULT_CONFIDENCE, samples: int = DEFAULT_SAMPLES,
                 rng: np.random.Generator | None = None) -> tuple[float, float, float]:
    """``(IQM, low, high)``, the interval a percentile bootstrap over the values.

    The replicates are those of ``scipy.stats.bootstrap((values,), _iqm_axis, n_resamples=samples,
    method="percentile", vectorized=True, random_state=rng)`` (one batch: ``rng.integers(0, R,
    (samples, R))`` indexes the resamples), computed here so that scipy is not imported.
    """
    values = np.asarray(values, dtype=float)
    point = iqm(values)
    if len(values) < 2 or not np.isfinite(point):
        return point, float("nan"), float("nan")
    rng = rng if rng is not None else np.random.default_rng(0)
    index = rng.integers(0, len(values), (samples, len(values)))
    low, high = percentile_interval(resampled_iqms(values, index), confidence, point)
    return point, low, high


def resampled_iqms(values: np.ndarray, index: np.ndarray) -> np.ndarray:
    """``_iqm_axis(values[index], axis=-1)``: the IQM of each resample (row of ``index``), the same bits.

    Each resample is sorted by counting how often it draws each value (the values sorted once)
    instead of sorting every row: the sorted row is the same array whatever the method, unless
    the values hold a NaN or a -0.0 (then the rows are sorted as :func:`_iqm_axis` does).  When
    every finite value is an integer and the middle's sum stays below 2**53, that sum is exact
    in any order, so the middle's mean is read off the draw counts (:func:`_resampled_rows`)
    without building the rows or :func:`trim_mean`'s partition; else the sorted rows are built
    from the counts (the same kernel) for :func:`trim_mean`.
    """
    values = np.asarray(values, dtype=float)
    samples, count = index.shape
    if count == 0 or np.isnan(values).any() or np.signbit(values[values == 0]).any():
        return _iqm_axis(values[index], axis=-1)
    order = np.argsort(values, kind="stable")
    rank = np.empty(len(values), dtype=np.int64)
    rank[order] = np.arange(len(values))
    finite = values[np.isfinite(values)]
    if np.array_equal(finite, np.trunc(finite)) and (len(finite) == 0 or
                                                     np.abs(finite).max() * count < EXACT_INTEGER_LIMIT):
        result = np.empty(samples)
        _resampled_rows(values[order], rank, np.ascontiguousarray(index, dtype=np.int64), int(IQM_TRIM * count),
                        result, np.empty((0, 0)))
    else:
        ordered = np.empty((samples, count))
        _resampled_rows(values[order], rank, np.ascontiguousarray(index, dtype=np.int64), 0, np.empty(0), ordered)
        result = trim_mean(ordered, IQM_TRIM, axis=-1)
    return np.where(np.isfinite(result), result, np.nan)


@numba.njit(cache=True, nogil=True)
def _resampled_rows(sorted_values, rank, index, low, means, rows):
    """Resamples from their draw counts (``index``: ``(samples, count)``; ``rank[i]``: the position
    of value i in ``sorted_values``), without sorting: into ``means`` (``(samples,)``), the mean of
    each sorted resample from position ``low`` to ``count - low``, or, when ``means`` is empty,
    into ``rows`` (``(samples, count)``), the sorted resamples ``np.sort(sorted_values[rank[index[b]]])``.

    The middle's sum is taken as ``value * copies`` per value: exact, hence the bits of any order
    of the additions (numpy's pairwise mean), when the values are integers whose sums stay below
    2**53 (infinities give the same infinity or NaN); then divided by the middle's length as
    ``np.mean`` does.  Only for such values may ``means`` be asked for."""
    samples, count = index.shape
    draws = np.zeros(sorted_values.shape[0], dtype=np.int64)
    high = count - low
    for b in range(samples):
        draws[:] = 0
        for i in range(count):
            draws[rank[index[b, i]]] += 1
        if means.shape[0] == 0:
            position = 0
            for k in range(sorted_values.shape[0]):
                for _ in range(draws[k]):
                    rows[b, position] = sorted_values[k]
                    position += 1
            continue
        total = 0.0
        seen = 0
        for k in range(sorted_values.shape[0]):
            copies = draws[k]
            if copies != 0:
                start, stop = max(seen, low), min(seen + copies, high)
                if stop > start:
                    total += sorted_values[k] * (stop - start)
                seen += copies
                if seen >= high:
                    break
        means[b] = total / (high - low)


def _beaten_and_tied(x: np.ndarray, y_sorted: np.ndarray, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """Per x: how many of the sorted y it beats by more than ``margin`` (``y < x - margin``) and
    how many it does not (``y <= x + margin``): ``(below, not_above)`` index arrays into y."""
    with np.errstate(invalid="ignore"):
        below = np.searchsorted(y_sorted, x - margin, side="left")
        not_above = np.searchsorted(y_sorted, x + margin, side="right")
    return below, not_above


def probability_of_improvement(x, y, higher_is_better: bool = True, margin: float = 0.0) -> float:
    """P(a run of X beats a run of Y) + P(tie) / 2, over all pairs (rliable's definition for
    ``margin = 0``).

    With a practical-equivalence ``margin`` (>= 0, in the score's units) a pair is a tie when
    ``|x - y| <= margin`` and x beats y only by more than that: differences nobody would act on
    count as ties, not as wins.
    """
    if not margin >= 0:
        raise ValueError(f"margin must be a number >= 0 (score units), got {margin!r}")
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if not higher_is_better:
        x, y = -x, -y
    below, not_above = _beaten_and_tied(x, np.sort(y), margin)
    return float((below + HALF * (not_above - below)).sum() / (len(x) * len(y)))


def probability_of_improvement_interval(x, y, higher_is_better: bool = True, confidence: float = DEFAULT_CONFIDENCE,
                                        samples: int = DEFAULT_SAMPLES, rng: np.random.Generator | None = None,
                                        margin: float = 0.0):
    """``(P, low, high)`` with a stratified percentile bootstrap (X's and Y's runs resampled apart),
    P as :func:`probability_of_improvement` with the same ``margin``.

    Replicates are computed from counts: each replicate draws multinomial counts of X's runs and
    of Y's runs (:func:`uniform_multinomial`), and P is the count-weighted share of (x, y) pairs
    where x beats y by more than ``margin``, plus half the pairs within it.  The interval holds P
    (:func:`percentile_interval` with the point).
    """
    rng = rng if rng is not None else np.random.default_rng(0)
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    point = probability_of_improvement(x, y, higher_is_better, margin)
    if not higher_is_better:
        x, y = -x, -y
    order = np.argsort(y, kind="stable")
    below, not_above = _beaten_and_tied(x, y[order], margin)
    cx = uniform_multinomial(rng, len(x), len(x), samples)
    cy = uniform_multinomial(rng, len(y), len(y), samples)
    replicates = _improvement_replicates(cx, cy, order, below, not_above)
    low, high = percentile_interval(replicates, confidence, point)
    return point, low, high


@numba.njit(cache=True, nogil=True)
def _improvement_replicates(cx, cy, order, below, not_above):
    """``(B,)``: each replicate's count-weighted share of (x, y) pairs where x wins, ties counting half.

    Replicate b: ``cumulative[k]`` = how many of the resampled y (counts ``cy[b]``, taken in
    ``order``, i.e. sorted) are among the k smallest; x_i's run (count ``cx[b, i]``) beats
    ``cumulative[below[i]]`` of them and ties ``cumulative[not_above[i]] - cumulative[below[i]]``.
    Every term and partial sum is a multiple of 1/2 far below 2**52, so the sum is exact in any
    order (the same bits as summing the ``(B, nx)`` array of terms with numpy).
    """
    samples, n_x, n_y = cx.shape[0], cx.shape[1], cy.shape[1]
    replicates = np.empty(samples)
    cumulative = np.empty(n_y + 1)
    for b in range(samples):
        cumulative[0] = 0.0
        for k in range(n_y):
            cumulative[k + 1] = cumulative[k] + cy[b, order[k]]
        total = 0.0
        for i in range(n_x):
            count = cx[b, i]
            if count != 0:
                wins = cumulative[below[i]]
                total += count * (wins + HALF * (cumulative[not_above[i]] - wins))
        replicates[b] = total / (n_x * n_y)
    return replicates


#: Columns (iterations) of the values :func:`_weighted_row_range` sums at a time: a tile of
#: G = 100 groups x 512 float64 (400 KB) stays in a core's L2 cache while every row reads it.
SUM_TILE = 512


@numba.njit(cache=True, nogil=True)
def _weighted_row_range(lo, hi, weights, values, out):
    """Rows ``lo .. hi - 1`` of :func:`_weighted_rows` into ``out``, groups summed in ascending order.

    ``out[b, t]`` receives ``weights[b, g] * values[g, t]`` for every g with a non-zero weight, g
    ascending, each product rounded then added, as the plain triple loop would.  Faster, the same
    operations: the columns are taken :data:`SUM_TILE` at a time (the values' tile stays in
    cache), and four groups are added to an element in one pass over the tile (``out`` is read
    and written once per four groups).  Indices are unsigned so that the inner loops vectorise
    (no negative-index wraparound)."""
    n_groups, length = weights.shape[1], values.shape[1]
    used = np.empty(n_groups, dtype=np.int64)
    for start in range(0, length, SUM_TILE):
        first, stop = np.uint64(start), np.uint64(min(start + SUM_TILE, length))
        for b in range(lo, hi):
            n_used = 0
            for g in range(n_groups):
                if weights[b, g] != 0.0:
                    used[n_used] = g
                    n_used += 1
            k = 0
            while k + 4 <= n_used:
                g0, g1, g2, g3 = used[k], used[k + 1], used[k + 2], used[k + 3]
                w0, w1, w2, w3 = weights[b, g0], weights[b, g1], weights[b, g2], weights[b, g3]
                for t in range(first, stop):
                    out[b, t] = (((out[b, t] + w0 * values[g0, t]) + w1 * values[g1, t]) + w2 * values[g2, t]
                                 ) + w3 * values[g3, t]
                k += 4
            while k < n_used:
                g0 = used[k]
                w0 = weights[b, g0]
                for t in range(first, stop):
                    out[b, t] += w0 * values[g0, t]
                k += 1


#: Fewest products (B x G x T) for which :func:`_weighted_rows` spreads its rows over threads
#: (below, starting the threads costs more than they save: the per-group sums of asymptotes).
THREADED_PRODUCTS = 1_000_000


def _weighted_rows(weights: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``(B, T)``: row b is the sum over groups g (ascending) of ``weights[b, g] * values[g]``, rows
    spread over threads when the sums are large (each row is summed by one thread, so the bits do
    not depend on them).  Threads rather than a numba parallel loop: the loop's compilation cost a
    first process ~1-2 s, and this loop takes no rows of arrays (no reference counting)."""
    out = np.zeros((weights.shape[0], values.shape[1]))
    if weights.size * values.shape[1] < THREADED_PRODUCTS:
        _weighted_row_range(0, weights.shape[0], weights, values, out)
    else:
        run_in_threads(_weighted_row_range, weights.shape[0], (weights, values, out))
    return out


#: Largest magnitude an integer-valued float64 sum may reach and still be exact (2**53).
EXACT_INTEGER_LIMIT = 2.0 ** 53
#: The same for float32 (2**24): such sums are exact in a single-precision product too.
EXACT_SINGLE_LIMIT = 2.0 ** 24


def _exact_integer_product(weights: np.ndarray, values: np.ndarray, limit: float = EXACT_INTEGER_LIMIT) -> bool:
    """Whether every product and partial sum of ``weights @ values`` is an integer below ``limit``
    (:data:`EXACT_INTEGER_LIMIT`, or :data:`EXACT_SINGLE_LIMIT` for a float32 product), so that any
    summation order (BLAS, any thread count) gives the exact, identical result: both
    integer-valued and ``max |v| * max_b sum_g |w_bg|`` in range."""
    if values.size == 0 or weights.size == 0:
        return False
    largest = np.abs(values).max()
    return bool(np.isfinite(largest) and largest * np.abs(weights).sum(axis=1).max() < limit
                and np.array_equal(values, np.trunc(values)) and np.array_equal(weights, np.trunc(weights)))


def weighted_group_sums(weights: np.ndarray, values: np.ndarray, exact: bool | None = None,
                        single: np.ndarray | None = None) -> np.ndarray:
    """``weights @ values`` summed in a fixed order (groups ascending, per output element).

    A BLAS matrix product's last bits depend on its thread count (OpenBLAS splits the sum), so a
    cell bootstrapped on a 1-thread Ray worker differed from the same cell on 2 threads; this sum
    gives the same bits for any thread count, process or executor (and equals ``np.einsum``).
    When the values and weights are integers small enough for every partial sum to be exact
    (:func:`_exact_integer_product`: the success and finished-run counts, the runs per group), the
    order cannot matter and the BLAS product (~10x faster) gives those same bits; ``+ 0.0`` maps
    a BLAS ``-0.0`` to the ordered sum's ``+0.0``.  Below :data:`EXACT_SINGLE_LIMIT` (the success
    and finished-run counts of a cell: at most runs x groups), a float32 product is exact as well,
    and ~30 % cheaper.

    Args:
        weights: ``(B, G)`` replicate counts of each group.
        values: ``(G,)`` or ``(G, T)`` per-group sums.
        exact: :func:`_exact_integer_product` of these weights and values when the caller knows it
            (e.g. checked once for all the batches of one cell's replicates); None: checked here.
        single: ``values`` as float32 when the caller checked that their product with such weights
            is exact in single precision (:func:`_exact_integer_product` with
            :data:`EXACT_SINGLE_LIMIT`); then the product is taken in float32.

    Returns:
        ``(B,)`` or ``(B, T)`` float64.
    """
    if single is not None:
        return np.add(np.asarray(weights, dtype=np.float32) @ single, 0.0, dtype=np.float64)
    weights = np.ascontiguousarray(weights, dtype=np.float64)
    values = np.asarray(values, dtype=np.float64)
    if _exact_integer_product(weights, values) if exact is None else exact:
        return weights @ values + 0.0
    if values.ndim == 1:
        return _weighted_rows(weights, np.ascontiguousarray(values[:, None]))[:, 0]
    return _weighted_rows(weights, np.ascontiguousarray(values))


@dataclass
class CellStatistics:
    """A cell's intervals, curve bands and per-run scores.

    Attributes:
        intervals: ``{scalar: (low, high)}`` for every :data:`SUMMARY_SCALARS` name (NaN if undefined).
        bands: ``{curve: (low, high)}``, each ``(ceil(T / band_stride),)`` at iteration counts
            ``1, 1 + band_stride, ...`` for the curves in :data:`BAND_CURVES`.
        band_stride: iterations between band points (>= 1).
        runs: ``{score: (R,) array}`` per-run scores (:data:`RUN_SCORES`; first-success iterations
            NaN for a run that never succeeded).
        scores: ``{score: (IQM, low, high)}``.
        settling: the behaviour drift over the window's last quarter (:mod:`tableclean_suite.settling`).
    """

    intervals: dict = field(default_factory=dict)
    bands: dict = field(default_factory=dict)
    band_stride: int = 1
    runs: dict = field(default_factory=dict)
    scores: dict = field(default_factory=dict)
    settling: Settling = field(default_factory=Settling.not_measured)

    def band_iterations(self, iterations: int) -> np.ndarray:
        """Iteration counts (1-based) of the band points for curves of length ``iterations``."""
        return np.arange(0, iterations, self.band_stride) + 1

    def band_at(self, curve: str, iterations: np.ndarray, length: int) -> tuple[np.ndarray, np.ndarray]:
        """The band of ``curve`` at the given iteration counts (interpolated between band points)."""
        grid = self.band_iterations(length)
        low, high = self.bands[curve]
        return (np.interp(iterations, grid, low, left=np.nan, right=np.nan),
                np.interp(iterations, grid, high, left=np.nan, right=np.nan))


#: The per-group sums a replicate is rebuilt from (:class:`GroupedCurveSums` attributes).
REPLICATE_SUMS = ("runs_per_group", "success", "average_sum", "finished_runs")


def replicate_scalars(grouped: GroupedCurveSums, asymptote_sums: dict, weights: np.ndarray, threshold: float,
                      plateau_fraction: float, support_fraction: float, keep: np.ndarray, peak: int | None = None,
                      exact: dict | None = None, single: dict | None = None):
    """Table 3 scalars and band curves of bootstrap replicates.

    Args:
        grouped: the cell's grouped sums (G groups).
        asymptote_sums: ``{"success", "average_reward", "terminal": (G,) sums of per-run asymptotes}``.
        weights: ``(B, G)`` multinomial counts of each group in each replicate.
        keep: iteration indices (or a slice) of the band curves.
        peak: index of the point curve's maximum average reward (``metrics.batch_scalars``).
        exact: ``{name: bool}`` :func:`_exact_integer_product` of weights like these (the same row
            sums) and each of :data:`REPLICATE_SUMS` and ``asymptote_sums`` (a name missing:
            checked here), so that the batches of one cell check each sum once.
        single: ``{name: float32 copy}`` of the sums of :data:`REPLICATE_SUMS` whose products with
            weights like these are exact in single precision (:func:`weighted_group_sums`).

    Returns:
        :func:`tableclean_suite.metrics.batch_scalars` of the replicates.
    """
    exact = exact or {}
    single = single or {}
    runs = weighted_group_sums(weights, grouped.runs_per_group, exact.get("runs_per_group"))
    sums = {name: weighted_group_sums(weights, getattr(grouped, name), exact.get(name), single.get(name))
            for name in ("success", "average_sum", "finished_runs")}
    tops = {name: weighted_group_sums(weights, values, exact.get(f"asymptote {name}")) / runs
            for name, values in asymptote_sums.items()}

    def episode_sums(index):
        return np.einsum("bg,gb->b", weights, grouped.episodes[:, index])

    return metrics.batch_scalars(sums, runs, tops, threshold, plateau_fraction, support_fraction, keep,
                                 episode_sums, peak)


def cell_statistics(grouped: GroupedCurveSums, per_run: dict, rng: np.random.Generator, threshold: float,
                    plateau_fraction: float, support_fraction: float, samples: int = DEFAULT_SAMPLES,
                    confidence: float = DEFAULT_CONFIDENCE, drift: np.ndarray | None = None,
                    checkpoint: int = 0, point: dict | None = None) -> CellStatistics:
    """Intervals, bands and per-run scores of one cell (see the module docstring).

    Args:
        grouped: the cell's :class:`~tableclean_suite.metrics.GroupedCurveSums`.
        per_run: ``{"success", "average_reward", "terminal": (R,)}`` per-run asymptotes, in run order.
        rng: the cell's generator (:func:`bootstrap_rng`).
        samples: bootstrap replicates (>= 1).
        confidence: interval coverage in (0, 1).
        drift: per-run behaviour drift ``(R,)`` (:func:`tableclean_suite.settling.behaviour_drift`),
            resampled with the same replicates as the scalars; None: not measured.
        checkpoint: the iteration ``drift`` compares with (>= 1 when ``drift`` is given).
        point: ``{scalar: value}`` the point estimates (``Summary.scalars()``, the same estimator the
            replicates recompute); each interval is extended to hold its point
            (:func:`percentile_interval`).  None: plain percentile intervals.
    """
    iterations, groups = grouped.iterations, grouped.groups
    group_of = np.arange(grouped.runs) % groups
    asymptote_sums = {name: np.bincount(group_of, weights=values, minlength=groups) for name, values in per_run.items()}
    stride = max(1, -(-iterations // BAND_POINTS))
    kept = slice(0, iterations, stride)  # band iterations: a view of each batch's curves, not a gather
    scalars = {name: np.full(samples, np.nan) for name in SUMMARY_SCALARS}
    curves = {name: np.full((samples, len(range(iterations)[kept])), np.nan) for name in BAND_CURVES}
    drift_replicates = np.full(samples, np.nan)
    if groups >= MIN_GROUPS:
        peak = metrics.peak_index(grouped.totals().curves(support_fraction)["average_reward"])
        weights = uniform_multinomial(rng, groups, groups, samples).astype(float)
        # Every batch's weights are multinomial counts of ``groups`` draws (integers, each row summing
        # to ``groups``), so whether a sum is exact in any order is the same for all batches: check once.
        exact = {name: _exact_integer_product(weights, getattr(grouped, name)) for name in REPLICATE_SUMS}
        exact.update({f"asymptote {name}": _exact_integer_product(weights, values)
                      for name, values in asymptote_sums.items()})
        # Integer sums whose products stay below 2**24 are exact in float32 too.
        single = {name: getattr(grouped, name).astype(np.float32) for name in ("success", "finished_runs")
                  if exact[name] and _exact_integer_product(weights, getattr(grouped, name), EXACT_SINGLE_LIMIT)}
        for lo in range(0, samples, REPLICATE_BATCH):
            batch = slice(lo, lo + REPLICATE_BATCH)
            values, bands = replicate_scalars(grouped, asymptote_sums, weights[batch], threshold, plateau_fraction,
                                              support_fraction, kept, peak, exact, single)
            for name in SUMMARY_SCALARS:
                scalars[name][batch] = values[name]
            for name in BAND_CURVES:
                curves[name][batch] = bands[name]
        if drift is not None:
            drift_sums = np.bincount(group_of, weights=np.asarray(drift, dtype=np.float64), minlength=groups)
            drift_replicates = (weights @ drift_sums) / (weights @ grouped.runs_per_group)
    point = point or {}
    intervals = {name: percentile_interval(values, confidence, _number(point.get(name)))
                 for name, values in scalars.items()}
    bands = {name: _bands(values, confidence) for name, values in curves.items()}
    first = grouped.first_success_iterations()
    runs = {"success_asymptote": np.asarray(per_run["success"], dtype=float), "first_success_iterations": first}
    scores = {name: iqm_interval(np.where(np.isnan(values), np.inf, values), confidence, samples, rng)
              for name, values in runs.items()}
    settled = Settling.not_measured()
    if drift is not None:
        mean_drift = float(np.mean(drift))
        settled = Settling(mean_drift, *percentile_interval(drift_replicates, confidence, mean_drift), int(checkpoint))
    return CellStatistics(intervals, bands, stride, runs, scores, settled)


def _number(value) -> float | None:
    """``value`` as a float, None when it is missing (None or NaN)."""
    return None if value is None or value != value else float(value)


def _bands(replicates: np.ndarray, confidence: float) -> tuple[np.ndarray, np.ndarray]:
    """Per-column percentile bounds of ``(B, n)`` replicate curves (NaN-aware where needed): the
    bits of :func:`_numpy_bands`, computed by :func:`_band_columns` (numpy's when it cannot: a
    -0.0, whose place among equal zeros numpy's partition decides, or a central quantile)."""
    tail = 50.0 * (1.0 - confidence)
    quantiles = np.true_divide(np.array([tail, 100.0 - tail]), 100)  # np.percentile's q / 100
    replicates = np.asarray(replicates, dtype=np.float64)
    low = np.full(replicates.shape[1], np.nan)
    high = np.full(replicates.shape[1], np.nan)
    if replicates.shape[0] > 0 and _band_columns(replicates, quantiles[0], quantiles[1], 1.0 - MIN_DEFINED, low, high):
        return low, high
    return _numpy_bands(replicates, confidence)


def _numpy_bands(replicates: np.ndarray, confidence: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_bands` by numpy: ``np.percentile`` of the columns without NaN, ``np.nanpercentile``
    of those with at most ``1 - MIN_DEFINED`` NaN, NaN bounds for the rest."""
    tail = 50.0 * (1.0 - confidence)
    replicates = np.ascontiguousarray(replicates.T).T  # percentiles per column read columns
    low = np.full(replicates.shape[1], np.nan)
    high = np.full(replicates.shape[1], np.nan)
    undefined = np.isnan(replicates)
    clean = ~undefined.any(axis=0)
    if clean.any():
        low[clean], high[clean] = np.percentile(replicates[:, clean], [tail, 100.0 - tail], axis=0)
    partial = ~clean & (undefined.mean(axis=0) <= 1.0 - MIN_DEFINED)
    if partial.any():
        low[partial], high[partial] = np.nanpercentile(replicates[:, partial], [tail, 100.0 - tail], axis=0)
    return low, high


#: Most order statistics :func:`_band_columns` keeps at each end of a column (the 2.5 % and 97.5 %
#: points of 500 replicates need 14); bands that need more (central quantiles) are numpy's.
KEPT_ORDER_STATISTICS = 64


@numba.njit(cache=True, nogil=True)
def _band_columns(replicates, low_q, high_q, most_undefined, low, high):
    """:func:`_numpy_bands` of ``(B, n)`` ``replicates`` (B >= 1) into ``low``/``high`` (NaN-filled
    ``(n,)``), column by column with numpy's 'linear' quantile arithmetic (``low_q``/``high_q``:
    its quantiles in [0, 1]): of the column's m defined values (all of them, or, when at most
    ``most_undefined`` of them are NaN, the rest, as ``np.nanpercentile``), the order statistics
    at ``before = floor((m - 1) * q)`` and ``before + 1`` (both the last when ``(m - 1) * q >= m -
    1``), interpolated as numpy's ``_lerp`` with ``gamma = (m - 1) * q - before``.  The order
    statistics are found in one pass that keeps the column's few smallest and largest values
    (sorted insertion; a value tying the last kept one need not enter): their values do not
    depend on how they are found, unless zeros of both signs tie.

    Returns:
        False (``low``/``high`` unfinished) when a defined value is -0.0 (numpy's partition decides
        which zero lands at a rank) or a column needs more than :data:`KEPT_ORDER_STATISTICS` order
        statistics at one end: the caller computes the bands with numpy.
    """
    rows, n = replicates.shape
    column = np.empty(rows)
    smallest = np.empty(KEPT_ORDER_STATISTICS)
    largest = np.empty(KEPT_ORDER_STATISTICS)
    quantiles = (low_q, high_q)
    virtual = np.empty(2)
    before = np.empty(2, dtype=np.int64)
    after = np.empty(2, dtype=np.int64)
    for c in range(n):
        m = 0
        for r in range(rows):
            v = replicates[r, c]
            if v == v:
                if v == 0.0 and np.signbit(v):
                    return False
                column[m] = v
                m += 1
        if m == 0 or (m < rows and (rows - m) / rows > most_undefined):
            continue
        for k in range(2):  # numpy's _get_indexes
            virtual[k] = (m - 1) * quantiles[k]
            if virtual[k] >= m - 1:
                before[k] = m - 1
                after[k] = m - 1
            else:
                before[k] = int(np.floor(virtual[k]))
                after[k] = before[k] + 1
        n_small = after[0] + 1  # ranks 0 .. after[0]
        n_large = m - before[1]  # ranks before[1] .. m - 1
        if n_small > KEPT_ORDER_STATISTICS or n_large > KEPT_ORDER_STATISTICS:
            return False
        kept_small = 0
        kept_large = 0
        small_top = np.inf
        large_top = -np.inf
        for i in range(m):
            v = column[i]
            if kept_small < n_small or v < small_top:  # smallest[:kept_small] ascending
                slot = kept_small if kept_small < n_small else n_small - 1
                kept_small = min(kept_small + 1, n_small)
                while slot > 0 and smallest[slot - 1] > v:
                    smallest[slot] = smallest[slot - 1]
                    slot -= 1
                smallest[slot] = v
                small_top = smallest[n_small - 1] if kept_small == n_small else np.inf
            if kept_large < n_large or v > large_top:  # largest[:kept_large] descending
                slot = kept_large if kept_large < n_large else n_large - 1
                kept_large = min(kept_large + 1, n_large)
                while slot > 0 and largest[slot - 1] < v:
                    largest[slot] = largest[slot - 1]
                    slot -= 1
                largest[slot] = v
                large_top = largest[n_large - 1] if kept_large == n_large else -np.inf
        for k in range(2):
            if k == 0:
                a, b = smallest[before[0]], smallest[after[0]]
            else:
                a, b = largest[m - 1 - before[1]], largest[m - 1 - after[1]]
            gamma = virtual[k] - before[k]
            diff = b - a  # numpy's _lerp
            value = b - diff * (1 - gamma) if gamma >= 0.5 else a + diff * gamma
            if k == 0:
                low[c] = value
            else:
                high[c] = value
    return True


def comparisons(cells: list[dict], confidence: float = DEFAULT_CONFIDENCE, samples: int = DEFAULT_SAMPLES,
                seed: int = 0):
    """Probabilities of improvement between reward patterns (same learner) and between learners
    (same reward), on every per-run score.

    Args:
        cells: ``{"learner", "reward", "runs": {score: (R,)}}`` of the main cells.

    Returns:
        A DataFrame with columns ``comparison, learner_x, reward_x, learner_y, reward_y, score,
        higher_is_better, margin, probability_of_improvement, probability_of_improvement_low,
        probability_of_improvement_high`` (X improves on Y by more than ``margin``, the score's
        :data:`EQUIVALENCE_MARGINS` entry, with that probability; pairs within it count half):
        :func:`comparisons_frame` of :func:`comparison_rows`.
    """
    return comparisons_frame(comparison_rows(cells, confidence, samples, seed))


def comparisons_frame(rows: list[dict]):
    """The DataFrame of :func:`comparisons` from its rows (columns :data:`COMPARISON_COLUMNS`)."""
    import pandas as pd

    return pd.DataFrame(rows, columns=COMPARISON_COLUMNS)


def comparison_rows(cells: list[dict], confidence: float = DEFAULT_CONFIDENCE, samples: int = DEFAULT_SAMPLES,
                    seed: int = 0) -> list[dict]:
    """The rows of :func:`comparisons` as plain values (str, bool, float): JSON-serialisable, so
    that ``benchmarks.run`` can cache them (:mod:`.derived`)."""
    rows = []
    rng = np.random.default_rng(seed)
    for i, x in enumerate(cells):
        for y in cells[i + 1:]:
            same_learner, same_reward = x["learner"] == y["learner"], x["reward"] == y["reward"]
            if same_learner == same_reward:
                continue
            for score, higher in RUN_SCORES.items():
                a = np.where(np.isnan(x["runs"][score]), np.inf, x["runs"][score])
                b = np.where(np.isnan(y["runs"][score]), np.inf, y["runs"][score])
                margin = EQUIVALENCE_MARGINS[score]
                p, low, high = probability_of_improvement_interval(a, b, higher, confidence, samples, rng, margin)
                rows.append({"comparison": "reward" if same_learner else "learner",
                             "learner_x": x["learner"], "reward_x": x["reward"], "learner_y": y["learner"],
                             "reward_y": y["reward"], "score": score, "higher_is_better": higher,
                             "margin": margin, "probability_of_improvement": p, "probability_of_improvement_low": low,
                             "probability_of_improvement_high": high})
    return rows


COMPARISON_COLUMNS = ("comparison", "learner_x", "reward_x", "learner_y", "reward_y", "score", "higher_is_better",
                      "margin", "probability_of_improvement", "probability_of_improvement_low",
                      "probability_of_improvement_high")
