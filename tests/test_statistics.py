"""Statistics on hand-made samples with known answers (rliable's definitions)."""

import numpy as np
import pytest

from tableclean_suite.bench import statistics


def test_iqm_is_the_mean_of_the_middle_half():
    assert statistics.iqm(np.arange(1, 9)) == pytest.approx(4.5)  # mean of 3, 4, 5, 6
    assert statistics.iqm([10.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]) == pytest.approx(4.5)  # order-free, outlier-free
    # never-succeeding runs (inf) in the outer quarter leave it finite; in the middle they make it NaN
    assert statistics.iqm([1, 2, 3, 4, 5, 6, 7, np.inf]) == pytest.approx(4.5)
    assert np.isnan(statistics.iqm([1, 2, 3, np.inf, np.inf, np.inf, np.inf, np.inf]))


def test_probability_of_improvement_counts_pairs_and_half_ties():
    # pairs (x, y): 3 > 1, 3 > 2, 2 > 1, 2 = 2 (half) -> (3 + 0.5) / 4
    assert statistics.probability_of_improvement([3, 2], [1, 2]) == pytest.approx(0.875)
    assert statistics.probability_of_improvement([1, 2], [3, 2]) == pytest.approx(0.125)
    assert statistics.probability_of_improvement([1, 2], [3, 2], higher_is_better=False) == pytest.approx(0.875)
    assert statistics.probability_of_improvement([5], [5]) == 0.5


def test_probability_of_improvement_interval_brackets_and_is_seeded():
    rng = np.random.default_rng(1)
    x, y = rng.normal(1.0, 1.0, 300), rng.normal(0.0, 1.0, 300)
    p, low, high = statistics.probability_of_improvement_interval(x, y, rng=np.random.default_rng(7))
    again = statistics.probability_of_improvement_interval(x, y, rng=np.random.default_rng(7))
    assert (p, low, high) == again
    # P(N(1,1) > N(0,1)) = Phi(1 / sqrt 2) = 0.760
    assert low < 0.760 < high and low < p < high and high - low < 0.12


def test_bootstrap_interval_of_a_mean_matches_the_normal_approximation():
    sample = np.r_[np.zeros(50), np.ones(50)]  # mean 0.5, standard error 0.05
    rng = np.random.default_rng(3)
    replicates = [rng.choice(sample, len(sample)).mean() for _ in range(4000)]
    low, high = statistics.percentile_interval(replicates)
    assert low == pytest.approx(0.5 - 1.96 * 0.05, abs=0.015) and high == pytest.approx(0.5 + 1.96 * 0.05, abs=0.015)
    assert np.isnan(statistics.percentile_interval([1.0, np.nan, np.nan])[0])  # mostly undefined: no interval


def test_iqm_interval_contains_the_iqm_and_is_reproducible():
    values = np.random.default_rng(2).exponential(size=400)
    point, low, high = statistics.iqm_interval(values, rng=np.random.default_rng(5))
    assert (point, low, high) == statistics.iqm_interval(values, rng=np.random.default_rng(5))
    assert low < point < high


def test_bootstrap_groups_respect_runs_and_memory():
    assert statistics.bootstrap_groups(1000, 4000) == statistics.MAX_GROUPS
    assert statistics.bootstrap_groups(7, 4000) == 7
    assert statistics.bootstrap_groups(1000, 10**8) == 1


@pytest.mark.parametrize("n, d, size", [(1000, 1000, 20), (100, 100, 50), (7, 7, 30), (1, 1, 3), (5, 40, 10),
                                        (1000, 3, 10), (60, 2, 10), (10_000, 100, 5)])
def test_uniform_multinomial_is_numpys_multinomial_bit_for_bit(n, d, size):
    """Same counts and same generator state after (BTPE cases included: n >> d, and rows mixing BTPE
    with inversion: 10000 draws over 100 categories)."""
    ours, theirs = np.random.default_rng(11), np.random.default_rng(11)
    for _ in range(2):  # the second call reuses the set-up table
        assert np.array_equal(statistics.uniform_multinomial(ours, n, d, size),
                              theirs.multinomial(n, np.full(d, 1.0 / d), size=size))
    assert ours.bit_generator.state == theirs.bit_generator.state


