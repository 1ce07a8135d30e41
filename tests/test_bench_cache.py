"""The cell cache never serves numbers computed by other code."""

import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Registers a user learner, runs the CLI, re-registers the same name with another TD target
#: body (overwrite=True), runs the CLI again into the same --out, then once more unchanged.
DRIVER = '''
import shutil
import sys

import numba

from tableclean_suite.bench.run import main
from tableclean_suite.learners import TabularLearner, register_learner


@numba.njit
def target(q_next, next_action, reward, gamma, epsilon, terminal):
    if terminal:
        return reward
    return reward + gamma * q_next.max()


greedy_target = target


@numba.njit
def target(q_next, next_action, reward, gamma, epsilon, terminal):  # same name, another body
    if terminal:
        return reward
    return reward + gamma * q_next[0]


first_action_target = target


out = sys.argv[1]
argv = ["--learners", "mine", "--rewards", "r1", "--runs", "20", "--iterations", "300", "--no-sweeps",
        "--no-literature",
        "--no-figures", "--no-progress", "--out", out]
register_learner(TabularLearner("mine", greedy_target))
assert main(argv) == 0
shutil.copy(out + "/table3.csv", out + "/first.csv")
register_learner(TabularLearner("mine", first_action_target), overwrite=True)
assert main(argv) == 0
shutil.copy(out + "/table3.csv", out + "/second.csv")
assert main(argv) == 0
'''


@pytest.mark.cli
def test_reregistered_learner_retrains_into_the_same_out(tmp_path):
    driver = tmp_path / "driver.py"
    driver.write_text(DRIVER)
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    result = subprocess.run([sys.executable, str(driver), str(out)], cwd=ROOT, env=env, capture_output=True,
                            text=True, timeout=300)  # PYTHONPATH: this checkout, as pytest imports it
    assert result.returncode == 0, result.stderr
    counts = [line for line in result.stdout.splitlines() if line.startswith("cells:")]
    assert len(counts) == 3
    assert "resumed 0 cells" in counts[0] and "trained 1" in counts[0]
    assert "resumed 0 cells" in counts[1] and "trained 1" in counts[1]  # same name, other code: retrained
    assert "resumed 1 cells" in counts[2] and "trained 0" in counts[2]  # same code again: cached
    first, second = pd.read_csv(out / "first.csv"), pd.read_csv(out / "second.csv")
    assert list(first["learner"]) == list(second["learner"]) == ["mine"]
    columns = ["reward_convergence_iterations", "max_success_iterations", "success_plateau", "max_average_reward"]
    assert not first[columns].equals(second[columns])  # the numbers changed with the code
    assert len(list((out / "cells").glob("mine-r1-*.npz"))) == 2


HELPER = "SCALE = {scale}\n\ndef scaled(value):\n    return SCALE * value\n"
PLUGIN = """
from tableclean_suite.rewards import RewardPattern, register_reward_pattern
import {helper} as helper

BONUS = {bonus}
register_reward_pattern(RewardPattern("{name}", terminal=helper.scaled(BONUS), relevant_clean=1.0,
                                      irrelevant_clean=-1.0, routine=-0.1, improper=-2.0), overwrite=True)
"""


def _write_plugin(folder: Path, tag: str, bonus: float, scale: float) -> Path:
    helper = f"faults_helper_{tag}"
    (folder / f"{helper}.py").write_text(HELPER.format(scale=scale))
    plugin = folder / f"faults_plugin_{tag}.py"
    plugin.write_text(PLUGIN.format(helper=helper, bonus=bonus, name=f"faults_{tag}"))
    return plugin


@pytest.mark.parametrize("edit", ["plugin constant", "imported helper"])
def test_the_code_digest_follows_edits_to_the_plugin_and_its_helpers(tmp_path, monkeypatch, edit):
    from tableclean_suite.bench import digests, plugins

    monkeypatch.syspath_prepend(str(tmp_path))
    tag = edit.replace(" ", "_")
    plugin = _write_plugin(tmp_path, tag, bonus=10, scale=1)
    sources = plugins.loaded_plugin_sources([str(plugin)])
    assert {Path(p).name for p in sources} == {plugin.name, f"faults_helper_{tag}.py"}
    before = digests.code_digest([str(plugin)])
    assert before == digests.code_digest([str(plugin)])  # stable
    if edit == "plugin constant":
        plugin.write_text(plugin.read_text().replace("BONUS = 10", "BONUS = 11"))
    else:
        (tmp_path / f"faults_helper_{tag}.py").write_text(HELPER.format(scale=2))
    assert digests.code_digest([str(plugin)]) != before
    assert digests.code_digest([]) not in (before, digests.code_digest([str(plugin)]))


def test_installed_and_package_modules_are_not_plugin_sources():
    import numpy

    from tableclean_suite.bench import plugins
    from tableclean_suite.task import model

    assert not plugins._is_user_file(numpy.__file__) and not plugins._is_user_file(model.__file__)
    assert not plugins._is_user_file(os.__file__) and plugins._is_user_file(__file__)


@pytest.mark.cli
def test_editing_a_plugin_retrains_its_cells_into_the_same_out(tmp_path):
    plugin = _write_plugin(tmp_path, "cli", bonus=10, scale=1)
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(tmp_path), str(ROOT),
                                                                      os.environ.get("PYTHONPATH")]))}

    def run():
        result = subprocess.run(
            [sys.executable, "-m", "benchmarks.run", "--plugins", str(plugin), "--rewards", "faults_cli",
             "--learners", "q_learning", "--runs", "10", "--iterations", "200", "--no-sweeps", "--no-literature",
             "--no-figures", "--no-progress", "--out", str(out)],
            cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
        assert result.returncode == 0, result.stderr
        return next(line for line in result.stdout.splitlines() if line.startswith("cells:"))

    assert "trained 1" in run()
    assert "resumed 1 cells" in run()
    (tmp_path / "faults_helper_cli.py").write_text(HELPER.format(scale=3))  # only the helper changes
    assert "resumed 0 cells" in run()


def test_a_run_hashes_the_code_once_not_per_cell(tmp_path, monkeypatch):
    from tableclean_suite.bench import digests, experiments
    from tableclean_suite.bench.config import RunConfig
    from tableclean_suite.task import TaskModel

    monkeypatch.syspath_prepend(str(tmp_path))
    plugin = _write_plugin(tmp_path, "once", bonus=10, scale=1)
    calls = []
    digest = digests.code_digest
    monkeypatch.setattr(digests, "code_digest", lambda entries: calls.append(entries) or digest(entries))
    config = RunConfig(runs=2, iterations=20, learners=("q_learning", "sarsa"), rewards=("r1", "r2"), sweeps=False,
                       literature=False, plugins=(str(plugin),))
    grid, store = experiments.config_grid(config), experiments.CellStore(tmp_path / "cells")
    outcome = experiments.run_grid(grid, config, TaskModel(), store)
    assert outcome.trained == 4 and len(calls) == 1
    stored = experiments.run_grid(grid, config, TaskModel(), store)
    assert stored.resumed == 4 and len(calls) == 2  # the same key: once per run
