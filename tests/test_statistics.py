"""Intervals over independent runs on samples with known answers (rliable's definitions), and a
cell's statistics against its per-run records."""

import math

import numpy as np
import pytest
from scipy import stats

import curve_oracle
from tableclean_suite import curves, intervals
from tableclean_suite.bench import statistics
from tableclean_suite.learners import train


def _pairwise(x, y, higher_is_better=True, margin=0.0):
    """The definition, pair by pair."""
    d = np.subtract.outer(np.asarray(x, float), np.asarray(y, float))
    d = d if higher_is_better else -d
    return float((d > margin).mean() + 0.5 * (np.abs(d) <= margin).mean())


def test_probability_of_improvement_counts_pairs_and_half_ties():
    # pairs (x, y): 3 > 1, 3 > 2, 2 > 1, 2 = 2 (half) -> (3 + 0.5) / 4
    assert intervals.probability_of_improvement([3, 2], [1, 2]) == pytest.approx(0.875)
    assert intervals.probability_of_improvement([1, 2], [3, 2]) == pytest.approx(0.125)
    assert intervals.probability_of_improvement([1, 2], [3, 2], higher_is_better=False) == pytest.approx(0.875)
    assert intervals.probability_of_improvement([5], [5]) == 0.5
    with pytest.raises(ValueError, match="margin"):
        intervals.probability_of_improvement([1], [2], margin=-1.0)


@pytest.mark.parametrize("margin", [0.0, 0.5, 3.0])
@pytest.mark.parametrize("higher", [True, False])
def test_probability_of_improvement_is_the_pairwise_definition(margin, higher):
    rng = np.random.default_rng(4)
    x, y = rng.integers(0, 30, 57).astype(float), rng.integers(0, 40, 43).astype(float)
    assert intervals.probability_of_improvement(x, y, higher, margin) == pytest.approx(_pairwise(x, y, higher, margin),
                                                                                       abs=1e-15)


def test_improvement_resamples_are_the_pairwise_definition_of_the_resampled_runs():
    """The counting statistic scipy's bootstrap calls on run indices gives, per resample, the
    definition applied to the resampled runs' values."""
    rng = np.random.default_rng(5)
    x, y = rng.integers(0, 9, 20).astype(float), rng.integers(0, 9, 30).astype(float)
    statistic = intervals._Improvement(x, y, False, 1.0)
    ix, iy = rng.integers(0, 20, (6, 20)), rng.integers(0, 30, (6, 30))
    expected = [_pairwise(x[a], y[b], False, 1.0) for a, b in zip(ix, iy)]
    np.testing.assert_allclose(statistic(ix, iy), expected, rtol=0, atol=1e-15)


def test_improvement_estimate_covers_the_known_value_and_is_seeded():
    rng = np.random.default_rng(1)
    x, y = rng.normal(1.0, 1.0, 300), rng.normal(0.0, 1.0, 300)
    p, low, high = intervals.improvement_estimate(x, y, rng=np.random.default_rng(7), reps=1000)
    assert (p, low, high) == intervals.improvement_estimate(x, y, rng=np.random.default_rng(7), reps=1000)
    # P(N(1,1) > N(0,1)) = Phi(1 / sqrt 2) = 0.760
    assert low < 0.760 < high and low < p < high and high - low < 0.15
    bca = intervals.improvement_estimate(x, y, rng=np.random.default_rng(7), reps=1000, method="bca")
    assert bca[0] == p and bca[1:] != (low, high) and bca[1] < 0.760 < bca[2]


def test_interval_estimates_is_scipys_bootstrap_with_the_same_generator():
    values = np.random.default_rng(2).exponential(size=300)
    points, bounds = intervals.interval_estimates({"a": values}, np.mean, 0.9, 500, "percentile",
                                                  np.random.default_rng(3))
    reference = stats.bootstrap((values,), np.mean, n_resamples=500, confidence_level=0.9, method="percentile",
                                vectorized=True, rng=np.random.default_rng(3)).confidence_interval
    assert points["a"] == values.mean() and bounds["a"] == (reference.low, reference.high)


def test_interval_estimates_stratifies_tuples_and_handles_degenerate_samples():
    rng = np.random.default_rng(8)
    a, b = rng.normal(0.0, 1.0, 200), rng.normal(2.0, 1.0, 100)

    def difference(x, y, axis=-1):
        return np.mean(y, axis=axis) - np.mean(x, axis=axis)

    points, bounds = intervals.interval_estimates({"d": (a, b)}, difference, rng=np.random.default_rng(0), reps=800)
    _, degenerate = intervals.interval_estimates({"same": np.full(9, 4.0), "one": np.array([1.0])}, np.mean)
    assert bounds["d"][0] < points["d"] < bounds["d"][1] and bounds["d"][0] < 2.0 < bounds["d"][1]
    assert degenerate["same"] == (4.0, 4.0)  # no spread to resample
    assert all(math.isnan(v) for v in degenerate["one"])  # one run: no interval