def test_uniform_multinomial_without_a_table(monkeypatch):
    monkeypatch.setattr(statistics, "SETUP_TABLE_ENTRIES", 0)
    ours, theirs = np.random.default_rng(2), np.random.default_rng(2)
    assert np.array_equal(statistics.uniform_multinomial(ours, 300, 300, 40),
                          theirs.multinomial(300, np.full(300, 1.0 / 300), size=40))


def test_iqm_interval_equals_scipys_bootstrap_bit_for_bit():
    """The scipy-free bootstrap of the IQM against the scipy.stats.bootstrap call it replaced."""
    import scipy.stats as scipy_stats  # an install requirement: never skipped
    values = np.random.default_rng(4).choice(np.r_[np.linspace(0.0, 1.0, 37) ** 3, np.inf], size=301)
    point, low, high = statistics.iqm_interval(values, 0.9, 200, np.random.default_rng(9))
    reference = scipy_stats.bootstrap((values,), statistics._iqm_axis, n_resamples=200, confidence_level=0.9,
                                      method="percentile", vectorized=True, random_state=np.random.default_rng(9))
    assert (low, high) == statistics.percentile_interval(reference.bootstrap_distribution, 0.9)
    assert point == float(scipy_stats.trim_mean(np.sort(values), statistics.IQM_TRIM))
    grid = np.random.default_rng(1).normal(size=(13, 41))
    for axis in (0, -1):
        assert np.array_equal(statistics.trim_mean(grid, 0.25, axis), scipy_stats.trim_mean(grid, 0.25, axis=axis))


def test_weighted_group_sums_have_the_same_bits_for_any_thread_count():
    """The bootstrap's weighted sums must not depend on threads (a BLAS product's last bits do)."""
    import numba

    rng = np.random.default_rng(3)
    weights = rng.multinomial(100, np.full(100, 0.01), size=64).astype(float)
    values = rng.random((100, 257))
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = statistics.weighted_group_sums(weights, values)
        numba.set_num_threads(max(2, before))
        many = statistics.weighted_group_sums(weights, values)
    finally:
        numba.set_num_threads(before)
    assert np.array_equal(one, many)
    assert np.array_equal(one, np.einsum("bg,gt->bt", weights, values))  # groups summed in order
    np.testing.assert_allclose(one, weights @ values, rtol=1e-12)
    np.testing.assert_array_equal(statistics.weighted_group_sums(weights, values[:, 0]), one[:, 0])


def test_weighted_group_sums_of_counts_take_the_exact_product_with_the_ordered_sums_bits():
    """Integer counts (success, finished runs) go through the matrix product: exact, so the same
    bits as the ordered sum; fractional values and sums past 2**53 keep the ordered sum."""
    rng = np.random.default_rng(4)
    weights = rng.multinomial(100, np.full(100, 0.01), size=64).astype(float)
    counts = rng.integers(0, 11, (100, 257)).astype(float)
    assert statistics._exact_integer_product(weights, counts)
    ordered = statistics._weighted_rows(weights, counts)
    fast = statistics.weighted_group_sums(weights, counts)
    assert np.array_equal(fast.view(np.int64), ordered.view(np.int64))  # bits, signs of zeros included
    negative_zeros = statistics.weighted_group_sums(weights, -np.zeros((100, 3)))
    assert not np.signbit(negative_zeros).any()
    assert not statistics._exact_integer_product(weights, counts + 0.5)
    assert not statistics._exact_integer_product(weights, counts * 2.0 ** 50)


