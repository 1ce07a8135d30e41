"""``tableclean-bench coverage``: its counts against a hand count over the run command's own tables,
its binomial interval, its refusals and its determinism."""

from __future__ import annotations

import csv
import math

import numpy as np
import pandas as pd
import pytest
from scipy.stats import beta

from tableclean_suite.bench import commands, coverage, run
from tableclean_suite.intervals import clopper_pearson

#: A tiny study: 20 runs (the fewest the curve bootstrap gives intervals for) of 150 iterations, two
#: cells (so that comparisons.csv has rows).
TINY = ["--learners", "q_learning", "sarsa", "--rewards", "r2", "--runs", "20", "--iterations", "150",
        "--bootstrap-samples", "40", "--max-itr", "60", "--seed", "3"]
REPLICATIONS, REFERENCE_RUNS = 3, 40


def _study(out, *extra) -> pd.DataFrame:
    argv = [*TINY, "--replications", str(REPLICATIONS), "--reference-runs", str(REFERENCE_RUNS), "--no-progress",
            "--out", str(out), *extra]
    assert coverage.main(argv) == 0
    return pd.read_csv(out / coverage.RESULT_FILE, float_precision="round_trip", keep_default_na=False)


def _published(out, seed: int, runs: int) -> dict:
    """``{(table, row label): row}`` of ``table3.csv`` and ``comparisons.csv`` as ``tableclean-bench run``
    writes them at ``seed`` with ``runs`` runs (text, as in the files)."""
    argv = [*TINY, "--seed", str(seed), "--runs", str(runs), "--no-sweeps", "--no-literature", "--no-figures",
            "--no-progress", "--out", str(out)]
    assert run.main(argv) == 0
    rows = {}
    for table in ("table3", "comparisons"):
        with open(out / f"{table}.csv", newline="") as handle:
            for row in csv.DictReader(handle):
                label = row["cell_id"] if table == "table3" else (
                    f"{row['learner_x']}-{row['reward_x']} vs {row['learner_y']}-{row['reward_y']}: {row['score']}")
                rows[table, label] = row
    return rows


def _number(text: str) -> float:
    return float(text) if text not in ("", "<NA>") else math.nan


@pytest.mark.slow
def test_counts_are_a_hand_count_over_the_run_commands_tables(tmp_path, capsys):
    study = _study(tmp_path / "coverage")
    reference = _published(tmp_path / "reference", 3, REFERENCE_RUNS)
    replications = [_published(tmp_path / f"rep{k}", 3 + 1 + k, 20) for k in range(REPLICATIONS)]
    expected = []
    for (table, label), row in reference.items():
        for name in (name for name in row if f"{name}_low" in row and f"{name}_high" in row):
            target = _number(row[name])
            covered = undefined = 0
            widths = []
            for published in replications:
                bounds = published[table, label]
                low, high = _number(bounds[f"{name}_low"]), _number(bounds[f"{name}_high"])
                if math.isnan(low) or math.isnan(high):
                    undefined += 1
                    continue
                widths.append(0.0 if low == high else high - low)
                covered += low <= target <= high
            expected.append((table, label, name, target, None if math.isnan(target) else covered, undefined,
                             np.mean(widths) if widths else math.nan))
    assert [tuple(e[:3]) for e in expected] == list(zip(study["table"], study["row"], study["statistic"]))
    assert {"table3", "comparisons"} == set(study["table"]) and len(study) >= 20
    for (table, label, name, target, covered, undefined, width), row in zip(expected, study.itertuples()):
        where = f"{table} {label} {name}"
        assert _number(str(row.target)) == target or math.isnan(target), where
        assert row.undefined == undefined and row.replications == REPLICATIONS, where
        assert _number(str(row.mean_width)) == pytest.approx(width, nan_ok=True), where
        if covered is None:
            assert row.covered == "" and row.coverage == "", where
        else:
            assert int(row.covered) == covered and float(row.coverage) == covered / REPLICATIONS, where
            low, high = clopper_pearson(covered, REPLICATIONS)
            assert (float(row.coverage_low), float(row.coverage_high)) == (low, high), where
    counts = pd.to_numeric(study["covered"])
    assert counts.sum() > 0 and (counts < REPLICATIONS).any()  # the counts vary between statistics


@pytest.mark.slow
def test_the_same_arguments_give_the_same_bytes_and_the_reference_is_kept(tmp_path, capsys):
    _study(tmp_path / "a")
    _study(tmp_path / "b")
    first = (tmp_path / "a" / coverage.RESULT_FILE).read_bytes()
    assert first == (tmp_path / "b" / coverage.RESULT_FILE).read_bytes()
    assert len(list((tmp_path / "a" / "cells").glob("*.npz"))) == 2  # the reference's cells; no replication's
    assert not list((tmp_path / "a").glob(".replications-*"))
    _study(tmp_path / "a")  # the reference loaded from its cell: the same bytes again
    assert (tmp_path / "a" / coverage.RESULT_FILE).read_bytes() == first
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("work: 3 replications x 2 cells x 20 runs x 150 iterations")
    assert max(map(len, lines)) <= coverage.PRINT_WIDTH
    assert not any(word in line for line in lines for word in ("PASS", "FAIL", "goal", "met"))