@pytest.mark.parametrize("bad, message", [({"confidence": 1.0}, "confidence"), ({"reps": 0}, "reps"),
                                          ({"method": "basic"}, "method")])
def test_interval_estimates_refuse_bad_settings_naming_them(bad, message):
    with pytest.raises(ValueError, match=message):
        intervals.interval_estimates({"a": np.arange(5.0)}, np.mean, **bad)


def test_clopper_pearson_is_the_exact_binomial_interval():
    low, high = intervals.clopper_pearson(18, 20)
    assert low == pytest.approx(0.683, abs=1e-3) and high == pytest.approx(0.988, abs=1e-3)
    assert intervals.clopper_pearson(0, 40)[0] == 0.0 and intervals.clopper_pearson(0, 40)[1] > 0.0
    assert all(math.isnan(v) for v in intervals.clopper_pearson(0, 0))
    # one-sided: the lower end of the two-sided interval at twice the error; n successes in n: (1 - c) ** (1 / n)
    assert intervals.clopper_pearson(18, 20, 0.975, "greater") == pytest.approx((low, 1.0), rel=1e-12)
    assert intervals.clopper_pearson(20, 20, 0.95, "greater")[0] == pytest.approx(0.05 ** (1 / 20), rel=1e-12)


def test_mean_band_is_the_normal_interval_of_the_per_run_values():
    values = np.random.default_rng(6).random((50, 7))  # 50 runs x 7 iterations
    low, high = intervals.mean_band(values.sum(0), (values ** 2).sum(0), np.full(7, 50.0), 0.95)
    half = stats.norm.ppf(0.975) * values.std(axis=0, ddof=1) / np.sqrt(50)
    np.testing.assert_allclose(low, values.mean(0) - half, rtol=1e-12)
    np.testing.assert_allclose(high, values.mean(0) + half, rtol=1e-12)
    assert np.isnan(intervals.mean_band([1.0], [1.0], [1.0])[0]).all()  # one value: no interval


@pytest.fixture(scope="module")
def cell():
    result = train("q_learning", "r4", runs=40, iterations=500, max_itr=80, seed=3)
    sums = curves.curve_sums(result)
    per_run = {"success": np.linspace(0.5, 0.9, 40), "average_reward": np.linspace(0.0, 0.2, 40),
               "terminal": np.ones(40), "greedy_success": np.ones(40), "never_terminal": np.r_[np.ones(3), np.zeros(37)]}
    return result, sums, per_run


def test_cell_statistics_bands_per_run_means_and_learning_time(cell):
    result, sums, per_run = cell
    learned = np.r_[np.arange(30) * 10, -np.ones(10, dtype=int)]
    cell_stats = statistics.cell_statistics(sums, per_run, statistics.bootstrap_rng(0, "x"), 0.5, samples=300,
                                            learned_at=learned, budget=500)
    success = curve_oracle.success_matrix(result)
    low, high = cell_stats.bands["success"]
    half = stats.norm.ppf(0.975) * success.std(axis=0, ddof=1) / np.sqrt(40)
    np.testing.assert_allclose(low, success.mean(0) - half, atol=1e-12)
    np.testing.assert_allclose(high, success.mean(0) + half, atol=1e-12)
    average = curve_oracle.average_reward_matrix(result)
    unsupported = np.isnan(average).mean(axis=0) > 0.5
    assert np.isnan(cell_stats.bands["average_reward"][0][unsupported]).all()
    low, high = cell_stats.intervals["success_plateau"]
    assert low < per_run["success"].mean() < high
    assert cell_stats.intervals["greedy_success_plateau"] == pytest.approx(intervals.clopper_pearson(40, 40))
    assert cell_stats.intervals["greedy_success_plateau"][0] < 1.0  # all 40 runs succeed: not a zero-width interval
    assert cell_stats.intervals["never_terminal_share"] == pytest.approx(intervals.clopper_pearson(3, 40))
    assert cell_stats.learning.censored_share == 0.25 and cell_stats.learning.budget == 500
    np.testing.assert_array_equal(cell_stats.runs["learning_time"], np.r_[np.arange(30) * 10.0, np.full(10, 500.0)])
    again = statistics.cell_statistics(sums, per_run, statistics.bootstrap_rng(0, "x"), 0.5, samples=300,
                                       learned_at=learned, budget=500)
    assert again.intervals == cell_stats.intervals and again.learning == cell_stats.learning


