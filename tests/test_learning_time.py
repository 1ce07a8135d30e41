"""The per-run learning time's summary: Kaplan-Meier with runs censored at the budget, checked
against lifelines' estimates and against the definitions on hand-made samples."""

import math

import numpy as np
import pytest

from tableclean_suite.learning_time import learning_time_summary, survival


def test_without_censoring_the_median_and_quartiles_are_the_order_statistics():
    times = np.array([7, 3, 9, 1, 5, 5, 8, 2])  # sorted 1 2 3 5 5 7 8 9
    summary = learning_time_summary(times, 10, rng=np.random.default_rng(0))
    assert (summary.q1, summary.median, summary.q3) == (2.0, 5.0, 7.0)  # first t with S(t) <= 3/4, 1/2, 1/4
    assert summary.rmst == times.mean() and summary.censored_share == 0.0
    assert summary.median_low <= summary.median <= summary.median_high


def test_censored_runs_count_at_the_budget_and_are_never_dropped():
    times = np.r_[np.arange(1, 5), -np.ones(6, dtype=int)]  # 4 learned by t = 4, 6 never within 100
    summary = learning_time_summary(times, 100, rng=np.random.default_rng(0))
    assert summary.censored_share == 0.6 and summary.median == math.inf  # dropping them would give 2
    assert summary.q1 == 3.0 and summary.rmst == pytest.approx((1 + 2 + 3 + 4 + 600) / 10)
    low, high = summary.censored_low, summary.censored_high
    assert 0.0 < low < 0.6 < high < 1.0


def test_matches_lifelines_kaplan_meier_median_interval_and_restricted_mean():
    lifelines = pytest.importorskip("lifelines")
    from lifelines.utils import median_survival_times, restricted_mean_survival_time

    rng = np.random.default_rng(3)
    times = np.round(rng.gamma(3.0, 50.0, 400)).astype(int)
    times[times > 300] = -1
    durations = np.where(times < 0, 300, times)
    fitter = lifelines.KaplanMeierFitter().fit(durations, times >= 0)
    summary = learning_time_summary(times, 300, rng=np.random.default_rng(0))
    assert summary.median == fitter.median_survival_time_
    bounds = median_survival_times(fitter.confidence_interval_)
    assert (summary.median_low, summary.median_high) == tuple(float(v) for v in bounds.to_numpy()[0])
    assert summary.rmst == pytest.approx(restricted_mean_survival_time(fitter, t=300), rel=1e-12)


def test_survival_is_one_minus_the_empirical_distribution_below_the_budget():
    times = np.array([0, 0, 4, 4, 4, 9, -1, -1])
    fit = survival(times, 12).sf
    np.testing.assert_allclose(fit.evaluate([0, 3, 4, 8, 9, 12]), [6 / 8, 6 / 8, 3 / 8, 3 / 8, 2 / 8, 2 / 8])


def test_intervals_cover_the_many_run_values_in_a_replication_study():
    """100 replications of 300 runs of a discrete, partly censored distribution: each interval
    holds the value of 10^6 runs at least 85 times (nominal 95)."""
    budget = 600

    def draw(rng, n):
        times = np.round(rng.gamma(4.0, 40.0, n)).astype(int)
        times[(rng.random(n) < 0.1) | (times > budget)] = -1
        return times

    pool = draw(np.random.default_rng(99), 1_000_000)
    at_budget = np.where(pool < 0, budget + 1, pool)
    truth = {"median": np.quantile(at_budget, 0.5, method="inverted_cdf"),
             "q1": np.quantile(at_budget, 0.25, method="inverted_cdf"),
             "rmst": np.minimum(at_budget, budget).mean(), "censored": (pool < 0).mean()}
    covered = dict.fromkeys(truth, 0)
    for k in range(100):
        summary = learning_time_summary(draw(np.random.default_rng(k), 300), budget, reps=300,
                                        rng=np.random.default_rng(k))
        covered["median"] += summary.median_low <= truth["median"] <= summary.median_high
        covered["q1"] += summary.q1_low <= truth["q1"] <= summary.q1_high
        covered["rmst"] += summary.rmst_low <= truth["rmst"] <= summary.rmst_high
        covered["censored"] += summary.censored_low <= truth["censored"] <= summary.censored_high
    assert min(covered.values()) >= 85, covered


@pytest.mark.parametrize("values, budget, message", [([3, -2], 10, "-2"), ([3, 11], 10, "11"), ([[1]], 10, "1-D"),
                                                     ([1.5], 10, "1.5"), ([1], 0, "budget")])
def test_bad_learning_times_are_refused_naming_the_value(values, budget, message):
    with pytest.raises(ValueError, match=message):
        learning_time_summary(np.array(values), budget)


def test_no_runs_give_an_all_nan_summary():
    summary = learning_time_summary(np.zeros(0, dtype=int), 50)
    assert summary.runs == 0 and math.isnan(summary.median) and math.isnan(summary.censored_share)


def test_survival_curve_is_the_share_not_yet_learned_with_its_band():
    from tableclean_suite.learning_time import survival_curve

    times = np.array([0, 2, 2, 5, -1, -1, 3, 9, 9, 1])
    curve, low, high = survival_curve(times, 10)
    at_budget = np.where(times < 0, 11, times)
    expected = [(at_budget > t).mean() for t in range(1, 11)]
    np.testing.assert_allclose(curve, expected)
    assert curve.shape == low.shape == high.shape == (10,)
    assert (low <= curve + 1e-12).all() and (curve <= high + 1e-12).all() and (high[:3] > low[:3]).all()