def test_max_average_reward_interval_contains_its_point():
    """The interval is the curve's value at the maximising iteration, so it brackets the maximum
    (the maximum of each resampled curve would be biased upward and could miss it)."""
    from tableclean_suite import metrics
    from tableclean_suite.curves import GroupedCurveSums
    from tableclean_suite.learners import train

    runs, iterations, groups = 1000, 4000, 100  # the harness default: a long flat plateau of noisy points
    result = train("q_learning", reward="r4", runs=runs, iterations=iterations, seed=3)
    grouped = GroupedCurveSums.zeros(iterations, groups).add(result)
    per_run = {name: np.full(runs, 0.5) for name in ("success", "average_reward", "terminal")}
    stats = statistics.cell_statistics(grouped, per_run, np.random.default_rng(0), 0.95, 0.25, 0.5, samples=200)
    point = metrics.maximum(grouped.totals().curves(0.5)["average_reward"])
    low, high = stats.intervals["max_average_reward"]
    assert low <= point <= high and low < high


def test_percentile_interval_is_extended_to_hold_its_point():
    replicates = np.arange(100.0)  # percentile interval [2.475, 96.525]
    low, high = statistics.percentile_interval(replicates)
    assert statistics.percentile_interval(replicates, point=50.0) == (low, high)  # inside: unchanged
    assert statistics.percentile_interval(replicates, point=99.5) == (low, 99.5)  # above: the top end moves
    assert statistics.percentile_interval(replicates, point=-1.0) == (-1.0, high)
    assert statistics.extended_side(replicates, 99.5) and not statistics.extended_side(replicates, 50.0)
    assert statistics.percentile_interval(replicates, point=float("nan")) == (low, high)  # no point: plain


def _pairwise_probability(x, y, margin):
    wins = sum(1.0 if a > b + margin else 0.5 if abs(a - b) <= margin else 0.0 for a in x for b in y)
    return wins / (len(x) * len(y))


def test_probability_of_improvement_counts_differences_within_the_margin_as_ties():
    x, y = [0.8714, 0.8710, 0.80], [0.8712, 0.7, 0.8714]
    assert statistics.probability_of_improvement(x, y) == pytest.approx(_pairwise_probability(x, y, 0.0))
    tied = statistics.probability_of_improvement(x, y, margin=0.01)
    assert tied == pytest.approx(_pairwise_probability(x, y, 0.01))
    assert tied != statistics.probability_of_improvement(x, y)  # 0.04 pp differences no longer decide
    assert statistics.probability_of_improvement([0.87101], [0.87142], margin=0.01) == 0.5
    with pytest.raises(ValueError, match="margin must be a number >= 0"):
        statistics.probability_of_improvement(x, y, margin=-0.1)


def test_probability_of_improvement_interval_replicates_are_the_pairwise_definition():
    """Each replicate is P of the resampled runs: check one replicate's counts by brute force."""
    rng = np.random.default_rng(4)
    x, y = np.round(rng.normal(0.87, 0.01, 40), 3), np.round(rng.normal(0.868, 0.01, 30), 3)
    for margin in (0.0, 0.0055):  # ties at margin 0 (rounded values); no difference on a margin boundary
        p, low, high = statistics.probability_of_improvement_interval(x, y, samples=1, rng=np.random.default_rng(9),
                                                                      margin=margin)
        draw = np.random.default_rng(9)
        cx = statistics.uniform_multinomial(draw, len(x), len(x), 1)[0]
        cy = statistics.uniform_multinomial(draw, len(y), len(y), 1)[0]
        replicate = _pairwise_probability(np.repeat(x, cx), np.repeat(y, cy), margin)
        assert p == pytest.approx(_pairwise_probability(x, y, margin))
        assert min(replicate, p) == pytest.approx(low) and max(replicate, p) == pytest.approx(high)


