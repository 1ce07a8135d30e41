"""The first process's statistics kernels are compiled by a forked process beside the training loop."""

import pytest

from tableclean_suite.bench import experiments, precompile
from tableclean_suite.bench.config import RunConfig
from tableclean_suite.learners import kernel

pytestmark = pytest.mark.quick


def _grid():
    config = RunConfig(runs=50, iterations=300, rewards=("r2", "r4"), sweeps=False, progress=False)
    return experiments.unique_cells(experiments.config_grid(config)), config, config.task_model()


def test_the_statistics_are_compiled_without_the_training_loop(monkeypatch):
    cells, config, model = _grid()
    assert {cell.learner for cell in cells} >= {"q_learning", "sarsa", "affordance_q_learning"}

    def no_training_loop(*args, **kwargs):
        raise AssertionError("the training loop was called")

    monkeypatch.setattr(kernel, "train_batch", no_training_loop)
    precompile.compile_statistics(cells, config, model)  # every learner's tiny cell, then a comparison
    assert precompile.statistics_kernels_cached()  # what it compiled (or found) is in the disk cache


def test_nothing_is_forked_when_there_is_nothing_to_gain(monkeypatch):
    cells, config, model = _grid()
    monkeypatch.setattr(precompile, "statistics_kernels_cached", lambda: True)
    assert precompile.start(cells, config, model) is None
    monkeypatch.setattr(precompile, "statistics_kernels_cached", lambda: False)
    assert precompile.start([], config, model) is None
    physics = RunConfig(runs=50, iterations=300, backend="physics", progress=False)
    assert precompile.start(cells, physics, model) is None


def test_the_forked_process_compiles_and_is_reaped(monkeypatch):
    cells, config, model = _grid()
    monkeypatch.setattr(precompile, "statistics_kernels_cached", lambda: False)
    process = precompile.start(cells[:2], config, model)
    assert process is not None and process.pid > 0
    calls = []
    monkeypatch.setattr(precompile.os, "kill", lambda *args: calls.append(args))  # let it finish: no stop
    monkeypatch.setattr(precompile.os, "waitpid", _blocking_waitpid)
    assert process.finish() == 0 and not calls


def _blocking_waitpid(pid, options, _waitpid=precompile.os.waitpid):
    return _waitpid(pid, 0)
