"""The scaling study (:mod:`tableclean_suite.bench.scaling`): its specs, exact quantities, fit and CLI."""

from __future__ import annotations

import json
import os
import math

import numpy as np
import pandas as pd
import pytest

from tableclean_suite import metrics
from tableclean_suite.analysis import action_probabilities, exact_success_probability
from tableclean_suite.bench import cli, scaling
from tableclean_suite.bench.scaling import command, family, report, statistics, study
from tableclean_suite.task import Outcome, TaskModel

#: A tiny study: 2 x 2 specs (20, 50, 90 and 327 reachable states), short windows, few runs and resamples.
TINY_ARGS = ["--segments", "3,2", "--objects", "2,1", "--seeds", "2", "--runs", "4", "--base-window", "300",
             "--resamples", "20",
             "--fixed-plan-objects", "1,2", "--learners", "q_learning", "--rewards", "r2,r4"]
#: The paper's reachable states (from every all-unclean layout).
PAPER_REACHABLE = 20
PAPER_EPSILON, PAPER_MAX_ITR = 0.1, 500
#: ``scaling.csv`` figures with ``_low``/``_high`` interval columns.
INTERVAL_FIGURES = ("learning_time", "success_window_mean", "never_terminal_share")


def _optimal(model):
    return model.distances_to_terminal(), model.optimal_policy()


#: The issue's family: N = 2..5 segments x M = 1..3 objects, up to at least this many reachable states.
ISSUE_SEGMENTS, ISSUE_OBJECTS, ISSUE_MIN_LARGEST_REACHABLE = (2, 3, 4, 5), (1, 2, 3), 30_000


def _reachable(segments, objects):
    return len(TaskModel(spec=family.family_spec(segments, objects)).reachable_states())


def test_family_reachable_counts_grow_along_both_axes_and_start_at_the_paper():
    counts = {(n, m): _reachable(n, m) for n in (2, 3, 4) for m in (1, 2)}
    assert counts[2, 1] == PAPER_REACHABLE
    assert all(counts[2, m] < counts[3, m] < counts[4, m] for m in (1, 2))
    assert all(counts[n, 1] < counts[n, 2] for n in (2, 3, 4))
    assert family.family_spec(2, 1).name == "paper"
    assert family.family_spec(3, 2).name == "scale_n3_m2"


def test_default_family_spans_three_object_counts_and_30000_reachable_states():
    specs = family.family_specs(family.DEFAULT_SEGMENTS, family.DEFAULT_OBJECT_COUNTS)
    assert family.DEFAULT_SEGMENTS == ISSUE_SEGMENTS and family.DEFAULT_OBJECT_COUNTS == ISSUE_OBJECTS
    assert {(s.segments, s.n_objects) for s in specs} == {(n, m) for n in ISSUE_SEGMENTS for m in ISSUE_OBJECTS}
    assert len(specs) == len(ISSUE_SEGMENTS) * len(ISSUE_OBJECTS)
    reachable = {s.name: len(TaskModel(spec=s).reachable_states()) for s in specs}
    assert min(reachable.values()) == PAPER_REACHABLE
    largest = family.family_spec(max(ISSUE_SEGMENTS), max(ISSUE_OBJECTS))
    assert reachable[largest.name] == max(reachable.values()) >= ISSUE_MIN_LARGEST_REACHABLE


def test_describe_family_orders_specs_by_reachable_states():
    specs = family.family_specs((3, 2), (2, 1))
    assert [(s.segments, s.n_objects) for s in specs] == [(3, 2), (3, 1), (2, 2), (2, 1)]
    infos = [info for info, _ in family.describe_family(specs, 8, 100, 1.0)]
    assert [(i.segments, i.objects) for i in infos][0] == (2, 1) and len(infos) == 4
    assert [i.reachable_from_start for i in infos] == sorted(i.reachable_from_start for i in infos)
    assert all(i.family == family.PRODUCT_FAMILY for i in infos)


def _policy_from_shortest_plans(model):
    policy = np.zeros(model.n_states, dtype=np.int64)
    for state in model.reachable_states():
        plan = model.shortest_plan(state)
        if plan:
            policy[state.index] = model.action_index(plan[0])
    return policy


