"""Table 3's iteration figures do not move with the training window (the plateau is an asymptote),
for cells whose behaviour has settled; ``benchmarks.window_invariance`` measures it."""

import math
import re

import pandas as pd
import pytest

from tableclean_suite.bench import experiments, window_invariance
from tableclean_suite.bench.config import RunConfig
from tableclean_suite.task import TaskModel

FIGURES = ("max_success_iterations", "reward_convergence_iterations")
#: Largest relative change allowed between the two windows.
TOLERANCE = 0.05


def _cell(reward, iterations):
    cell = experiments.Cell("q_learning", reward, 0.3, 0.3)
    config = RunConfig(runs=200, iterations=iterations, bootstrap_samples=20, seed=0)
    summary, stats, *_ = experiments.train_cell(experiments.CellRun(cell, config, TaskModel()))
    assert stats.settling.settled(), (reward, iterations, stats.settling)
    return summary


@pytest.mark.parametrize("reward", ["r2", "r4"])
def test_iteration_figures_agree_between_a_window_and_one_three_times_longer(reward):
    short, long = _cell(reward, 1500), _cell(reward, 4500)
    for name in FIGURES:
        a, b = getattr(short, name), getattr(long, name)
        assert a is not None and b is not None, name
        assert abs(a - b) <= TOLERANCE * b, (name, a, b)


def test_relative_change_treats_not_reached_as_a_value():
    assert window_invariance.relative_change(200, 210) == pytest.approx(0.05)
    assert window_invariance.relative_change(None, float("nan")) == 0.0
    assert math.isinf(window_invariance.relative_change(200, None))
    assert math.isinf(window_invariance.relative_change(0, 3)) and window_invariance.relative_change(0, 0) == 0.0


def test_figure_changes_pairs_cells_and_needs_both_windows_settled():
    def table(value, settled):
        return pd.DataFrame([{"learner": "q_learning", "reward": "r4", "settled": settled,
                              **{f: value for f in window_invariance.FIGURES}}])

    changes = window_invariance.figure_changes(table(100, True), table(110, "True"))
    assert list(changes["figure"]) == list(window_invariance.FIGURES)
    assert changes["change"].tolist() == pytest.approx([0.1] * len(window_invariance.FIGURES))
    assert changes["settled"].all()
    beyond = window_invariance.relative_change(float("inf"), float("inf"))  # beyond both windows: no change
    assert beyond == 0.0 and window_invariance.relative_change(float("inf"), 900.0) == float("inf")
    assert not window_invariance.figure_changes(table(100, True), table(100, float("nan")))["settled"].any()
    assert window_invariance.cells_above(changes, 0.05).to_dict() == pytest.approx({"q_learning r4": 0.1})
    assert window_invariance.cells_above(changes, 0.1).empty  # a change equal to the threshold is not listed
    lines = window_invariance.summary_lines(changes, 0.05, (1, 2))
    assert lines[0].endswith("more than 5.0 %: q_learning r4 (10.0 %)") and "largest change 10.0 %" in lines[0]
    assert window_invariance.summary_lines(changes, 0.2, (1, 2))[0].endswith("more than 20.0 %: none")
    with pytest.raises(ValueError, match="no .* in common"):
        window_invariance.figure_changes(table(1, True), table(1, True).assign(reward="r1"))


def test_window_invariance_command_writes_its_comparison(tmp_path, capsys):
    out = tmp_path / "wi"
    code = window_invariance.main(["--windows", "1000", "3000", "--learners", "q_learning", "--rewards", "r2",
                                   "--runs", "40", "--bootstrap-samples", "20", "--no-literature", "--out", str(out)])
    assert code == 0
    frame = pd.read_csv(out / window_invariance.RESULT_FILE)
    assert len(frame) == len(window_invariance.FIGURES) and set(frame["cell"]) == {"q_learning r2"}
    short = pd.read_csv(out / "w1000" / "table3.csv").iloc[0]
    assert frame["short"].iloc[0] == short["learning_time_median"]
    assert frame["short"].iloc[1] == short["reward_convergence_iterations"]
    printed = capsys.readouterr().out
    settled = frame[frame["settled"]]
    if len(settled):  # the summary's largest change is the CSV's
        largest = re.search(r"largest change (\S+)", printed)
        assert largest is not None, printed
        expected = settled["change"].max()
        assert (largest[1] == "inf") if math.isinf(expected) else float(largest[1]) == pytest.approx(100 * expected, abs=0.05)
        assert "moving by more than 5.0 %" in printed
    else:
        assert "no cell settled in both windows" in printed
    assert re.search(r"\b(goal|met)\b", printed) is None


@pytest.mark.parametrize("argv, message", [
    (["--windows", "900", "300"], "SHORT < LONG"),
    (["--iterations", "10"], "--iterations: set by this command"),
    (["--goal", "2"], "--goal"),
    (["--runs", "0"], "runs"),
    (["--describe"], "--describe: writes no Table 3"),
])
def test_window_invariance_refuses_bad_flags_with_exit_2(tmp_path, capsys, argv, message):
    with pytest.raises(SystemExit) as stop:
        code = window_invariance.main([*argv, "--out", str(tmp_path / "wi")])
        raise SystemExit(code)
    assert stop.value.code == 2
    assert message in capsys.readouterr().err


def test_window_invariance_entry_point_exits_2_without_a_traceback(tmp_path):
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    done = subprocess.run([sys.executable, "-m", "benchmarks.window_invariance", "--windows", "5", "1",
                           "--out", str(tmp_path / "wi")], cwd=root, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert "SHORT < LONG" in done.stderr and not (tmp_path / "wi").exists()
