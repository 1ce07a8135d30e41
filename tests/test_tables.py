"""Table builders, the quoted paper values, and the cell grid/store, on tiny hand-made inputs."""

import math
import re

import numpy as np
import pandas as pd
import pytest

from tableclean_suite import metrics
from tableclean_suite.bench import digests, experiments, tables
from tableclean_suite.bench.config import RunConfig
from tableclean_suite.learners import code_digest, get_learner
from tableclean_suite.metrics import CURVE_NAMES, SUMMARY_SCALARS, Summary
from tableclean_suite.settling import Settling
from tableclean_suite.task import TaskModel


def record(experiment="main", learner="q_learning", reward="r1", alpha=0.3, gamma=0.3, **scalars):
    base = {
        "max_success_iterations": 100,
        "max_success_episodes": 5.5,
        "reward_convergence_iterations": 120,
        "reward_convergence_episodes": 6.25,
        "success_plateau": 0.875,
        "max_average_reward": 0.25,
        "average_reward_plateau": 0.2,
        "terminal_plateau": 0.9,
        **dict.fromkeys(("success_window_mean", "average_reward_window_mean", "held_success_iterations",
                         "held_success_episodes", "greedy_success_plateau", "never_terminal_share")),
    }
    base.update(scalars)
    cell = experiments.Cell(learner, reward, alpha, gamma)
    return {"cell_id": cell.label, "learner": learner, "reward": reward, "alpha": alpha, "gamma": gamma,
            "experiment": experiment, **base}


# ---------------------------------------------------------------------------
# Table 3
# ---------------------------------------------------------------------------
def test_table3_columns_order_and_paper_values():
    records = [
        record("alpha_sweep", reward="r4", alpha=0.5, max_success_iterations=None, max_success_episodes=None),
        record("main", learner="sarsa", reward="r2"),
        record("main", reward="r4", success_plateau=0.5),
        record("main", reward="r1"),
    ]
    t3 = tables.table3(records)
    assert list(t3.columns) == list(tables.TABLE3_COLUMNS)
    assert list(zip(t3["experiment"], t3["learner"], t3["reward"])) == [
        ("main", "q_learning", "r1"),
        ("main", "q_learning", "r4"),
        ("main", "sarsa", "r2"),
        ("alpha_sweep", "q_learning", "r4"),
    ]
    r1, r4, sarsa, sweep = (t3.iloc[i] for i in range(4))
    assert (r1["paper_reward_convergence_iterations"], r1["paper_reward_convergence_episodes"]) == (680, 31)
    assert (r1["paper_max_success_iterations"], r1["paper_max_success_episodes"]) == (630, 25)
    assert r1["paper_success_rate"] == pytest.approx(0.8394)
    assert (r4["paper_max_success_iterations"], r4["paper_success_rate"]) == (140, 0.8477)
    assert r4["success_plateau"] == 0.5 and r1["success_plateau"] == 0.875
    for row in (sarsa, sweep):  # the paper's numbers are Q-learning main rows only
        assert all(math.isnan(row[c]) for c in tables.PAPER_COLUMNS)
    assert sweep["max_success_iterations"] is pd.NA and math.isnan(sweep["max_success_episodes"])
    assert sweep["alpha"] == 0.5 and sweep["cell_id"] == "q_learning-r4-a0.5-g0.3"
    assert str(t3["max_success_iterations"].dtype) == "Int64"


def test_table3_rejects_records_without_scalars():
    bad = record()
    del bad["success_plateau"]
    with pytest.raises(ValueError, match="success_plateau"):
        tables.table3([bad])


def test_table4_ours_then_quoted():
    t3 = tables.table3([record("main", reward="r2", success_plateau=0.8125, reward_convergence_episodes=12.5,
                               max_success_episodes=7.0),
                        record("main", learner="sarsa", reward="r2"),
                        record("gamma_sweep", reward="r4", gamma=0.9)])
    t4 = tables.table4(t3)
    assert list(t4.columns) == list(tables.TABLE4_COLUMNS)
    assert len(t4) == 1 + 8
    ours = t4.iloc[0]
    assert ours["methodology"] == "This run: Q-learning with reward r2"
    assert ours["source"] == "this run"
    assert ours["max_success_rate_percent"] == 81.25
    assert ours["average_reward_convergence_episodes"] == 12.5 and ours["max_success_episodes"] == 7.0
    assert (t4["source"].iloc[1:] == "quoted from the paper").all()
    assert "average_reward_convergence_episodes_low" not in t4.columns  # a mean-curve reading: no interval
    shown = tables.display_table4(t4)
    assert list(shown["source"].iloc[:2]) == ["run here", "quoted"]
    assert shown.iloc[2]["conv. eps"] == "-"  # Classic RL [7] gives none
    assert shown.iloc[0]["method"] == "Q-learning, r2"