def _success_by_hand(model, policy, epsilon, max_itr):
    """P(terminal within max_itr steps without an improper action), by a plain Python DP over model.step."""
    probabilities = action_probabilities(policy, epsilon, model.n_actions)
    value = {s: 0.0 for s in model.reachable_states()}
    for _ in range(max_itr):
        updated = {}
        for state in value:
            if state.is_terminal:
                updated[state] = 0.0
                continue
            total = 0.0
            for action in range(model.n_actions):
                nxt, outcome = model.step(state, action)
                if outcome == Outcome.TERMINAL:
                    total += probabilities[state.index, action]
                elif outcome != Outcome.IMPROPER:
                    total += probabilities[state.index, action] * value[nxt]
            updated[state] = total
        value = updated
    return value[model.start_state]


def test_optimal_policy_success_on_paper_equals_independent_dp():
    model = TaskModel(spec="paper")
    _, policy = _optimal(model)
    reachable = [s.index for s in model.reachable_states() if not s.is_terminal]
    by_plans = _policy_from_shortest_plans(model)
    np.testing.assert_array_equal(policy[reachable], by_plans[reachable])
    ours = float(exact_success_probability(policy, PAPER_EPSILON, PAPER_MAX_ITR, model=model))
    expected = _success_by_hand(model, by_plans, PAPER_EPSILON, PAPER_MAX_ITR)
    assert ours == pytest.approx(expected, rel=1e-12)
    assert 0.5 < ours < 1.0


def test_plan_window_scales_with_plan_length():
    assert family.plan_window(8, 8, 1000, 3.0) == (1000, family.BASE_MAX_ITR)
    assert family.plan_window(16, 8, 1000, 3.0) == (8000, 2 * family.BASE_MAX_ITR)


@pytest.mark.parametrize("exponent", [0.5, 1.0, 1.7])
def test_censored_fit_recovers_a_known_exponent(exponent):
    rng = np.random.default_rng(1)
    x = np.geomspace(20, 40_000, 10)
    y = 3.0 * x ** exponent * np.exp(rng.normal(0.0, 0.1, len(x)))
    fit = statistics.fit_censored_power_law(x, y, np.zeros(len(x), bool), np.full(len(x), 0.05))
    assert fit["points"] == len(x) and fit["censored"] == 0
    assert fit["exponent"] == pytest.approx(exponent, abs=0.1)
    assert fit["low"] < exponent < fit["high"]


def test_censored_points_pull_the_exponent_up_instead_of_being_dropped():
    """Dropping the censored (slowest) points flattens the fit; the censored likelihood does not."""
    x = np.geomspace(20, 20_000, 8)
    truth = 5.0 * x ** 1.2
    window = np.full(len(x), 3.0 * 5.0 * 20_000 ** 0.9)  # the largest specs do not get there in time
    censored = truth > window
    assert 2 <= censored.sum() < len(x) - 2
    y = np.where(censored, window, truth)
    se = np.full(len(x), 0.05)
    with_censoring = statistics.fit_censored_power_law(x, y, censored, se)
    dropped = statistics.fit_censored_power_law(x[~censored], y[~censored], censored[~censored], se[~censored])
    naive = statistics.fit_censored_power_law(x, y, np.zeros(len(x), bool), se)  # censored read as reached
    assert with_censoring["censored"] == censored.sum()
    assert with_censoring["exponent"] == pytest.approx(1.2, abs=0.1)
    assert naive["exponent"] < 1.1 and with_censoring["exponent"] > naive["exponent"]
    assert dropped["points"] == (~censored).sum()
    assert math.isnan(statistics.fit_censored_power_law(x[:1], y[:1], [False], [0.1])["exponent"])


def test_a_points_own_uncertainty_weights_the_fit():
    x = np.array([10.0, 100.0, 1000.0, 10_000.0])
    y = np.array([10.0, 100.0, 1000.0, 100.0])  # the last point breaks the line ...
    loose = statistics.fit_censored_power_law(x, y, np.zeros(4, bool), [0.01, 0.01, 0.01, 5.0])
    tight = statistics.fit_censored_power_law(x, y, np.zeros(4, bool), [0.01, 0.01, 0.01, 0.01])
    assert loose["exponent"] == pytest.approx(1.0, abs=0.05)  # ... but it is known only within a factor e**5
    assert tight["exponent"] < 0.8