def test_every_interval_of_the_harness_tables_holds_its_point(tmp_path):
    """One test over every ``X``/``X_low``/``X_high`` column of Table 3, Table 4 and the
    comparisons that a (small) harness run writes: no reported number lies outside its interval."""
    import pandas as pd

    from tableclean_suite.bench import run

    out = tmp_path / "run"
    assert run.main(["--runs", "40", "--iterations", "600", "--bootstrap-samples", "60", "--no-literature",
                     "--out", str(out), "--fresh"]) == 0
    checked = 0
    for name in ("table3.csv", "table4.csv", "comparisons.csv"):
        frame = pd.read_csv(out / name)
        for column in frame.columns:
            if f"{column}_low" not in frame.columns:
                continue
            value, low, high = (frame[c].astype(float) for c in (column, f"{column}_low", f"{column}_high"))
            defined = value.notna() & low.notna()
            assert ((low[defined] <= value[defined]) & (value[defined] <= high[defined])).all(), (name, column)
            checked += int(defined.sum())
    assert checked > 200  # the check is not vacuous


@pytest.mark.parametrize("kind", ["integers", "integers_inf", "fractions", "fractions_inf", "nan", "signed_zero",
                                  "ties", "integers_both_infs", "large_integers", "few_integers"])
def test_resampled_iqms_are_the_sorted_rows_bits(kind):
    rng = np.random.default_rng(3)
    values = {"integers": rng.integers(1, 4000, 200).astype(float),
              "integers_inf": np.where(rng.random(200) < 0.2, np.inf, rng.integers(1, 4000, 200)),
              "fractions": rng.random(200),
              "fractions_inf": np.where(rng.random(200) < 0.3, np.inf, rng.random(200)),
              "nan": np.where(rng.random(200) < 0.1, np.nan, rng.random(200)),
              "signed_zero": np.where(rng.random(200) < 0.3, -0.0, rng.random(200)),
              "ties": rng.choice([0.0, 0.25, 1 / 3, 0.5, 1.0], 200),
              "integers_both_infs": rng.choice([-np.inf, np.inf, -3.0, 0.0, 7.0, 4000.0], 200, p=[.1, .2, .2, .2, .2, .1]),
              "large_integers": rng.integers(-2 ** 44, 2 ** 44, 200).astype(float),  # sums near 2**53: exact still
              "few_integers": rng.integers(0, 3, 200).astype(float)}[kind]
    index = rng.integers(0, len(values), (300, len(values)))
    expected = statistics._iqm_axis(values[index], axis=-1)
    assert statistics.resampled_iqms(values, index).tobytes() == expected.tobytes()
    odd = index[:, :77]  # resamples of another size than the values
    assert statistics.resampled_iqms(values, odd).tobytes() == statistics._iqm_axis(values[odd], axis=-1).tobytes()


def test_weighted_group_sums_told_exactness_give_the_checked_bits():
    rng = np.random.default_rng(4)
    weights = statistics.uniform_multinomial(rng, 30, 30, 40).astype(float)
    for values in (rng.integers(0, 10, (30, 50)).astype(float), rng.normal(size=(30, 50)), rng.random(30)):
        exact = statistics._exact_integer_product(weights, values)
        checked = statistics.weighted_group_sums(weights, values)
        told = statistics.weighted_group_sums(weights, values, exact)
        ordered = statistics.weighted_group_sums(weights, values, False)
        assert told.tobytes() == checked.tobytes()
        assert ordered.tobytes() == checked.tobytes() or not exact  # exact sums: either way, the same bits


def _ordered_weighted_sums(weights, values):
    """The definition: per output element, ``weights[b, g] * values[g, t]`` added for g ascending,
    zero weights skipped, each product rounded then added (numpy elementwise, one group at a time)."""
    out = np.zeros((weights.shape[0], values.shape[1]))
    for g in range(weights.shape[1]):
        rows = weights[:, g] != 0.0
        out[rows] = out[rows] + weights[rows, g][:, None] * values[g]
    return out


