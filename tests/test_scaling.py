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
             "--learners", "q_learning", "--rewards", "r2,r4"]
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
    assert [(i.segments, i.objects) for i in infos] == [(2, 1), (2, 2), (3, 1), (3, 2)]
    assert [i.reachable for i in infos] == sorted(i.reachable for i in infos)


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
def test_growth_exponent_fit_recovers_a_known_exponent(exponent):
    rng = np.random.default_rng(1)
    x = np.geomspace(20, 40_000, 8)
    y = 3.0 * x ** exponent * np.exp(rng.normal(0.0, 0.05, len(x)))
    fit = statistics.fit_growth_exponent(x, y)
    assert fit["points"] == len(x)
    assert fit["exponent"] == pytest.approx(exponent, abs=0.05)
    assert fit["low"] < exponent < fit["high"]


def test_growth_exponent_fit_skips_missing_points():
    x = np.array([10.0, 100.0, 1000.0, 10_000.0])
    y = np.array([5.0, math.nan, 500.0, 5000.0])
    fit = statistics.fit_growth_exponent(x, y)
    assert fit["points"] == 3
    assert fit["exponent"] == pytest.approx(1.0)
    assert math.isnan(statistics.fit_growth_exponent(x[:1], y[:1])["exponent"])


def test_plateau_verdict_flags_a_rising_curve():
    rising = np.linspace(0.0, 0.8, 1000)
    flat = np.r_[np.linspace(0.0, 0.8, 500), np.full(500, 0.8)]
    assert statistics.plateau_verdict(rising)[0] is False
    assert statistics.plateau_verdict(flat) == (True, "")
    assert statistics.plateau_verdict(np.zeros(100))[0] is False


def test_order_holds():
    assert statistics.order_holds({"r4": 1, "r2": 2, "r1": 3, "r3": 4}) is True
    assert statistics.order_holds({"r4": 3, "r2": 2, "r1": 3, "r3": 4}) is False
    assert statistics.order_holds({"r4": 1, "r2": math.nan, "r1": 3, "r3": 4}) is None


def test_grid_curves_match_metrics_success_matrix():
    from tableclean_suite import metrics
    from tableclean_suite.learners import train

    model = TaskModel(spec="paper")
    info = family.describe_spec(model.spec, 8, 400, 1.0)[0]
    records = study.train_cell(model, info, "q_learning", "r4", runs=5, seed=3)
    result = train(reward="r4", runs=5, iterations=info.window, max_itr=info.max_itr, seed=3, task=model)
    success = metrics.success_matrix(result)[:, records.grid]
    episodes = np.cumsum(result.episode_end != 0, axis=1)[:, records.grid]
    np.testing.assert_array_equal(records.success, success)
    np.testing.assert_array_equal(records.episodes, episodes)
    np.testing.assert_allclose(records.summary.success, metrics.learning_curves(result)["success"])