def test_log_standard_error_reads_the_interval():
    z = 1.959963984540054
    assert statistics.log_standard_error(100.0, 50.0, 200.0) == pytest.approx(math.log(4) / (2 * z))
    assert statistics.log_standard_error(100.0, 50.0, math.inf) == pytest.approx(math.log(2) / z)  # one-sided
    assert math.isnan(statistics.log_standard_error(math.nan, 1.0, 2.0))


def test_the_bootstraps_lower_median_is_the_kaplan_meier_median_of_runs_censored_at_the_budget():
    """The identity the seeds-then-runs bootstrap relies on: with every run censored at the same
    budget, the lower median with censored runs at +inf is the Kaplan-Meier median."""
    from tableclean_suite.learning_time import learning_time_summary

    rng = np.random.default_rng(3)
    budget = 1000
    for runs, censored_share in ((301, 0.3), (40, 0.1), (41, 0.6), (10, 0.0)):
        codes = rng.integers(0, budget + 1, runs)
        codes[rng.random(runs) < censored_share] = -1
        km = learning_time_summary(codes, budget).median
        assert statistics.lower_median(statistics.learning_times(codes)) == km, (runs, censored_share)
    assert statistics.lower_median(statistics.learning_times([5, -1, -1])) == math.inf


def test_the_seeds_then_runs_interval_carries_the_between_seed_spread():
    """Five seeds whose runs agree within each seed but not across: resampling runs alone would give
    a point interval; resampling seeds first spans the seeds' own medians."""
    times = np.repeat(np.array([100.0, 200.0, 300.0, 400.0, 500.0])[:, None], 40, axis=1)
    index = statistics.seeds_then_runs(5, 40, 2000, np.random.default_rng(0))
    medians = statistics.lower_median(statistics.pooled_resamples(times, index))
    low, high = statistics.percentile_bounds(medians)
    assert low <= 200.0 and high >= 400.0
    runs_only = statistics.lower_median(times.ravel()[np.random.default_rng(0).integers(0, 200, (2000, 200))])
    assert np.ptp(runs_only) < high - low
    censored = times.copy()
    censored[3:] = np.inf  # two seeds of five never learn: some resamples' medians are censored
    draws = statistics.lower_median(statistics.pooled_resamples(censored, index))
    assert statistics.percentile_bounds(draws)[1] == math.inf


def test_local_slopes_read_a_bending_curve_and_skip_censored_cells():
    sizes = np.array([10.0, 100.0, 1000.0, 10_000.0])
    medians = np.array([10.0, 100.0, 316.227766, math.inf])  # slope 1, then 0.5, then censored
    replicates = medians[:, None] * np.exp(np.random.default_rng(1).normal(0, 0.05, (4, 500)))
    slopes = statistics.local_slopes(sizes, medians, replicates)
    assert [s["to"] for s in slopes] == [100.0, 1000.0, 10_000.0]
    assert slopes[0]["slope"] == pytest.approx(1.0) and slopes[1]["slope"] == pytest.approx(0.5)
    assert slopes[0]["low"] < 1.0 < slopes[0]["high"] and slopes[1]["high"] < 1.0
    assert math.isnan(slopes[2]["slope"]) and math.isnan(slopes[2]["low"])


def test_order_verdict_separates_holds_ties_and_failures():
    rng = np.random.default_rng(2)
    draws = {name: value * np.exp(rng.normal(0, 0.02, 400)) for name, value in
             (("r4", 100.0), ("r2", 200.0), ("r1", 400.0), ("r3", 800.0))}
    assert statistics.order_verdict(draws) == "holds"
    assert statistics.order_verdict({**draws, "r2": draws["r4"][::-1]}) == "tie"  # r4 = r2 within noise
    assert statistics.order_verdict({**draws, "r3": np.full(400, math.inf)}) == "holds"  # censored is slowest
    assert statistics.order_verdict({**draws, "r4": draws["r1"]}) == "fails"
    assert statistics.order_verdict({"r4": draws["r4"]}) is None


def _fit_rows(times, censored, sizes=(20, 50, 90, 327, 1158)):
    return [{"learner": "q_learning", "reward": "r1", "gamma": 0.9, "family": family.PRODUCT_FAMILY, "spec": f"s{k}",
             "reachable_from_start": size, "window": 20_000, "censored": cut,
             "learning_time": math.inf if cut else value, "learning_time_low": value * 0.9,
             "learning_time_high": value * 1.1} for k, (size, value, cut) in enumerate(zip(sizes, times, censored))]


