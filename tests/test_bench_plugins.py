"""``--plugins``: a user's module registers an action, a task spec and a reward pattern, and the
command line (and its executor workers) can use them by name."""

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pandas as pd
import pytest

pytestmark = pytest.mark.cli  # each test runs the command line in new processes

ROOT = Path(__file__).resolve().parents[1]
PLUGIN = textwrap.dedent("""
    from tableclean_suite.rewards import RewardPattern, register_reward_pattern
    from tableclean_suite.task import ActionRule, Outcome, TaskSpec, register_action, register_task_spec

    def move_back(state):
        return state.replace(arm=(state.arm - 1) % state.n_segments), Outcome.ROUTINE

    register_action(ActionRule("plugin_move_back", move_back), overwrite=True)
    register_task_spec(TaskSpec("plugin_three_back", segments=3,
                                actions=("move", "plugin_move_back", "pick", "place", "clean")), overwrite=True)
    register_reward_pattern(RewardPattern("plugin_sparse", terminal=10, relevant_clean=0, irrelevant_clean=0,
                                          routine=0, improper=-1), overwrite=True)
""")
TINY = ["--learners", "q_learning", "--runs", "20", "--iterations", "400", "--no-sweeps", "--no-literature",
        "--no-figures", "--no-progress"]


def cli(*args):
    return subprocess.run([sys.executable, "-m", "benchmarks.run", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=600)


def test_a_plugin_registers_names_the_command_line_then_accepts(tmp_path):
    plugin = tmp_path / "extras.py"
    plugin.write_text(PLUGIN)
    refused = cli("--task", "plugin_three_back", *TINY, "--out", str(tmp_path / "refused"))
    assert refused.returncode == 2 and "unknown task spec 'plugin_three_back'" in refused.stderr
    result = cli("--plugins", str(plugin), "--task", "plugin_three_back", "--rewards", "r4,plugin_sparse", *TINY,
                 "--out", str(tmp_path / "out"))
    assert result.returncode == 0, result.stderr
    table = pd.read_csv(tmp_path / "out" / "table3.csv")
    assert sorted(table["reward"]) == ["plugin_sparse", "r4"]
    config = json.loads((tmp_path / "out" / "config.json").read_text())
    assert config["args"]["plugins"] == [str(plugin)]


def test_executor_workers_import_the_plugins_too(tmp_path):
    plugin = tmp_path / "extras.py"
    plugin.write_text(PLUGIN)
    common = ["--plugins", str(plugin), "--task", "plugin_three_back", "--rewards", "r4,plugin_sparse", *TINY]
    serial = cli(*common, "--out", str(tmp_path / "serial"))
    parallel = cli(*common, "--executor", "local", "--workers", "2", "--out", str(tmp_path / "parallel"))
    assert serial.returncode == 0 and parallel.returncode == 0, parallel.stderr
    for name in ("table3.csv", "curves.csv"):
        assert (tmp_path / "serial" / name).read_bytes() == (tmp_path / "parallel" / name).read_bytes()


def test_a_plugin_that_cannot_be_imported_exits_2_naming_it(tmp_path):
    broken = tmp_path / "broken.py"
    broken.write_text("raise RuntimeError('no licence')\n")
    for entry, message in ((str(tmp_path / "missing.py"), "no such file"),
                           (str(broken), "RuntimeError: no licence"),
                           ("no_such_module_for_tableclean", "ModuleNotFoundError")):
        result = cli("--plugins", entry, *TINY, "--out", str(tmp_path / "never"))
        assert result.returncode == 2 and message in result.stderr and "Traceback" not in result.stderr
    assert not (tmp_path / "never").exists()
