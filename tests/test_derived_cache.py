"""The derived-results cache: a stored entry gives the bytes a computation gives without computing
them; a changed input or setting, or a damaged entry, is computed again."""

from __future__ import annotations

import numpy as np
import pytest

from tableclean_suite.bench import derived

SETTINGS = {"confidence": 0.95, "samples": 40, "seed": 0}


@pytest.fixture(scope="module")
def inputs():
    """Two trained main cells (q_learning on r1 and r4): comparison inputs, curves frame, Table 3."""
    from tableclean_suite.bench import experiments, tables
    from tableclean_suite.bench.config import RunConfig
    from tableclean_suite.task import TaskModel

    config = RunConfig(runs=12, iterations=150, bootstrap_samples=20, seed=0)
    cells = [experiments.Cell("q_learning", reward, 0.3, 0.3) for reward in ("r1", "r4")]
    summaries, statistics = {}, {}
    for cell in cells:
        summaries[cell], statistics[cell], *_ = experiments.train_cell(experiments.CellRun(cell, config, TaskModel()))
    records, curves = experiments.cell_records([experiments.Membership("main", cell) for cell in cells],
                                               summaries, statistics)
    comparison_cells = [{"learner": c.learner, "reward": c.reward, "runs": statistics[c].runs} for c in cells]
    return comparison_cells, tables.curves_long(records, curves), tables.table3(records)


def compute(root, cells, curves=None, table3=None, read=True, **changed):
    settings = {**SETTINGS, **changed}
    return derived.derive(root, cells, settings["confidence"], settings["samples"], settings["seed"], curves, table3,
                          plateau_fraction=0.25, dpi=50, read=read)


def outputs(results) -> tuple:
    return results.comparisons.to_csv(index=False), list(results.figures.items())


def test_a_stored_entry_gives_the_computed_bytes_without_computing(inputs, tmp_path):
    cells, curves, table3 = inputs
    first = compute(tmp_path, cells, curves, table3)
    second = compute(tmp_path, cells, curves, table3)
    assert not first.cached and "computed in" in first.summary()
    assert second.cached and second.summary().startswith("derived results (comparisons, 2 figures): loaded from")
    assert outputs(second) == outputs(first)
    assert len(first.comparisons) == 2 and list(first.figures) == [
        "fig3_success_rate_q_learning.png", "fig4_average_reward_q_learning.png"]
    fresh = compute(tmp_path, cells, curves, table3, read=False)  # --fresh: computed again, the same bytes
    assert not fresh.cached and outputs(fresh) == outputs(first)


def test_computed_and_stored_comparisons_equal_the_statistics_modules(inputs, tmp_path):
    from tableclean_suite.bench import statistics

    cells, _, _ = inputs
    direct = statistics.comparisons(cells, SETTINGS["confidence"], SETTINGS["samples"], SETTINGS["seed"])
    for _ in range(2):  # computed, then loaded
        assert compute(tmp_path, cells).comparisons.to_csv(index=False) == direct.to_csv(index=False)


def test_a_changed_sample_count_or_cell_is_computed_again(inputs, tmp_path):
    cells, _, _ = inputs
    reference = compute(tmp_path, cells)
    more_samples = compute(tmp_path, cells, samples=41)
    assert not more_samples.cached and outputs(more_samples) != outputs(reference)
    changed = [dict(cell, runs=dict(cell["runs"])) for cell in cells]
    learning_time = np.array(changed[1]["runs"]["learning_time"], copy=True)
    learning_time[0] += 1
    changed[1]["runs"]["learning_time"] = learning_time
    assert not compute(tmp_path, changed).cached
    latest = compute(tmp_path, cells)  # only the latest entry is kept: the first was removed
    assert not latest.cached and [p.name for p in tmp_path.glob("derived-*.zip")] == [latest.path.name]
    assert compute(tmp_path, cells).cached


def test_a_changed_figure_input_is_drawn_again(inputs, tmp_path):
    cells, curves, table3 = inputs
    compute(tmp_path, cells, curves, table3)
    changed = curves.copy()
    changed.loc[changed.index[-1], "value"] += 0.5
    assert not compute(tmp_path, cells, changed, table3).cached
    assert not compute(tmp_path, cells).cached  # no figures asked for: another entry


@pytest.mark.parametrize("damage", ["truncated", "flipped byte", "garbage", "empty"])
def test_a_damaged_entry_is_computed_again_and_replaced(inputs, tmp_path, capsys, damage):
    cells, _, _ = inputs
    reference = compute(tmp_path, cells)
    data = reference.path.read_bytes()
    at = data.index(b"probability_of_improvement")  # inside the stored comparison rows
    damaged = {"truncated": data[: len(data) // 2], "flipped byte": data[:at] + b"q" + data[at + 1:],
               "garbage": b"not a cache entry\n" * 10, "empty": b""}[damage]
    reference.path.write_bytes(damaged)
    capsys.readouterr()
    again = compute(tmp_path, cells)
    assert not again.cached and outputs(again) == outputs(reference)
    assert "ignoring the cached results" in capsys.readouterr().err
    assert compute(tmp_path, cells).cached  # replaced by a whole entry