def test_coverage_frame_counts_closed_intervals_and_leaves_undefined_targets_empty():
    reference = pd.DataFrame({"x": [1.0], "x_low": [0.0], "x_high": [2.0], "y": [pd.NA], "y_low": [0.0],
                              "y_high": [1.0], "z": [5.0], "z_low": [0.0], "t": [math.inf], "t_low": [3.0],
                              "t_high": [math.inf]}, index=["c"])
    bounds = [(0.0, 2.0, 3.0), (1.0, 1.0, math.inf), (1.5, 2.0, 4.0), (math.nan, 3.0, math.inf)]
    replications = [{"table3": reference.assign(x_low=low, x_high=high, t_low=t_low,
                                                t_high=math.inf if t_low > 3 else 9.0)}
                    for low, high, t_low in bounds]
    frame = coverage.coverage_frame({"table3": reference}, replications, runs=10, reference_runs=100, nominal=0.95)
    assert list(frame["statistic"]) == ["x", "y", "t"]  # z has no high bound: not an interval
    x, y, t = (frame.iloc[i] for i in range(3))
    assert (x["covered"], x["undefined"], x["replications"]) == (2, 1, 4)
    assert x["coverage"] == 0.5 and x["mean_width"] == pytest.approx((2.0 + 0.0 + 0.5) / 3)
    assert (x["coverage_low"], x["coverage_high"]) == clopper_pearson(2, 4)
    assert pd.isna(y["covered"]) and math.isnan(y["coverage"]) and y["mean_width"] == 1.0
    assert t["covered"] == 3 and t["mean_width"] == math.inf  # +inf (censored) is covered by a top of +inf


def test_the_coverage_interval_is_the_exact_binomial_one():
    low, high = clopper_pearson(18, 20, 0.95)
    assert low == pytest.approx(beta.ppf(0.025, 18, 3)) and high == pytest.approx(beta.ppf(0.975, 19, 2))
    assert (round(100 * low), round(100 * high)) == (68, 99)  # why 20 replications cannot show 90 %
    assert clopper_pearson(0, 100)[0] == 0.0 and clopper_pearson(100, 100)[1] == 1.0
    reference = pd.DataFrame({"x": [0.5], "x_low": [0.0], "x_high": [1.0]}, index=["c"])
    misses = [{"t": reference.assign(x_low=0.6)}] * 2 + [{"t": reference}] * 18
    frame = coverage.coverage_frame({"t": reference}, misses, runs=1, reference_runs=1, nominal=0.95, confidence=0.9)
    assert frame.loc[0, "covered"] == 18 and frame.loc[0, "coverage_confidence"] == 0.9
    assert (frame.loc[0, "coverage_low"], frame.loc[0, "coverage_high"]) == clopper_pearson(18, 20, 0.9)
    assert frame.loc[0, "coverage_low"] == pytest.approx(beta.ppf(0.05, 18, 3))


def test_replication_seeds_follow_the_reference_and_share_no_run_key():
    from tableclean_suite.learners.rng import run_keys

    seeds = [coverage.replication_seed(7, k) for k in range(50)]
    assert seeds == list(range(8, 58))
    keys = np.concatenate([run_keys(7, 0, 2000), *(run_keys(seed, 0, 200) for seed in seeds)])
    assert len(np.unique(keys)) == len(keys)


@pytest.mark.parametrize("argv, named", [
    (["--replications", "0"], "argument --replications: expected a positive integer, got '0'"),
    (["--runs", "50", "--reference-runs", "40"],
     "--reference-runs: 40 is fewer than --runs 50; allowed: an integer >= --runs"),
    (["--learners", "q_lerning"], "--learners: unknown 'q_lerning'; allowed: "),
    (["--confidence", "1.5"], "argument --confidence: expected a number in (0, 1), got '1.5'"),
    (["--nominal", "0"], "--nominal must be in (0, 1), got 0.0"),
])
def test_bad_input_is_one_line_and_exit_2_before_any_training(argv, named, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(coverage, "measure", lambda *a: pytest.fail("trained despite a bad flag"))
    code = commands.main(["coverage", *argv, "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith("tableclean-bench coverage: error: ") and named in err[0], err[0]
    assert not (tmp_path / "out").exists()


def test_ctrl_c_is_one_line_and_exit_130(tmp_path, capsys, monkeypatch):
    def interrupted(*args):
        raise KeyboardInterrupt

    monkeypatch.setattr(coverage, "measure", interrupted)
    code = commands.main(["coverage", *TINY, "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 130 and len(err) == 1 and "interrupted" in err[0]
    assert not (tmp_path / "out" / coverage.RESULT_FILE).exists()
