"""Settling: the behaviour drift over the window's last quarter, and the harness's use of it."""

import math

import numpy as np
import pandas as pd
import pytest

from tableclean_suite import analysis, asymptotes, settling
from tableclean_suite.bench import experiments, tables
from tableclean_suite.bench.config import RunConfig
from tableclean_suite.learners import train
from tableclean_suite.settling import Settling
from tableclean_suite.task import TaskModel

MODEL = TaskModel()


def test_checkpoint_is_three_quarters_of_the_window_and_at_least_one():
    assert settling.checkpoint_iteration(4000) == 3000
    assert settling.checkpoint_iteration(7) == 5
    assert settling.checkpoint_iteration(1) == 1
    with pytest.raises(ValueError, match="iterations"):
        settling.checkpoint_iteration(0)


def test_drift_is_the_absolute_change_per_run_and_settled_compares_its_mean():
    np.testing.assert_allclose(settling.behaviour_drift([0.8, 0.2, 0.5], [0.7, 0.4, 0.5]), [0.1, 0.2, 0.0])
    with pytest.raises(ValueError, match=r"\(R,\)"):
        settling.behaviour_drift([0.1, 0.2], [0.1])
    assert Settling(0.01, 0.0, 0.02, 30).settled(0.01) is True
    assert Settling(0.0101, 0.0, 0.02, 30).settled(0.01) is False
    assert Settling.not_measured().settled() is None and not Settling.not_measured().measured


def _stats(learner, reward, runs=200, iterations=2000):
    cell = experiments.Cell(learner, reward, 0.3, 0.3)
    config = RunConfig(runs=runs, iterations=iterations, bootstrap_samples=50, seed=0)
    return experiments.train_cell(experiments.CellRun(cell, config, MODEL))[1]


def test_harness_drift_is_the_mean_change_between_the_checkpoint_and_the_end():
    stats = _stats("sarsa", "r4", runs=60, iterations=800)
    chain = asymptotes.EpisodeChain.build(MODEL, "r4")
    ends = [analysis.final_asymptotes(train(learner="sarsa", reward="r4", runs=60, iterations=t, alpha=0.3,
                                            gamma=0.3, epsilon=0.1, max_itr=500, seed=0, task=MODEL),
                                      chain, 500, MODEL).success for t in (600, 800)]
    assert stats.settling.checkpoint == 600
    assert stats.settling.drift == pytest.approx(np.abs(ends[1] - ends[0]).mean(), abs=1e-12)
    assert stats.settling.low <= stats.settling.drift <= stats.settling.high


@pytest.mark.parametrize("learner", ["q_learning", "sarsa", "double_q_learning", "q_lambda", "dyna_q",
                                     "learned_affordance_q_learning", "interactive_q_learning"])
def test_checkpoint_q_tables_of_one_pass_are_those_of_the_shorter_training(learner):
    """train(checkpoint=k) keeps, from the same pass, the Q-tables a k-iteration training ends with."""
    from tableclean_suite.backends import CHECKPOINT_Q

    common = dict(learner=learner, reward="r4", runs=7, alpha=0.3, gamma=0.3, epsilon=0.1, max_itr=40, seed=3,
                  task=MODEL)
    full = train(iterations=300, checkpoint=211, **common)
    short = train(iterations=211, **common)
    assert np.array_equal(full.info[CHECKPOINT_Q], short.q)
    early = experiments.checkpoint_result(full, 211)
    assert np.array_equal(early.states, short.states) and early.iterations == 211
    chain = asymptotes.EpisodeChain.build(MODEL, "r4")
    assert np.array_equal(analysis.final_asymptotes(early, chain, 40, MODEL).success,
                          analysis.final_asymptotes(short, chain, 40, MODEL).success)
    assert CHECKPOINT_Q not in train(iterations=300, **common).info
    with pytest.raises(ValueError, match="checkpoint"):
        train(iterations=300, checkpoint=301, **common)


def test_converged_q_learning_settles_and_drifting_sarsa_does_not():
    q, s = _stats("q_learning", "r2"), _stats("sarsa", "r4")
    assert q.settling.settled() is True, q.settling
    assert s.settling.settled() is False, s.settling
    assert s.settling.low > settling.DEFAULT_SETTLE_TOLERANCE


def test_table3_carries_the_settling_columns():
    cell = experiments.Cell("q_learning", "r2", 0.3, 0.3)
    config = RunConfig(runs=40, iterations=600, bootstrap_samples=20, seed=0)
    summary, stats, *_ = experiments.train_cell(experiments.CellRun(cell, config, MODEL))
    grid = [experiments.Membership("main", cell)]
    records, _ = experiments.cell_records(grid, {cell: summary}, {cell: stats}, settle_tolerance=0.0)
    row = tables.table3(records).iloc[0]
    assert row["checkpoint_iteration"] == 450 and row["behaviour_drift"] == stats.settling.drift
    assert bool(row["settled"]) == (stats.settling.drift <= 0.0)
    shown = tables.display_plateaus(tables.table3(records))
    assert shown["drift pp [CI]"].iloc[0].startswith(f"{100 * stats.settling.drift:.2f}")


def test_table3_without_settling_leaves_it_empty():
    cell = experiments.Cell("q_learning", "r2", 0.3, 0.3)
    config = RunConfig(runs=10, iterations=200, bootstrap_samples=5, seed=0)
    summary, *_ = experiments.train_cell(experiments.CellRun(cell, config, MODEL))
    records, _ = experiments.cell_records([experiments.Membership("main", cell)], {cell: summary})
    row = tables.table3(records).iloc[0]
    assert math.isnan(row["behaviour_drift"]) and row["checkpoint_iteration"] is pd.NA and row["settled"] is pd.NA


def test_sweep_table_marks_settled_unsettled_and_unmeasured_rows():
    def row(alpha, settled):
        cell = experiments.Cell("q_learning", "r4", alpha, 0.3)
        scalars = {name: 1.0 for name in tables.SUMMARY_SCALARS}
        return {"cell_id": cell.label, "learner": "q_learning", "reward": "r4", "alpha": alpha, "gamma": 0.3,
                "experiment": "alpha_sweep", "settled": settled, **scalars}

    shown = tables.display_sweeps(tables.table3([row(0.3, True), row(0.5, False), row(0.7, None)]))
    assert shown["settled"].tolist() == ["yes", "NO", "-"]


@pytest.mark.parametrize("learner", ["q_learning", "double_q_learning"])
def test_the_reference_engine_keeps_the_checkpoint_q_tables_too(learner):
    """engine="reference" honours checkpoint= (it left the key out, silently) with the compiled loop's tables."""
    from tableclean_suite.backends import CHECKPOINT_Q

    common = dict(learner=learner, reward="r4", runs=3, max_itr=40, seed=3, task=MODEL)
    full = train(iterations=120, checkpoint=77, engine="reference", **common)
    assert np.array_equal(full.info[CHECKPOINT_Q], train(iterations=77, engine="reference", **common).q)
    assert np.array_equal(full.info[CHECKPOINT_Q], train(iterations=120, checkpoint=77, **common).info[CHECKPOINT_Q])
    assert CHECKPOINT_Q not in train(iterations=120, engine="reference", **common).info