def test_display_tables_label_the_papers_definitions_and_fit_the_terminal():
    learning = {"learning_time_median": 803.0, "learning_time_median_low": 780.0, "learning_time_median_high": 830.0,
                "learning_time_q1": 600.0, "learning_time_q3": math.inf, "learning_time_rmst": 1200.5,
                "learning_time_rmst_low": 1150.0, "learning_time_rmst_high": 1250.0, "censored_share": 0.3,
                "censored_share_low": 0.25, "censored_share_high": 0.35}
    t3 = tables.table3([record("main", reward="r3", reward_convergence_iterations=None, success_plateau_low=0.8,
                               success_plateau_high=0.9, **learning),
                        record("main", learner="sarsa", reward="r3")])
    headline = tables.display_learning_time(t3).loc[("q_learning", "r3")]
    assert headline["median [CI]"] == "803 [780, 830]" and headline["quartiles"] == "600-inf"
    assert headline["RMST [CI]"] == "1200 [1150, 1250]" and headline["censored % [CI]"] == "30.0 [25.0, 35.0]"
    assert tables.display_learning_time(t3).loc[("sarsa", "r3")]["median [CI]"] == "-"  # not recorded
    plateaus = tables.display_plateaus(t3).loc[("q_learning", "r3")]
    assert (plateaus["success % [CI]"], plateaus["paper"]) == ("87.50 [80.00, 90.00]", "81.08")
    assert (plateaus["settled"], plateaus["drift pp [CI]"]) == ("-", "-")  # not measured
    paper = tables.display_paper_definitions(t3)
    assert paper.loc[("q_learning", "r3")]["conv. itr"] == "- (2350)"
    assert paper.loc[("q_learning", "r3")]["touch itr"] == "100 (2350)"  # no interval on a mean-curve reading
    assert paper.loc[("sarsa", "r3")]["touch itr"] == "100"  # the paper has no SARSA rows
    for frame in (tables.display_learning_time(t3), tables.display_plateaus(t3), paper):
        assert max(map(len, frame.to_string().splitlines())) <= tables.PRINT_WIDTH


def test_interval_columns_are_exactly_those_with_bounds():
    """``table3.csv``'s convention: a column X with an interval has X_low and X_high; the paper's
    mean-curve readings have none."""
    columns = set(tables.TABLE3_COLUMNS)
    with_bounds = {c for c in columns if f"{c}_low" in columns and f"{c}_high" in columns}
    assert {"learning_time_median", "learning_time_rmst", "censored_share", "success_plateau",
            "greedy_success_plateau", "never_terminal_share", tables.DRIFT} <= with_bounds
    for reading in ("max_success_iterations", "reward_convergence_iterations", "max_average_reward",
                    "held_success_iterations", "success_window_mean"):
        assert reading in columns and reading not in with_bounds


# ---------------------------------------------------------------------------
# The quoted numbers are the paper's
# ---------------------------------------------------------------------------
EXPECTED_TABLE3 = {  # reward: conv. iterations, conv. episodes, max-success iterations, episodes (paper Table 3)
    "r1": (680, 31, 630, 25),
    "r2": (290, 21, 240, 14),
    "r3": (2350, 70, 2350, 70),
    "r4": (190, 15, 140, 10),
}
EXPECTED_TABLE4 = [  # the paper's Table 4, NaN for "-"
    ("Classic RL [8]", 1000, 35, 1000),
    ("Classic RL [7]", None, 4, 1000),
    ("Affordance RL [8]", 48, 99.9, None),
    ("Interactive RL (L=0.5) [8]", 40, None, None),
    ("This work with reward r1", 31, 83.94, 25),
    ("This work with reward r2", 21, 84.73, 14),
    ("This work with reward r3", 70, 81.08, 70),
    ("This work with reward r4", 15, 84.77, 10),
]


