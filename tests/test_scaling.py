"""The scaling study (:mod:`tableclean_suite.bench.scaling`): its specs, exact quantities, fit and CLI."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from tableclean_suite.analysis import action_probabilities, exact_success_probability
from tableclean_suite.bench import scaling
from tableclean_suite.bench.scaling import command, family, report, statistics, study
from tableclean_suite.task import Outcome, TaskModel

#: A tiny study: 2 x 2 specs (20, 50, 90 and 327 reachable states), short windows, few runs and resamples.
TINY_ARGS = ["--segments", "3,2", "--objects", "2,1", "--runs", "4", "--base-window", "300", "--resamples", "20",
             "--fixed-plan-objects", "1,2", "--learners", "q_learning", "--rewards", "r2,r4"]
#: The paper's reachable states (from every all-unclean layout).
PAPER_REACHABLE = 20
PAPER_EPSILON, PAPER_MAX_ITR = 0.1, 500


def _optimal(model):
    next_state, _ = model.transition_arrays()
    distance = family.distances_to_terminal(next_state, family.terminal_codes(model))
    return distance, family.optimal_policy(next_state, distance)


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
    largest = family.largest_default_spec()
    assert (largest.segments, largest.n_objects) == (max(ISSUE_SEGMENTS), max(ISSUE_OBJECTS))
    assert reachable[largest.name] == max(reachable.values()) >= ISSUE_MIN_LARGEST_REACHABLE
    # the name other modules use for the largest spec (bench.spec_speed) still builds it
    assert family.family_spec(max(family.DEFAULT_SEGMENTS), max(family.DEFAULT_OBJECT_COUNTS)) == largest


def test_describe_family_orders_specs_by_reachable_states():
    specs = family.family_specs((3, 2), (2, 1))
    assert [(s.segments, s.n_objects) for s in specs] == [(3, 2), (3, 1), (2, 2), (2, 1)]
    infos = [info for info, _ in family.describe_family(specs, 8, 100, 1.0)]
    assert [(i.segments, i.objects) for i in infos][0] == (2, 1) and len(infos) == 4
    assert [i.reachable_from_start for i in infos] == sorted(i.reachable_from_start for i in infos)
    assert all(i.family == family.PRODUCT_FAMILY for i in infos)


@pytest.mark.parametrize(("segments", "objects"), [(2, 1), (3, 1), (4, 1), (2, 2), (3, 3)])
def test_distances_match_the_models_shortest_plans(segments, objects):
    model = TaskModel(spec=family.family_spec(segments, objects))
    distance, _ = _optimal(model)
    lengths = model.shortest_plan_lengths()
    assert {code: int(distance[code]) for code in lengths} == lengths


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


def test_held_to_end_and_censoring():
    curves = np.array([[0.1, 0.9, 0.5, 0.9, 0.95, 0.9],   # dips at block 2: held from block 3
                       [0.1, 0.9, 0.9, 0.9, 0.9, 0.5],    # ends below: censored
                       [0.9, 0.9, 0.9, 0.9, 0.9, 0.9]])   # held from the start
    np.testing.assert_array_equal(statistics.held_to_end(curves, 0.8), [3, -1, 0])
    np.testing.assert_array_equal(statistics.held_to_end(curves, [0.8, 0.4, 0.95]), [3, 1, -1])


def test_order_holds():
    assert statistics.order_holds({"r4": 1, "r2": 2, "r1": 3, "r3": 4}) is True
    assert statistics.order_holds({"r4": 3, "r2": 2, "r1": 3, "r3": 4}) is False
    assert statistics.order_holds({"r4": 1, "r2": 2, "r1": 3, "r3": math.inf}) is True  # censored sorts last
    assert statistics.order_holds({"r4": 1, "r2": math.nan, "r1": 3, "r3": 4}) is None


def test_block_sums_match_the_success_matrix():
    from tableclean_suite import metrics
    from tableclean_suite.learners import train

    model = TaskModel(spec="paper")
    info = family.describe_spec(model.spec, 8, 400, 1.0)[0]
    records = study.train_cell(model, info, "q_learning", "r4", runs=5, seed=3, gamma=0.3)
    result = train(reward="r4", runs=5, iterations=info.window, max_itr=info.max_itr, seed=3, task=model)
    success = metrics.success_matrix(result)
    starts = np.r_[0, records.edges[:-1] + 1]
    np.testing.assert_array_equal(records.block_success, np.add.reduceat(success, starts, axis=1))
    np.testing.assert_array_equal(records.episodes, np.cumsum(result.episode_end != 0, axis=1)[:, records.edges])
    tail = study.plateau_start(info.window)
    np.testing.assert_allclose(records.tail_success, success[:, tail:].mean(axis=1))
    reached = (result.outcomes == int(Outcome.TERMINAL)).any(axis=1)
    np.testing.assert_array_equal(records.never_terminal, (~reached).astype(float))
    assert records.tail_success.mean() == pytest.approx(
        metrics.plateau(metrics.success_curve(result), metrics.DEFAULT_PLATEAU_FRACTION), rel=1e-12)


def test_the_point_is_the_all_ones_resample_and_inside_its_interval():
    model = TaskModel(spec="paper")
    info = family.describe_spec(model.spec, 8, 1500, 1.0)[0]
    records = study.train_cell(model, info, "q_learning", "r2", runs=30, seed=5, gamma=0.3)
    counts = statistics.resample_counts(30, 200, seed=0)
    row = study.cell_row(info, "q_learning", "r2", 0.3, records, counts)
    assert not row["censored"]
    figures = statistics.cell_figures(np.ones((1, 30)), records.block_success, statistics.block_widths(records.edges),
                                      records.edges, records.episodes, records.tail_success, records.never_terminal,
                                      row["yardstick_level"])
    assert row["yardstick_iterations"] == figures["yardstick_iterations"][0]
    for name in study.INTERVAL_FIGURES:
        assert row[name + "_low"] <= row[name] <= row[name + "_high"], name
    np.testing.assert_array_equal(statistics.resample_counts(30, 200, seed=0),
                                  np.random.default_rng(0).multinomial(30, np.full(30, 1 / 30), size=200))


def test_cli_tiny_budget_writes_consistent_files(tmp_path, capsys):
    assert scaling.main(TINY_ARGS + ["--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    for name in ("scaling.csv", "scaling_specs.csv", "scaling.png", "config.json"):
        assert (tmp_path / name).stat().st_size > 0
    assert not list(tmp_path.glob("*.tmp"))
    cells = pd.read_csv(tmp_path / "scaling.csv")
    specs = pd.read_csv(tmp_path / "scaling_specs.csv")
    config = json.loads((tmp_path / "config.json").read_text())
    assert len(specs) == 2 * 2 + 2 and len(cells) == len(specs) * 2 * 1 * 2  # specs x gammas x learners x rewards
    product = specs[specs["family"] == family.PRODUCT_FAMILY]
    assert list(product["reachable_from_start"]) == sorted(product["reachable_from_start"])
    assert product["reachable"].iloc[0] == PAPER_REACHABLE
    assert set(zip(product["segments"], product["objects"])) == {(2, 1), (2, 2), (3, 1), (3, 2)}
    fixed = specs[specs["family"] == family.FIXED_PLAN_FAMILY]
    assert set(fixed["plan_length"]) == {8} and fixed["reachable_from_start"].is_monotonic_increasing
    assert set(cells["spec"]) == set(specs["name"]) and set(cells["reward"]) == {"r2", "r4"}
    assert set(cells["gamma"]) == {0.3, 0.9}
    for column in study.INTERVAL_FIGURES:
        assert {f"{column}_low", f"{column}_high"} <= set(cells.columns)
        defined = cells[column].notna()
        assert (cells.loc[defined, f"{column}_low"] <= cells.loc[defined, column]).all()
        assert (cells.loc[defined, column] <= cells.loc[defined, f"{column}_high"]).all()
    reached = cells[~cells["censored"]]
    assert (reached["yardstick_iterations"] <= reached["window"]).all()
    assert cells.loc[cells["censored"], "yardstick_iterations"].isna().all()
    assert (cells["yardstick_level"] == 0.9 * cells["optimal_success"]).all()
    assert config["runs"] == 4 and config["segments"] == [2, 3] and config["objects"] == [1, 2]
    assert config["gammas"] == [0.3, 0.9] and config["fixed_plan_objects"] == [1, 2]
    assert [s["name"] for s in config["specs"]] == list(specs["name"])
    assert set(config["growth_exponents"]) == {family.PRODUCT_FAMILY, family.FIXED_PLAN_FAMILY}
    product_fits = config["growth_exponents"][family.PRODUCT_FAMILY]
    assert set(product_fits) == {"0.3", "0.9"} and set(product_fits["0.3"]) == {"r2", "r4"}
    assert "Does r4 < r2 < r1 < r3 hold" in printed


@pytest.mark.parametrize("flag", [["--rewards", "r9"], ["--learners", "td_lambda"], ["--runs", "0"],
                                  ["--segments", "1,2"], ["--objects", "0,1"], ["--objects", "two"],
                                  ["--gammas", "0"], ["--gammas", "0.3,1.5"], ["--fixed-plan-objects", "0"]])
def test_cli_bad_flag_exits_2_with_one_line(flag, tmp_path, capsys):
    with pytest.raises(SystemExit) as stop:
        scaling.main(flag + ["--out", str(tmp_path)])
    assert stop.value.code == scaling.EXIT_USAGE
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "error" in error
    if flag[0] in ("--rewards", "--learners"):
        assert "allowed:" in error


def test_blocks_are_increasing_end_at_the_window_and_are_fine_early():
    edges = statistics.block_edges(100_000)
    assert edges[-1] == 100_000 - 1 and np.all(np.diff(edges) > 0)
    widths = statistics.block_widths(edges)
    assert widths.sum() == 100_000 and widths[:20].max() <= 2 and widths.max() <= 100_000 / statistics.LINEAR_BLOCKS


def test_observed_order_sorts_and_names_missing_patterns():
    rows = [{"spec": "a", "learner": "q_learning", "reward": name, "gamma": 0.3, "yardstick_iterations": value}
            for name, value in (("r1", 30.0), ("r2", 10.0), ("r3", math.nan), ("r4", 20.0))]
    assert report.observed_order(rows, "a", "q_learning", 0.3) == "r2 < r4 < r1 (censored: r3)"


@pytest.mark.parametrize(("text", "expected"), [("2", (2,)), ("3,1,3", (1, 3)), ("1, 2,3", (1, 2, 3))])
def test_objects_flag_takes_one_count_or_a_list(text, expected):
    args = command.build_parser().parse_args(["--objects", text])
    assert args.objects == expected
    assert command.build_parser().parse_args([]).objects == family.DEFAULT_OBJECT_COUNTS


def test_figure_draws_reached_and_censored_cells(tmp_path):
    rows = [{"learner": "q_learning", "reward": "r2", "gamma": g, "family": fam, "reachable_from_start": reach,
             "censored": censored, "window": 1000, "yardstick_iterations": math.nan if censored else it,
             "yardstick_iterations_low": it * 0.9, "yardstick_iterations_high": math.inf if reach > 90 else it * 1.1,
             "window_mean_over_optimum": 0.95}
            for g in (0.3, 0.9) for fam, reach, it, censored in
            ((family.PRODUCT_FAMILY, 20, 200.0, False), (family.PRODUCT_FAMILY, 50, 400.0, False),
             (family.PRODUCT_FAMILY, 327, 900.0, True), (family.FIXED_PLAN_FAMILY, 40, 300.0, False))]
    fit = {"exponent": 0.8, "intercept": 1.0}
    report.write_figure(tmp_path / "f.png", rows, "q_learning", {"0.3": {"r2": fit}, "0.9": {"r2": fit}})
    assert (tmp_path / "f.png").stat().st_size > 0


def test_a_study_into_a_folder_another_run_holds_exits_2_before_training(tmp_path, capsys):
    import filelock

    from tableclean_suite.bench import commands, outputs

    other = filelock.FileLock(str(tmp_path / outputs.LOCK_FILE))  # another writer's hold (its own open file)
    with other:
        code = commands.main(["scaling", *TINY_ARGS, "--out", str(tmp_path)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "in use by another run" in err[0], err
    assert not (tmp_path / "scaling.csv").exists()