def test_cell_statistics_without_learning_times_leave_them_out(cell):
    _, sums, per_run = cell
    cell_stats = statistics.cell_statistics(sums, per_run, statistics.bootstrap_rng(0, "x"), 0.5, samples=50)
    assert cell_stats.learning is None and "learning_time" not in cell_stats.runs
    record = statistics.learning_time_record(None)
    assert set(record) == {f"{c}{s}" for c in statistics.LEARNING_TIME_COLUMNS for s in ("", "_low", "_high")}
    assert all(math.isnan(v) for v in record.values())


def test_simulated_means_take_their_monte_carlo_error_into_their_intervals(cell):
    """A simulated plateau's interval is the bootstrap's widened in quadrature by z x its Monte
    Carlo error, clipped to [0, 1]; the others are untouched."""
    _, sums, per_run = cell
    exact = statistics.cell_statistics(sums, per_run, statistics.bootstrap_rng(0, "x"), 0.5, samples=200)
    simulated = statistics.cell_statistics(sums, per_run, statistics.bootstrap_rng(0, "x"), 0.5, samples=200,
                                           monte_carlo={"success": 0.05, "greedy_success": 0.01})
    low, high = exact.intervals["success_plateau"]
    mean, z = per_run["success"].mean(), stats.norm.ppf(0.975)
    assert simulated.intervals["success_plateau"] == pytest.approx(
        (mean - math.hypot(mean - low, z * 0.05), mean + math.hypot(high - mean, z * 0.05)))
    greedy_low, greedy_high = simulated.intervals["greedy_success_plateau"]
    assert greedy_low < exact.intervals["greedy_success_plateau"][0] and greedy_high == 1.0  # clipped
    for name in ("average_reward_plateau", "terminal_plateau", "never_terminal_share"):
        assert simulated.intervals[name] == exact.intervals[name]


def test_comparisons_pair_rewards_and_learners_on_each_score_they_share():
    rng = np.random.default_rng(0)
    runs = lambda: {"success_asymptote": rng.random(30), "learning_time": rng.integers(0, 100, 30).astype(float)}  # noqa: E731
    cells = [{"learner": learner, "reward": reward, "runs": runs()}
             for learner in ("q_learning", "sarsa") for reward in ("r1", "r2")]
    cells[-1]["runs"].pop("learning_time")  # a cell without learning times is compared on the rest
    frame = statistics.comparisons(cells, samples=200, seed=1)
    assert tuple(frame.columns) == statistics.COMPARISON_COLUMNS
    assert len(frame) == 2 * 4 - 2  # 4 pairs (2 reward, 2 learner), 2 scores, 2 missing learning times
    row = frame[(frame["reward_x"] == "r1") & (frame["reward_y"] == "r2") & (frame["learner_x"] == "q_learning")
                & (frame["score"] == "learning_time")].iloc[0]
    assert row["probability_of_improvement"] == pytest.approx(
        _pairwise(cells[0]["runs"]["learning_time"], cells[1]["runs"]["learning_time"], False))
    assert row["margin"] == statistics.EQUIVALENCE_MARGINS["learning_time"] and not row["higher_is_better"]
    assert frame.equals(statistics.comparisons(cells, samples=200, seed=1))


def test_unseen_share_is_the_exact_bound_for_an_outcome_no_run_showed():
    """1 - 0.025 ** (1 / n): with that probability of a kind of run, n runs miss it all in 2.5 % of samples."""
    share = intervals.unseen_share(1000)
    assert abs((1 - share) ** 1000 - 0.025) < 1e-12 and 0.0036 < share < 0.0037
    with pytest.raises(ValueError, match="runs must be"):
        intervals.unseen_share(0)


def test_a_mean_of_identical_runs_is_widened_toward_the_limits_a_rare_run_could_reach():
    """Every run of a sample at 0.87 (a rare run at 0.2 absent): the interval reaches below 0.87 by the
    unseen share times the distance to 0, and above by the share times the distance to 1, not past them."""
    values = np.full(1000, 0.87)
    share = intervals.unseen_share(1000)
    low, high = intervals.widened_for_unseen_runs(0.87, 0.87, values, (0.0, 1.0))
    assert low == pytest.approx(0.87 - share * 0.87) and high == pytest.approx(0.87 + share * 0.13)
    rare = 0.87 * (1 - 1 / 5000) + 0.2 / 5000  # the mean with one run in 5000 at 0.2
    assert low <= rare <= high
    assert intervals.widened_for_unseen_runs(0.0, 0.1, np.zeros(1000), (0.0, 1.0))[0] == 0.0