def _same(value, expected):
    return math.isnan(value) if expected is None else value == pytest.approx(expected)


def test_quoted_table3_values():
    paper = tables.PAPER_TABLE3.set_index("reward")
    for reward, numbers in EXPECTED_TABLE3.items():
        assert tuple(paper.loc[reward, list(tables.PAPER_COLUMNS[:4])]) == numbers
    # the success rates of Table 3's rows are those of Table 4's "This work" rows
    rates = dict(zip(tables.PAPER_TABLE3["reward"], tables.PAPER_TABLE3["paper_success_rate"]))
    assert rates == pytest.approx({"r1": 0.8394, "r2": 0.8473, "r3": 0.8108, "r4": 0.8477})


def test_quoted_table4_values():
    quoted = tables.PAPER_TABLE4
    assert list(quoted["methodology"]) == [row[0] for row in EXPECTED_TABLE4]
    for (_, conv, rate, episodes), (_, row) in zip(EXPECTED_TABLE4, quoted.iterrows()):
        assert _same(row["average_reward_convergence_episodes"], conv)
        assert _same(row["max_success_rate_percent"], rate)
        assert _same(row["max_success_episodes"], episodes)


# ---------------------------------------------------------------------------
# Curves in long format
# ---------------------------------------------------------------------------
def test_curves_long_exact_rows_and_stride():
    recs = [record("main", reward="r2")]
    curves = [{"success": np.array([0.0, 0.5, 1.0]), "average_reward": np.array([1.0, 2.0, 3.0]),
               "episodes": np.array([0.0, 1.0, 1.0])}]
    full = tables.curves_long(recs, curves)
    assert list(full.columns) == ["learner", "reward", "alpha", "gamma", "experiment", "iteration", "metric", "value",
                                  "low", "high"]
    assert full["low"].isna().all()  # no bands given
    banded = tables.curves_long(recs, [{**curves[0], "success_low": np.array([0.0, 0.25, 0.5]),
                                        "success_high": np.array([0.5, 0.75, 1.0])}], metrics=("success",))
    assert list(banded["low"]) == [0.0, 0.25, 0.5] and list(banded["high"]) == [0.5, 0.75, 1.0]
    assert len(full) == 9
    success = full[full["metric"] == "success"]
    assert list(success["iteration"]) == [1, 2, 3] and list(success["value"]) == [0.0, 0.5, 1.0]
    assert set(full["reward"]) == {"r2"} and set(full["experiment"]) == {"main"}
    strided = tables.curves_long(recs, [{"success": np.arange(5.0)}], metrics=("success",), stride=3)
    assert list(strided["iteration"]) == [1, 4, 5] and list(strided["value"]) == [0.0, 3.0, 4.0]
    with pytest.raises(ValueError):
        tables.curves_long(recs, [])


# ---------------------------------------------------------------------------
# Grid and cell store
# ---------------------------------------------------------------------------
def test_the_grid_deduplicates_cells():
    config = RunConfig(learners=("q_learning", "sarsa"), rewards=("r1", "r4"), sweep_learner="q_learning",
                       sweep_reward="r4", alpha_sweep=(0.3, 0.5, 0.50), gamma_sweep=(0.30, 0.9), literature=False)
    grid = experiments.config_grid(config)
    assert [m.experiment for m in grid].count("main") == 4
    assert [m.experiment for m in grid].count("alpha_sweep") == 2
    assert [m.experiment for m in grid].count("gamma_sweep") == 2
    cells = experiments.unique_cells(grid)
    assert len(cells) == 4 + 1 + 1  # (q_learning, r4, 0.3, 0.3) shared by all three experiments
    assert len(experiments.config_grid(RunConfig(learners=("sarsa",), rewards=("r1",), sweeps=False,
                                                 literature=False))) == 1


def _config(**changes):
    return RunConfig(**{"runs": 10, "iterations": 5, **changes})


PAPER_MODEL = TaskModel()