def test_cli_tiny_budget_writes_consistent_files(tmp_path, capsys):
    assert scaling.main(TINY_ARGS + ["--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    for name in ("scaling.csv", "scaling_specs.csv", "scaling.png", "config.json"):
        assert (tmp_path / name).stat().st_size > 0
    assert not list(tmp_path.glob("*.tmp"))
    cells = pd.read_csv(tmp_path / "scaling.csv")
    specs = pd.read_csv(tmp_path / "scaling_specs.csv")
    config = json.loads((tmp_path / "config.json").read_text())
    assert len(cells) == len(specs) * 1 * 2 and len(specs) == 2 * 2
    assert list(specs["reachable"]) == sorted(specs["reachable"]) and specs["reachable"].iloc[0] == PAPER_REACHABLE
    assert set(zip(specs["segments"], specs["objects"])) == {(2, 1), (2, 2), (3, 1), (3, 2)}
    assert set(cells["spec"]) == set(specs["name"]) and set(cells["reward"]) == {"r2", "r4"}
    for column in ("max_success_iterations", "max_success_episodes", "success_plateau"):
        assert {f"{column}_low", f"{column}_high"} <= set(cells.columns)
    reached = cells[cells["reached"]]
    assert (reached["max_success_iterations"] <= reached["window"]).all()
    assert cells.loc[~cells["reached"], "max_success_iterations"].isna().all()
    assert config["runs"] == 4 and config["segments"] == [2, 3] and config["objects"] == [1, 2]
    assert [s["reachable"] for s in config["specs"]] == list(specs["reachable"])
    assert set(config["growth_exponents"]) == {"r2", "r4"}
    assert "Does r4 < r2 < r1 < r3 hold" in printed


@pytest.mark.parametrize("flag", [["--rewards", "r9"], ["--learners", "td_lambda"], ["--runs", "0"],
                                  ["--segments", "1,2"], ["--objects", "0,1"], ["--objects", "two"]])
def test_cli_bad_flag_exits_2_with_one_line(flag, tmp_path, capsys):
    with pytest.raises(SystemExit) as stop:
        scaling.main(flag + ["--out", str(tmp_path)])
    assert stop.value.code == scaling.EXIT_USAGE
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "error" in error
    if flag[0] in ("--rewards", "--learners"):
        assert "allowed:" in error


def test_grid_is_increasing_and_dense_early():
    grid = study.grid_indices(100_000)
    assert grid[0] == 0 and grid[-1] == 100_000 - 1
    assert np.all(np.diff(grid) > 0)
    assert study.grid_gap(grid, 1000.0) < 0.01 * 1000


def test_run_plateaus_average_to_the_summary_plateau():
    model = TaskModel(spec="paper")
    info = family.describe_spec(model.spec, 8, 400, 1.0)[0]
    records = study.train_cell(model, info, "q_learning", "r2", runs=6, seed=5)
    assert records.run_plateau.mean() == pytest.approx(records.summary.success_plateau, rel=1e-12)
    counts = statistics.resample_counts(6, 50, seed=0)
    interval = statistics.bootstrap_cell(records, counts)
    low, high = interval["plateau"]
    assert records.run_plateau.min() <= low <= high <= records.run_plateau.max()


def test_observed_order_sorts_and_names_missing_patterns():
    rows = [{"spec": "a", "learner": "q_learning", "reward": name, "max_success_iterations": value}
            for name, value in (("r1", 30.0), ("r2", 10.0), ("r3", math.nan), ("r4", 20.0))]
    assert report.observed_order(rows, "a", "q_learning") == "r2 < r4 < r1 (not reached: r3)"


@pytest.mark.parametrize(("text", "expected"), [("2", (2,)), ("3,1,3", (1, 3)), ("1, 2,3", (1, 2, 3))])
def test_objects_flag_takes_one_count_or_a_list(text, expected):
    args = command.build_parser().parse_args(["--objects", text])
    assert args.objects == expected
    assert command.build_parser().parse_args([]).objects == family.DEFAULT_OBJECT_COUNTS


def test_figure_marks_object_counts(tmp_path):
    rows = [{"learner": "q_learning", "reward": "r2", "reached": True, "reachable": reach, "segments": n,
             "objects": m, "max_success_iterations": it, "max_success_iterations_low": it * 0.9,
             "max_success_iterations_high": it * 1.1} for n, m, reach, it in
            ((2, 1, 20, 200.0), (2, 2, 50, 400.0), (3, 1, 90, 500.0), (3, 2, 327, 900.0))]
    fit = statistics.fit_growth_exponent([r["reachable"] for r in rows], [r["max_success_iterations"] for r in rows])
    report.write_figure(tmp_path / "f.png", rows, "q_learning", {"r2": fit})
    assert (tmp_path / "f.png").stat().st_size > 0
    assert report.object_marker(1) != report.object_marker(2) != report.object_marker(3)