@pytest.mark.parametrize("groups, length", [(37, 1300), (100, 4000), (3, 5), (1, 1)])
def test_weighted_row_range_is_the_ordered_sum_bit_for_bit(groups, length):
    """The tiled kernel (columns in tiles, four groups per pass) adds the same products in the same
    order as the plain loop: every bit, on values of mixed magnitudes and signs, infinities and
    negative zeros (tiles and group counts with remainders included)."""
    rng = np.random.default_rng(groups)
    weights = rng.multinomial(groups, np.full(groups, 1.0 / groups), size=23).astype(float)
    weights[5] *= 0.37  # non-integer weights too
    values = rng.normal(size=(groups, length)) * 10.0 ** rng.integers(-8, 9, (groups, length))
    values[rng.random((groups, length)) < 0.01] = -0.0
    values[rng.random((groups, length)) < 0.001] = np.inf
    out = np.zeros((weights.shape[0], length))
    statistics._weighted_row_range(0, weights.shape[0], weights, values, out)
    assert out.tobytes() == _ordered_weighted_sums(weights, values).tobytes()
    assert statistics.weighted_group_sums(weights, values, False).tobytes() == out.tobytes()


@pytest.mark.parametrize("confidence", [0.95, 0.9, 0.5, 0.999])
def test_bands_are_numpys_percentiles_bit_for_bit(confidence):
    """The compiled bands are ``np.percentile`` (clean columns) and ``np.nanpercentile`` (columns
    mostly defined) bit for bit: few and many replicates, ties, infinities, NaN shares on both
    sides of the limit; a -0.0 falls back to numpy."""
    import warnings

    rng = np.random.default_rng(7)
    compiled = 0
    for trial in range(120):
        rows, columns = int(rng.integers(1, 600)), int(rng.integers(1, 30))
        curves = rng.normal(size=(rows, columns)) * 10.0 ** rng.uniform(-3, 3)
        if trial % 3 == 1:
            curves = np.abs(np.round(curves))  # ties (+0.0 only)
        if trial % 3 == 2:
            curves = rng.integers(0, 3, (rows, columns)) / 3.0
        curves[rng.random((rows, columns)) < rng.uniform(0.0, 0.8, columns)] = np.nan
        if trial % 7 == 0:
            curves[rng.random((rows, columns)) < 0.05] = np.inf * rng.choice([-1.0, 1.0])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            expected = statistics._numpy_bands(curves, confidence)
        for ours, theirs in zip(statistics._bands(curves, confidence), expected):
            assert ours.tobytes() == theirs.tobytes()
        compiled += statistics._band_columns(curves, *np.true_divide([50.0 * (1 - confidence),
                                                                      100 - 50.0 * (1 - confidence)], 100),
                                             0.5, np.full(columns, np.nan), np.full(columns, np.nan))
    assert compiled > (100 if confidence > 0.9 else -1)  # the tails' bands are the kernel's, not numpy's
    signed = np.array([[-0.0, 1.0], [0.0, 2.0], [-0.0, 3.0]])
    assert not statistics._band_columns(signed, 0.025, 0.975, 0.5, np.full(2, np.nan), np.full(2, np.nan))
    for ours, theirs in zip(statistics._bands(signed, confidence), statistics._numpy_bands(signed, confidence)):
        assert ours.tobytes() == theirs.tobytes()


def test_weighted_group_sums_in_single_precision_give_the_exact_bits():
    """Counts whose products stay below 2**24 are summed in float32 (the bootstrap's success and
    finished-run sums): the same bits as the float64 sums, negative zeros mapped to +0.0; the
    limit check tells such values from larger ones."""
    rng = np.random.default_rng(8)
    weights = statistics.uniform_multinomial(rng, 100, 100, 64).astype(float)
    counts = rng.integers(0, 11, (100, 777)).astype(float)
    counts[:, :5] = -0.0
    assert statistics._exact_integer_product(weights, counts, statistics.EXACT_SINGLE_LIMIT)
    fast = statistics.weighted_group_sums(weights, counts, True, counts.astype(np.float32))
    assert fast.dtype == np.float64
    assert fast.tobytes() == statistics.weighted_group_sums(weights, counts, False).tobytes()
    large = counts * 2.0 ** 17  # sums past 2**24: float32 would round
    assert statistics._exact_integer_product(weights, large)
    assert not statistics._exact_integer_product(weights, large, statistics.EXACT_SINGLE_LIMIT)