def _cell_config(cell, config, model=PAPER_MODEL, transitions_sha256=None):
    return experiments.cell_config(experiments.CellRun(cell, config, model), digests.code_digest(config.plugins),
                                   digests.task_digest(model), transitions_sha256)


def _key(cell=None, config=None, model=PAPER_MODEL, transitions_sha256=None):
    cell = cell or experiments.Cell("q_learning", "r4", 0.3, 0.3)
    return experiments.config_hash(_cell_config(cell, config or _config(), model, transitions_sha256))


def test_config_hash_depends_on_what_determines_a_cell():
    digest = _key()
    for same in (_config(workers=2), _config(out="elsewhere", fresh=True, figures=False, progress=False),
                 _config(learners=("sarsa",), rewards=("r1",), alpha=0.9, sweeps=False)):
        assert _key(config=same) == digest  # settings that change no number of this cell
    others = [
        _key(config=_config(seed=1)),
        _key(config=_config(runs=11)),
        _key(config=_config(iterations=6)),
        _key(config=_config(epsilon=0.2)),
        _key(config=_config(max_itr=50)),
        _key(config=_config(threshold=0.9)),
        _key(config=_config(plateau_fraction=0.5)),
        _key(config=_config(start="uniform_unclean")),
        _key(model=TaskModel(start="uniform_unclean")),
        _key(model=TaskModel(ineffective="improper")),
        _key(model=TaskModel(spec="three_segments")),
        _key(transitions_sha256="0" * 64),
        _key(cell=experiments.Cell("q_learning", "r3", 0.3, 0.3)),
        _key(cell=experiments.Cell("q_learning", "r4", 0.3, 0.5)),
        _key(cell=experiments.Cell("q_learning", "r4", 0.5, 0.3)),
        _key(cell=experiments.Cell("sarsa", "r4", 0.3, 0.3)),
    ]
    assert digest not in others and len(set(others)) == len(others)


def test_cell_key_includes_the_code():
    config = _cell_config(experiments.Cell("q_learning", "r4", 0.3, 0.3), _config())
    assert config["learner"]["code_digest"] == code_digest(get_learner("q_learning"))
    assert config["task_digest"] == digests.task_digest(PAPER_MODEL)
    assert config["code_digest"] == digests.code_digest()


def test_a_simulated_cell_key_names_its_analysis_and_an_exact_one_is_unchanged():
    cell = experiments.Cell("q_learning", "r4", 0.3, 0.3)
    exact = _cell_config(cell, _config())
    forced = _cell_config(cell, _config(analysis="exact"))
    simulated = _cell_config(cell, _config(analysis="simulated", analysis_episodes=50))
    assert "analysis" not in exact and exact == forced  # auto chose exact on the paper task: the same key
    assert simulated["analysis"] == "simulated (50 episodes per run)"
    assert {k: v for k, v in simulated.items() if k != "analysis"} == exact


def _summary(iterations=5):
    curves = {name: np.linspace(0, 1, iterations) + i for i, name in enumerate(CURVE_NAMES)}
    scalars = {name: 0.5 for name in SUMMARY_SCALARS}
    scalars["max_success_iterations"] = None
    scalars["reward_convergence_episodes"] = float("nan")
    return Summary(**scalars, **curves)


def _statistics(runs, iterations=5):
    from tableclean_suite.bench.statistics import CellStatistics
    from tableclean_suite.learning_time import learning_time_summary, survival_curve

    learned = np.r_[-1, np.arange(runs - 1) % iterations]
    survival, *band = survival_curve(learned, iterations)
    return CellStatistics(intervals={"success_plateau": (0.25, 0.75), "never_terminal_share": (float("nan"), 0.5)},
                          bands={"success": (np.zeros(iterations), np.ones(iterations)),
                                 "average_reward": (np.zeros(iterations), np.ones(iterations)),
                                 "not_learned": tuple(band)}, survival=survival,
                          runs={"success_asymptote": np.linspace(0, 1, runs),
                                "learning_time": np.where(learned < 0, iterations, learned).astype(float)},
                          learning=learning_time_summary(learned, iterations, reps=50),
                          settling=Settling(0.02, 0.015, 0.025, 75))