def test_the_studys_fit_takes_a_censored_cell_as_a_lower_bound_and_gives_no_exponent_when_most_are_censored():
    """The study's own fit (pipeline.growth_fits) with a censored cell: the cell enters at its window
    as a right-censored point, which steepens the fit against dropping it; with most cells censored
    there is no exponent."""
    from tableclean_suite.bench.scaling import pipeline

    sizes = np.array([20, 50, 90, 327, 1158])
    truth = 30.0 * sizes ** 1.0  # the last cell's 34 740 iterations lie beyond its 20 000 window
    censored = [False, False, False, False, True]
    fit = pipeline.growth_fits(_fit_rows(truth, censored), "q_learning", ["r1"], [0.9])["0.9"]["r1"]
    dropped = pipeline.growth_fits(_fit_rows(truth[:4], censored[:4], sizes[:4]), "q_learning", ["r1"],
                                   [0.9])["0.9"]["r1"]
    assert fit["censored"] == 1 and fit["points"] == 5 and dropped["censored"] == 0
    assert fit["exponent"] == pytest.approx(1.0, abs=0.05) and fit["low"] < 1.0 < fit["high"]
    as_reached = statistics.fit_censored_power_law(sizes, np.r_[truth[:4], 20_000], np.zeros(5, bool), [0.05] * 5)
    assert as_reached["exponent"] < fit["exponent"] - 0.05  # reading the window as the time flattens the fit
    mostly = pipeline.growth_fits(_fit_rows(truth, [False, False, True, True, True]), "q_learning", ["r1"],
                                  [0.9])["0.9"]["r1"]
    assert math.isnan(mostly["exponent"]) and mostly["censored"] == 3


def test_train_cell_keeps_every_seeds_learning_times_and_window_sums():
    import curve_oracle
    from tableclean_suite.learners import train

    model = TaskModel(spec="paper")
    info = family.describe_spec(model.spec, 8, 400, 1.0)[0]
    records = study.train_cell(model, info, "q_learning", "r4", runs=5, seeds=(3, 4), gamma=0.3)
    assert records.learned_at.shape == (2, 5) and records.seeds == (3, 4)
    for row, seed in enumerate((3, 4)):
        result = train(reward="r4", runs=5, iterations=info.window, max_itr=info.max_itr, seed=seed, task=model)
        np.testing.assert_array_equal(records.learned_at[row], result.learned_at)
        success = curve_oracle.success_matrix(result)
        tail = metrics.plateau_start(info.window)
        np.testing.assert_allclose(records.tail_success[row], success[:, tail:].mean(axis=1))
        reached = (result.outcomes == int(Outcome.TERMINAL)).any(axis=1)
        np.testing.assert_array_equal(records.never_terminal[row], (~reached).astype(float))
    assert not np.array_equal(records.learned_at[0], records.learned_at[1])  # two seeds, two sets of runs


def test_cell_row_pools_the_seeds_and_its_interval_holds_the_seeds_spread():
    model = TaskModel(spec="paper")
    info = family.describe_spec(model.spec, 8, 1500, 1.0)[0]
    records = study.train_cell(model, info, "q_learning", "r2", runs=10, seeds=(0, 1, 2), gamma=0.3)
    row, medians = study.cell_row(info, "q_learning", "r2", 0.3, records, 300, np.random.default_rng(0))
    assert medians.shape == (300,) and row["seeds"] == 3 and row["runs"] == 10
    from tableclean_suite.learning_time import learning_time_summary

    pooled = learning_time_summary(records.learned_at.ravel(), info.window)
    assert row["learning_time"] == pooled.median and row["censored_share"] == pooled.censored_share
    for name in INTERVAL_FIGURES:
        assert row[name + "_low"] <= row[name] <= row[name + "_high"], name
    seed_medians = [float(v) for v in row["seed_medians"].split(";")]
    assert seed_medians == list(statistics.lower_median(statistics.learning_times(records.learned_at)))
    again, _ = study.cell_row(info, "q_learning", "r2", 0.3, records, 300, np.random.default_rng(0))
    assert again == row  # deterministic


