"""Smoke runs of the real ``python -m benchmarks.run`` CLI on a tiny budget (``cli``: new processes),
and its flag checks in process."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from tableclean_suite.bench import tables

ROOT = Path(__file__).resolve().parents[1]
SMOKE = ["--runs", "20", "--iterations", "300", "--alpha-sweep", "0.3,0.5", "--gamma-sweep", "0.3"]
#: Cruz et al.'s methods run here (Table 4), at r4.
LITERATURE = ("affordance_q_learning", "learned_affordance_q_learning", "interactive_q_learning")
#: 2 learners x 4 rewards (main), alphas 0.3/0.5 and gamma 0.3 of q_learning/r4, the 3 literature
#: learners at r4: 14 rows, 12 distinct cells.
EXPECTED_ROWS = (
    [("main", l, r, 0.3, 0.3) for l in ("q_learning", "sarsa") for r in ("r1", "r2", "r3", "r4")]
    + [("alpha_sweep", "q_learning", "r4", a, 0.3) for a in (0.3, 0.5)]
    + [("gamma_sweep", "q_learning", "r4", 0.3, 0.3)]
    + [("literature", l, "r4", 0.3, 0.3) for l in LITERATURE]
)
FIGURES = ("fig3_success_rate_q_learning", "fig4_average_reward_q_learning", "fig5_average_reward_sarsa",
           "fig6_success_rate_sweeps", "fig7_average_reward_sweeps")
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def cli(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "benchmarks.run", *args], cwd=cwd, capture_output=True,
                          text=True, timeout=300)


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    out = tmp_path_factory.mktemp("smoke") / "tmp"
    result = cli(*SMOKE, "--out", str(out))
    assert result.returncode == 0, result.stderr
    return out, result


@pytest.mark.cli
def test_smoke_run_writes_every_file(smoke):
    out, result = smoke
    for name in ("table3.csv", "table4.csv", "curves.csv", "config.json"):
        assert (out / name).stat().st_size > 0, name
    for stem in FIGURES:
        data = (out / f"{stem}.png").read_bytes()
        assert data.startswith(PNG_MAGIC) and len(data) > 5000, stem
    assert len(list((out / "cells").glob("*.npz"))) == 12
    assert "Table 3" in result.stdout and "Table 4" in result.stdout and "Traceback" not in result.stderr
    config = json.loads((out / "config.json").read_text())
    assert config["args"]["runs"] == 20 and config["package_version"] and config["paper"] and config["timestamp"]


@pytest.mark.cli
def test_table3_has_one_row_per_expected_cell(smoke):
    out, _ = smoke
    t3 = pd.read_csv(out / "table3.csv")
    required = {"learner", "reward", "alpha", "gamma", "experiment", "max_success_iterations",
                "max_success_episodes", "reward_convergence_iterations", "reward_convergence_episodes",
                "success_plateau", "max_average_reward", "average_reward_plateau", "terminal_plateau",
                "paper_reward_convergence_iterations", "paper_reward_convergence_episodes",
                "paper_max_success_iterations", "paper_max_success_episodes", "paper_success_rate"}
    assert required <= set(t3.columns)
    rows = sorted(zip(t3["experiment"], t3["learner"], t3["reward"], t3["alpha"], t3["gamma"]))
    assert rows == sorted(EXPECTED_ROWS)
    assert t3["success_plateau"].between(0, 1).all()
    paper_rows = t3[t3["paper_max_success_iterations"].notna()]
    assert sorted(zip(paper_rows["learner"], paper_rows["reward"])) == [("q_learning", f"r{i}") for i in range(1, 5)]
    assert (paper_rows["experiment"] == "main").all()
    t4 = pd.read_csv(out / "table4.csv")
    assert list(t4.columns) == list(tables.TABLE4_COLUMNS)
    assert (t4["source"] == "this run").sum() == 4 + 3 and (t4["source"] == "quoted from the paper").sum() == 8
    run_here = t4[t4["source"] == "this run"]["methodology"]
    assert run_here.str.contains("Affordance RL, given").sum() == 1 and run_here.str.contains("Interactive RL").sum() == 1


@pytest.mark.cli
def test_table4_marks_every_row_run_here_or_quoted(smoke):
    _, result = smoke
    table4 = result.stdout.split("Table 4:")[1].split("written:")[0]
    rows = [line.lstrip() for line in table4.splitlines() if line.lstrip().startswith(("run here ", "quoted "))]
    assert len(rows) == 4 + 3 + 8
    assert sum(line.startswith("run here ") for line in rows) == 7
    assert sum(line.startswith("quoted ") for line in rows) == 8
    assert all("[" in line for line in rows if line.startswith("run here "))  # ours with intervals


@pytest.mark.cli
def test_curves_long_format(smoke):
    out, _ = smoke
    curves = pd.read_csv(out / "curves.csv")
    assert list(curves.columns) == ["learner", "reward", "alpha", "gamma", "experiment", "iteration", "metric",
                                    "value", "low", "high"]
    assert set(curves["metric"]) == {"success", "average_reward", "episodes"}
    assert len(curves) == len(EXPECTED_ROWS) * 3 * 300
    one = curves[(curves["experiment"] == "main") & (curves["learner"] == "sarsa") & (curves["reward"] == "r2")
                 & (curves["metric"] == "success")]
    assert list(one["iteration"]) == list(range(1, 301))


@pytest.mark.cli
def test_every_published_statistic_has_an_interval_and_the_papers_readings_none(smoke):
    """The per-run statistics carry X_low/X_high beside X in table3.csv, holding X; the paper's readings of the
    mean curves (first touch, reward convergence, maximum average reward) carry no interval."""
    out, result = smoke
    t3, t4 = pd.read_csv(out / "table3.csv"), pd.read_csv(out / "table4.csv")
    columns = list(t3.columns)
    for name in ("learning_time_median", "learning_time_rmst", "censored_share", "success_plateau",
                 "greedy_success_plateau", "never_terminal_share"):
        assert columns[columns.index(name) + 1: columns.index(name) + 3] == [name + "_low", name + "_high"]
        defined = t3[[name, name + "_low", name + "_high"]].dropna()
        assert len(defined) > 0, name
        assert ((defined[name + "_low"] <= defined[name] + 1e-12)
                & (defined[name] <= defined[name + "_high"] + 1e-12)).all(), name
    for name in ("max_success_iterations", "reward_convergence_episodes", "max_average_reward"):
        assert name in columns and name + "_low" not in columns and name + "_high" not in columns
    ours = t4[t4["source"] == "this run"]
    assert ours["max_success_rate_percent_low"].notna().all() and ours["max_success_rate_percent_high"].notna().all()
    assert "Probability of improvement" in result.stdout and "Kaplan-Meier" in result.stdout
    row = next(line for line in result.stdout.splitlines() if line.split()[:2] == ["q_learning", "r1"])
    assert row.count("[") >= 3  # Table 3a's row: median, RMST and censored share with their intervals
    comparisons = pd.read_csv(out / "comparisons.csv")
    assert comparisons["probability_of_improvement"].between(0, 1).all() and len(comparisons) == 2 * (6 * 2 + 4)
    curves = pd.read_csv(out / "curves.csv")
    banded = curves[curves["metric"] == "success"].dropna(subset=["low", "high"])
    assert len(banded) > 0 and (banded["low"] <= banded["high"]).all()


@pytest.mark.cli
def test_rerun_resumes_every_cell_with_identical_table(smoke, tmp_path):
    out, _ = smoke
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    result = cli(*SMOKE, "--out", str(copy), "--no-figures")
    assert result.returncode == 0, result.stderr
    assert "resumed 12 cells" in result.stdout and "trained 0" in result.stdout
    assert (copy / "table3.csv").read_bytes() == (out / "table3.csv").read_bytes()
    assert (copy / "curves.csv").read_bytes() == (out / "curves.csv").read_bytes()
    assert (copy / "comparisons.csv").read_bytes() == (out / "comparisons.csv").read_bytes()


@pytest.mark.cli
def test_corrupt_cell_file_gives_clear_error(smoke, tmp_path):
    out, _ = smoke
    copy = tmp_path / "copy"
    shutil.copytree(out / "cells", copy / "cells")
    victim = sorted((copy / "cells").glob("sarsa-r2-*.npz"))[0]
    victim.write_bytes(b"\x00garbage")
    result = cli(*SMOKE, "--out", str(copy), "--no-figures")
    assert result.returncode in (1, 2)
    assert victim.name in result.stderr and "--fresh" in result.stderr
    assert "Traceback" not in result.stderr


@pytest.mark.cli
def test_describe_prints_model_analysis():
    result = cli("--describe")
    assert result.returncode == 0, result.stderr
    text = result.stdout
    assert "20 states = 18 non-terminal + 2 terminal" in text
    assert "Shortest plan from Table 1 state 4 (code 0): 8 actions" in text
    assert "Table 1 rows never reachable: 14, 15, 16, 18" in text
    assert "r4" in text and "sarsa" in text and "q_learning" in text


@pytest.mark.parametrize(
    "args, named",
    [
        (["--rewards", "r1,r9"], "r9"),
        (["--learners", "dqn"], "dqn"),
        (["--alpha", "0"], "alpha"),
        (["--alpha", "1.5"], "1.5"),
        (["--runs", "0"], "runs"),
        (["--gamma", "-1"], "-1"),
        (["--alpha-sweep", "0.3,2"], "2"),
        (["--bogus-flag"], "--bogus-flag"),
        (["--backend", "calibrated"], "--transitions"),
        (["--executor", "spark"], "--executor"),
        (["--ray-address", "auto"], "--ray-address"),
        (["--executor", "ray", "--workers", "0"], "--workers"),
    ],
)
def test_bad_input_exits_2_with_one_line(args, named, tmp_path, capsys):
    from tableclean_suite.bench.run import main

    with pytest.raises(SystemExit) as stop:
        main([*args, "--out", str(tmp_path / "never")])
    assert stop.value.code == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("tableclean-bench run: error:") and named in line
    assert not (tmp_path / "never").exists()


@pytest.mark.cli
def test_bad_input_from_the_entry_point_has_no_traceback(tmp_path):
    result = cli("--rewards", "r1,r9", "--out", str(tmp_path / "never"))
    assert result.returncode == 2 and "Traceback" not in result.stderr
    (line,) = result.stderr.strip().splitlines()
    assert line.startswith("python -m benchmarks.run: error:") and "r9" in line


def _import_robosuite(quiet: bool):
    code = ("import logging, sys\n"
            "from tableclean_suite.robosuite_adapter import quiet_robosuite_startup\n"
            + ("holder = quiet_robosuite_startup()\n" if quiet else "")
            + "import robosuite\n"
            "logging.getLogger('robosuite_logs').warning('a later message')\n")
    return subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)


@pytest.mark.cli
def test_robosuite_start_up_warnings_are_dropped_unless_verbose():
    quiet, verbose = _import_robosuite(quiet=True), _import_robosuite(quiet=False)
    assert quiet.returncode == verbose.returncode == 0, quiet.stderr + verbose.stderr
    assert "private macro file" in verbose.stderr  # what robosuite prints on import
    assert verbose.stderr.count("[robosuite WARNING]") > 1
    lines = [line for line in quiet.stderr.splitlines() if "[robosuite" in line]
    assert len(lines) == 1 and "a later message" in lines[0]  # only the start-up messages are dropped


@pytest.mark.cli
def test_symbolic_cli_prints_no_robosuite_warnings():
    result = cli("--describe")
    assert result.returncode == 0 and "[robosuite" not in result.stderr


def test_progress_bar_counts_resumed_cells_as_done(tmp_path, capsys):
    from tableclean_suite.bench import experiments
    from tableclean_suite.bench.config import RunConfig
    from tableclean_suite.task import TaskModel

    config = RunConfig(runs=3, iterations=40, learners=("q_learning",), rewards=("r1", "r2", "r3"), sweeps=False,
                       literature=False)
    grid, store, model = experiments.config_grid(config), experiments.CellStore(tmp_path / "cells"), TaskModel()
    experiments.run_grid(grid[:2], config, model, store)  # two of the three cells stored
    capsys.readouterr()
    outcome = experiments.run_grid(grid, config, model, store)
    bar = capsys.readouterr().err
    assert (outcome.resumed, outcome.trained) == (2, 1)
    first_frame = bar.replace("\r", "\n").strip().splitlines()[0]
    assert "2/3" in first_frame, bar  # resumed cells are done before the first trained one


def test_tables_name_a_json_spec_and_quote_the_papers_own_rows_only_beside_the_paper(tmp_path, capsys):
    from tableclean_suite.bench.run import main

    spec = tmp_path / "file_name_not_shown.json"
    spec.write_text(json.dumps({"name": "json_named_task", "segments": 3, "objects": 1}))
    tiny = ["--learners", "q_learning", "--rewards", "r4", "--runs", "3", "--iterations", "60", "--no-sweeps",
            "--no-literature", "--no-figures", "--no-progress"]
    assert main([*tiny, "--task", str(spec), "--out", str(tmp_path / "json")]) == 0
    printed = capsys.readouterr().out
    assert "Table 3: learning speed per reward pattern on task 'json_named_task'" in printed
    assert "Table 4: comparison with the literature on task 'json_named_task'" in printed
    assert "file_name_not_shown" not in printed
    quoted = pd.read_csv(tmp_path / "json" / "table4.csv")
    quoted = quoted[quoted["source"] != "this run"]["methodology"]
    assert len(quoted) == 4 and not quoted.str.startswith(tables.PAPER_OWN_ROWS).any()
    assert main([*tiny, "--out", str(tmp_path / "paper")]) == 0
    assert "on task" not in capsys.readouterr().out  # the paper's run prints as before
    quoted = pd.read_csv(tmp_path / "paper" / "table4.csv")
    assert quoted["methodology"].str.startswith(tables.PAPER_OWN_ROWS).sum() == 4
