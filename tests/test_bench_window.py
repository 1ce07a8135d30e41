"""Table 3's iteration figures do not move with the training window (the plateau is an asymptote)."""

import pytest

from tableclean_suite.bench import experiments
from tableclean_suite.bench.config import RunConfig
from tableclean_suite.task import TaskModel

FIGURES = ("max_success_iterations", "reward_convergence_iterations")
#: Largest relative change allowed between the two windows.
TOLERANCE = 0.05


def _cell(reward, iterations):
    cell = experiments.Cell("q_learning", reward, 0.3, 0.3)
    config = RunConfig(runs=200, iterations=iterations, bootstrap_samples=20, seed=0)
    summary, *_ = experiments.train_cell(cell, config, TaskModel())
    return summary


@pytest.mark.parametrize("reward", ["r2", "r4"])
def test_iteration_figures_agree_between_a_window_and_one_three_times_longer(reward):
    short, long = _cell(reward, 1500), _cell(reward, 4500)
    for name in FIGURES:
        a, b = getattr(short, name), getattr(long, name)
        assert a is not None and b is not None, name
        assert abs(a - b) <= TOLERANCE * b, (name, a, b)
