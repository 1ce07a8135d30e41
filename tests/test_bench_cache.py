"""The cell cache never serves numbers computed by other code."""

import os
import subprocess
import sys
from pathlib import Path

import pandas as pd

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