def test_cell_store_round_trip_and_corruption(tmp_path):
    store = experiments.CellStore(tmp_path / "cells")
    cell = experiments.Cell("sarsa", "r2", 0.5, 0.3)
    config = _cell_config(cell, _config())
    assert store.load(cell, config) is None
    runs = config["settings"]["runs"]
    config["settings"]["iterations"] = 5
    path = store.save(cell, config, _summary(), _statistics(runs))
    assert path.name.startswith("sarsa-r2-a0.5-g0.3-") and path.suffix == ".npz"
    loaded, stats = store.load(cell, config)
    assert stats.intervals["success_plateau"] == (0.25, 0.75)
    assert math.isnan(stats.intervals["never_terminal_share"][0])
    assert stats.learning == _statistics(runs).learning and stats.learning.censored_share > 0
    assert stats.settling == Settling(0.02, 0.015, 0.025, 75) and not stats.settling.settled(0.01)
    np.testing.assert_array_equal(stats.runs["learning_time"], _statistics(runs).runs["learning_time"])
    np.testing.assert_array_equal(stats.bands["success"][1], np.ones(5))
    np.testing.assert_array_equal(stats.survival, _statistics(runs).survival)
    np.testing.assert_array_equal(stats.bands["not_learned"][0], _statistics(runs).bands["not_learned"][0])
    assert isinstance(loaded, Summary)
    assert loaded.max_success_iterations is None and math.isnan(loaded.reward_convergence_episodes)
    assert loaded.success_plateau == 0.5
    for name in CURVE_NAMES:
        np.testing.assert_array_equal(getattr(loaded, name), getattr(_summary(), name))
    assert store.load(cell, _cell_config(cell, _config(seed=3))) is None
    assert list(path.parent.iterdir()) == [path]  # no temporary file left behind
    path.write_bytes(b"not an npz file")
    with pytest.raises(experiments.CellFileError, match=re.escape(str(path)) + ".*--fresh"):
        store.load(cell, config)


def test_table3_leaves_paper_columns_empty_for_another_task():
    assert tables.is_paper_task(TaskModel()) and tables.is_paper_task(TaskModel(start="uniform_unclean"))
    assert not tables.is_paper_task(TaskModel(spec="three_segments"))
    t3 = tables.table3([record("main", reward="r1")], compare_with_paper=False)
    assert all(math.isnan(t3.iloc[0][c]) for c in tables.PAPER_COLUMNS)
    assert tables.table3([record("main", reward="r1")]).iloc[0]["paper_max_success_iterations"] == 630


@pytest.mark.parametrize("runs_per_chunk", [1, 7])
def test_train_cell_chunking_does_not_change_the_numbers(runs_per_chunk):
    cell = experiments.Cell("q_learning", "r3", 0.5, 0.3)
    config = RunConfig(runs=23, iterations=600, max_itr=80, seed=9)
    whole, whole_stats, _, _ = experiments.train_cell(experiments.CellRun(cell, config, PAPER_MODEL,
                                                                               runs_per_chunk=config.runs))
    chunked, chunked_stats, _, _ = experiments.train_cell(experiments.CellRun(cell, config, PAPER_MODEL,
                                                                                   runs_per_chunk=runs_per_chunk))
    assert whole.max_success_iterations is not None
    for name in SUMMARY_SCALARS:
        a, b = getattr(whole, name), getattr(chunked, name)
        assert a == b or (a != a and b != b), name
    assert whole_stats.intervals == chunked_stats.intervals and whole_stats.learning == chunked_stats.learning
    for name, values in whole_stats.runs.items():
        np.testing.assert_array_equal(chunked_stats.runs[name], values)
    for name in CURVE_NAMES:
        np.testing.assert_array_equal(getattr(chunked, name), getattr(whole, name))


def test_chunk_runs_keeps_a_chunk_within_its_memory_budget():
    assert experiments.chunk_runs(4000, budget_bytes=48_000 * 10) == 10
    assert experiments.chunk_runs(10**8) == 1