def test_cli_tiny_budget_writes_consistent_files(tmp_path, capsys):
    assert scaling.main(TINY_ARGS + ["--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert max(map(len, printed.splitlines())) <= 120
    for name in ("scaling.csv", "scaling_specs.csv", "scaling_slopes.csv", "scaling.png", "config.json"):
        assert (tmp_path / name).stat().st_size > 0
    assert not list(tmp_path.glob("*.tmp"))
    cells = pd.read_csv(tmp_path / "scaling.csv")
    specs = pd.read_csv(tmp_path / "scaling_specs.csv")
    slopes = pd.read_csv(tmp_path / "scaling_slopes.csv")
    config = json.loads((tmp_path / "config.json").read_text())
    assert len(specs) == 2 * 2 + 2 and len(cells) == len(specs) * 2 * 1 * 2  # specs x gammas x learners x rewards
    product = specs[specs["family"] == family.PRODUCT_FAMILY]
    assert list(product["reachable_from_start"]) == sorted(product["reachable_from_start"])
    assert product["reachable"].iloc[0] == PAPER_REACHABLE
    assert set(zip(product["segments"], product["objects"])) == {(2, 1), (2, 2), (3, 1), (3, 2)}
    fixed = specs[specs["family"] == family.FIXED_PLAN_FAMILY]
    assert set(fixed["plan_length"]) == {8} and fixed["reachable_from_start"].is_monotonic_increasing
    assert set(cells["spec"]) == set(specs["name"]) and set(cells["reward"]) == {"r2", "r4"}
    assert set(cells["gamma"]) == {0.3, 0.9} and set(cells["seeds"]) == {2} and set(cells["runs"]) == {4}
    for column in INTERVAL_FIGURES:
        assert {f"{column}_low", f"{column}_high"} <= set(cells.columns)
        defined = np.isfinite(cells[column])
        assert (cells.loc[defined, f"{column}_low"] <= cells.loc[defined, column]).all()
        assert (cells.loc[defined, column] <= cells.loc[defined, f"{column}_high"]).all()
    reached = cells[~cells["censored"]]
    assert (reached["learning_time"] <= reached["window"]).all()
    assert (cells.loc[cells["censored"], "censored_share"] > 0.5).all()
    assert (cells["seed_medians"].str.count(";") == 1).all()
    # slopes along chains: N = 2 -> 3 at M = 1 and at M = 2 in the product family, M = 1 -> 2 in the fixed plan
    assert len(slopes) == 2 * 2 * (2 + 1) and set(slopes["family"]) == {family.PRODUCT_FAMILY, family.FIXED_PLAN_FAMILY}
    assert set(slopes["chain"]) == {"M=1", "M=2", "N=3"}
    paper_to_n3 = slopes[(slopes["chain"] == "M=1")].iloc[0]
    assert (paper_to_n3["from"], paper_to_n3["to"]) == (20, 90)
    assert config["runs"] == 4 and config["seeds"] == 2 and config["segments"] == [2, 3] and config["objects"] == [1, 2]
    assert config["gammas"] == [0.3, 0.9] and config["fixed_plan_objects"] == [1, 2]
    assert [s["name"] for s in config["specs"]] == list(specs["name"])
    assert set(config["growth_exponents"]) == {family.PRODUCT_FAMILY, family.FIXED_PLAN_FAMILY}
    product_fits = config["growth_exponents"][family.PRODUCT_FAMILY]
    assert set(product_fits) == {"0.3", "0.9"} and set(product_fits["0.3"]) == {"r2", "r4"}
    assert "r4 < r2 < r1 < r3" in printed and "local slopes" in printed
    capsys.readouterr()
    assert scaling.main(TINY_ARGS + ["--out", str(tmp_path / "again")]) == 0
    assert (tmp_path / "again" / "scaling.csv").read_text().count("\n") == len(cells) + 1
    again = pd.read_csv(tmp_path / "again" / "scaling.csv").drop(columns="seconds")
    pd.testing.assert_frame_equal(again, cells.drop(columns="seconds"))  # same seed, same numbers


@pytest.mark.parametrize("flag", [["--rewards", "r9"], ["--learners", "td_lambda"], ["--runs", "0"],
                                  ["--segments", "1,2"], ["--objects", "0,1"], ["--objects", "two"],
                                  ["--gammas", "0"], ["--gammas", "0.3,1.5"], ["--fixed-plan-objects", "0"],
                                  ["--seeds", "1"], ["--seeds", "many"]])
def test_cli_bad_flag_exits_2_with_one_line(flag, tmp_path, capsys):
    with pytest.raises(SystemExit) as stop:
        scaling.main(flag + ["--out", str(tmp_path)])
    assert stop.value.code == cli.EXIT_USAGE
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "error" in error
    if flag[0] in ("--rewards", "--learners"):
        assert "allowed:" in error


def test_observed_order_sorts_joins_ties_and_names_censored_patterns():
    rows = [{"spec": "a", "learner": "q_learning", "reward": name, "gamma": 0.3, "learning_time": value}
            for name, value in (("r1", 30.0), ("r2", 10.0), ("r3", math.inf), ("r4", 10.0))]
    assert report.observed_order(rows, "a", "q_learning", 0.3) == "r2 (10) = r4 (10) < r1 (30) (censored: r3)"


@pytest.mark.parametrize(("text", "expected"), [("2", (2,)), ("3,1,3", (1, 3)), ("1, 2,3", (1, 2, 3))])
def test_objects_flag_takes_one_count_or_a_list(text, expected):
    args = command.build_parser().parse_args(["--objects", text])
    assert args.objects == expected
    assert command.build_parser().parse_args([]).objects == family.DEFAULT_OBJECT_COUNTS


def test_figure_draws_reached_and_censored_cells(tmp_path):
    rows = [{"learner": "q_learning", "reward": "r2", "gamma": g, "family": fam, "reachable_from_start": reach,
             "censored": censored, "window": 1000, "learning_time": math.inf if censored else it,
             "learning_time_low": it * 0.9, "learning_time_high": math.inf if reach > 90 else it * 1.1,
             "censored_share": 0.7 if censored else 0.1}
            for g in (0.3, 0.9) for fam, reach, it, censored in
            ((family.PRODUCT_FAMILY, 20, 200.0, False), (family.PRODUCT_FAMILY, 50, 400.0, False),
             (family.PRODUCT_FAMILY, 327, 900.0, True), (family.FIXED_PLAN_FAMILY, 40, 300.0, False))]
    fit = {"exponent": 0.8, "intercept": 1.0}
    report.write_figure(tmp_path / "f.png", rows, "q_learning", {"0.3": {"r2": fit}, "0.9": {"r2": fit}})
    assert (tmp_path / "f.png").stat().st_size > 0


def test_a_study_into_a_folder_another_run_holds_exits_2_before_training(tmp_path, capsys):
    import fcntl

    from tableclean_suite.bench import commands

    other = os.open(tmp_path, os.O_RDONLY)  # another writer's hold (its own open file description)
    fcntl.flock(other, fcntl.LOCK_EX)
    try:
        code = commands.main(["scaling", *TINY_ARGS, "--out", str(tmp_path)])
    finally:
        os.close(other)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "in use by another run" in err[0], err
    assert not (tmp_path / "scaling.csv").exists()


def test_the_fit_stays_finite_and_silent_where_the_search_strays():
    import warnings

    args = (np.log([20.0, 90.0, 327.0]), np.log([200.0, 900.0, 4000.0]), np.zeros(3), np.zeros(3, dtype=bool))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's "overflow encountered in exp" was printed here
        assert math.isfinite(statistics._negative_log_likelihood([0.0, 1.0, 800.0], *args))


def test_the_printed_cell_table_fits_in_120_columns_and_keeps_columns_apart(capsys):
    row = {"spec": "fixed_plan_m5_long_name", "gamma": 0.9, "learner": "double_q_learning", "reward": "r4_cycle",
           "learning_time": 123456.0, "learning_time_low": 100000.0, "learning_time_high": math.inf,
           "censored_share": 0.5, "success_window_mean": 0.5, "success_window_mean_low": 0.25,
           "success_window_mean_high": 0.75, "optimal_success": 0.87, "never_terminal_share": 0.1}
    report.print_cells([row, {**row, "learner": "q"}])
    lines = capsys.readouterr().out.splitlines()
    assert max(map(len, lines)) <= 120
    assert "double_q_learning r4_cycle" in lines[1]