def test_csv_text_is_byte_identical_to_pandas_to_csv():
    """The fast writer of curves.csv must give to_csv's bytes: NaN, -0.0, inf, tiny/huge, ints, text."""
    rng = np.random.default_rng(3)
    values = np.r_[rng.normal(size=200) * 10.0 ** rng.integers(-9, 9, size=200),
                   [np.nan, -0.0, 0.0, np.inf, -np.inf, 1e-300, 123456.5, 1234567.0, 0.1 + 0.2]]
    frame = pd.DataFrame({"learner": "q_learning", "alpha": 0.3, "iteration": np.arange(len(values)),
                          "metric": np.where(np.arange(len(values)) % 2, "success", "episodes"),
                          "value": values, "low": values[::-1].copy()})
    expected = frame.to_csv(index=False, float_format=tables.CURVES_FLOAT_FORMAT)
    assert tables.csv_text(frame) == expected
    assert tables.csv_text(frame.iloc[:0]) == frame.iloc[:0].to_csv(index=False, float_format="%.6g")
    quoted = frame.assign(learner="a,b")  # needs quoting: deferred to pandas
    assert tables.csv_text(quoted) == quoted.to_csv(index=False, float_format="%.6g")


def test_csv_text_matches_to_csv_on_curves_long():
    curve = {name: np.linspace(0.0, 1.0, 7) for name in tables.CURVE_METRICS}
    curve["success_low"] = np.r_[np.nan, np.linspace(0.0, 1.0, 6)]
    frame = tables.curves_long([record(), record(reward="r2")], [curve, curve], stride=2)
    assert tables.csv_text(frame) == frame.to_csv(index=False, float_format=tables.CURVES_FLOAT_FORMAT)


def test_table4_adds_the_literature_cells_run_here():
    t3 = tables.table3([record("main", reward="r4"),
                        record("literature", learner="affordance_q_learning", reward="r4", success_plateau=1.0,
                               success_plateau_low=0.99, success_plateau_high=1.0),
                        record("literature", learner="interactive_q_learning", reward="r4")])
    t4 = tables.table4(t3)
    ours = t4[t4["source"] == tables.SOURCE_OURS]
    assert list(ours["methodology"]) == [
        "This run: Q-learning with reward r4",
        "This run: Affordance RL, given affordances (Q-learning) with reward r4",
        "This run: Interactive RL, optimal advisor L=0.5 C=1 (Q-learning) with reward r4",
    ]
    assert ours.iloc[1]["max_success_rate_percent"] == 100.0 and ours.iloc[1]["max_success_rate_percent_low"] == 99.0
    shown = tables.display_table4(t4)
    assert shown.iloc[1]["success % [CI]"] == "100.00 [99.00, 100.00]" and shown.iloc[1]["source"] == "run here"
    assert max(map(len, shown.to_string(index=False).splitlines())) <= tables.PRINT_WIDTH
    assert (shown["source"].iloc[3:] == "quoted").all()


def test_a_simulated_cell_trains_with_its_monte_carlo_error_and_its_row_names_the_kind():
    cell = experiments.Cell("q_learning", "r4", 0.3, 0.3)
    simulated_config = _config(runs=6, iterations=300, analysis="simulated", analysis_episodes=50)
    exact_config = _config(runs=6, iterations=300)
    simulated, exact = (experiments.CellRun(cell, c, PAPER_MODEL) for c in (simulated_config, exact_config))
    plans = {cell: simulated.plan}
    summary, stats, _, _ = experiments.train_cell(simulated)
    exact_summary, exact_stats, _, _ = experiments.train_cell(exact)
    np.testing.assert_array_equal(summary.success, exact_summary.success)  # the same training
    assert abs(summary.success_plateau - exact_summary.success_plateau) < 0.1  # 50 episodes per run: an estimate
    assert summary.success_plateau != exact_summary.success_plateau
    low, high = stats.intervals["success_plateau"]
    assert low < summary.success_plateau < high
    grid = [experiments.Membership("main", cell)]
    records, _ = experiments.cell_records(grid, {cell: summary}, {cell: stats}, plans=plans)
    table = tables.table3(records)
    assert table["asymptotes"].tolist() == ["simulated (50 episodes per run)"]
    assert tables.plateaus_kind(table).startswith("simulated (50 episodes per run;")
    exact_records, _ = experiments.cell_records(grid, {cell: exact_summary}, {cell: exact_stats},
                                                plans={cell: exact.plan})
    assert "asymptotes" not in tables.table3(exact_records).columns
