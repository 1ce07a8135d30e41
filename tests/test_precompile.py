"""A first process's compile time: the statistics kernels are compiled by a forked process beside
the training loop, and the grid's learners train on the loop's one-step epsilon-greedy copy, whose
compile skips the other update rules' and explorations' functions."""

import inspect

import numba
import pytest
from numba.core import dispatcher as numba_dispatcher

from tableclean_suite.backends import tabular
from tableclean_suite.bench import experiments, precompile
from tableclean_suite.bench.config import RunConfig
from tableclean_suite.learners import assist, exploration, get_learner, kernel, rules
from tableclean_suite.learners.exploration import EPSILON_GREEDY_CODE, SOFTMAX_CODE
from tableclean_suite.learners.rules import METHOD_ONE_STEP, METHOD_TRACES
from tableclean_suite.learners.train import train


def _grid():
    config = RunConfig(runs=50, iterations=300, rewards=("r2", "r4"), sweeps=False, progress=False)
    return experiments.unique_cells(experiments.config_grid(config)), config, config.task_model()


def test_the_statistics_are_compiled_without_the_training_loop(monkeypatch):
    cells, config, model = _grid()
    assert {cell.learner for cell in cells} >= {"q_learning", "sarsa", "affordance_q_learning"}

    def no_training_loop(*args, **kwargs):
        raise AssertionError("the training loop was called")

    monkeypatch.setattr(kernel, "train_batch", no_training_loop)
    monkeypatch.setattr(kernel, "train_batch_general", no_training_loop)
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


#: The functions only the other update rules (traces, Dyna, double Q) and the softmax exploration call.
OTHER_RULES_CALLS = {kernel.clear_traces, kernel.is_exploratory, kernel.trace_update, kernel.remember, kernel.plan,
                     kernel.double_q_update, exploration.softmax_action, assist.afforded_softmax,
                     rules.softmax_expected_sarsa_target}


def test_the_grids_learners_train_on_the_one_step_copy_and_the_others_on_the_general_loop():
    cells, _, _ = _grid()
    assert {kernel.kernel_for(get_learner(cell.learner)) for cell in cells} == {kernel.train_batch}
    for name in ("q_lambda", "double_q_learning", "dyna_q"):
        assert kernel.kernel_for(get_learner(name)) is kernel.train_batch_general, name


def _loop_arguments(monkeypatch, learner="q_learning"):
    """The arguments the table backend passes to the training loop for ``learner`` (2 runs)."""
    captured = []
    monkeypatch.setattr(tabular, "run_in_threads", lambda loop, n_runs, arguments: captured.append(arguments))
    train(learner, "r4", runs=2, iterations=10)
    return (0, 2) + captured[0]


def _loop_position(name: str) -> int:
    """Position of the training loop's argument ``name`` (in the tuple :func:`_loop_arguments` returns)."""
    return list(inspect.signature(kernel._train_loop).parameters).index(name)


def test_the_one_step_copy_refuses_another_rule_or_exploration(monkeypatch):
    arguments = _loop_arguments(monkeypatch)
    method, explore_code = _loop_position("method"), _loop_position("explore_code")
    assert (arguments[method], arguments[explore_code]) == (METHOD_ONE_STEP, EPSILON_GREEDY_CODE)
    kernel.train_batch(*arguments)  # its own rule and exploration: trains
    for position, code in ((method, METHOD_TRACES), (explore_code, SOFTMAX_CODE)):
        wrong = list(arguments)
        wrong[position] = code
        with pytest.raises(ValueError, match="compiled for another update rule or exploration"):
            kernel.train_batch(*wrong)


@pytest.mark.parametrize("method, exploration", [(99, EPSILON_GREEDY_CODE), (METHOD_ONE_STEP, 99),
                                                 (kernel.FROM_ARGUMENTS, EPSILON_GREEDY_CODE)])
def test_a_copy_for_an_unknown_rule_or_exploration_is_refused_naming_the_allowed(method, exploration):
    with pytest.raises(ValueError, match=r"method .* and exploration .*: allowed a method of \[0, 1, 2, 3\]"):
        kernel.specialised_loop("bad_copy", method, exploration)


@pytest.mark.jit  # compiles copies of the training loops that no disk cache serves
@pytest.mark.parametrize("name", ["train_batch", "train_batch_general"])
def test_only_the_general_loop_compiles_the_other_rules_functions(monkeypatch, name):
    arguments = _loop_arguments(monkeypatch)
    loop = numba.njit(nogil=True, pipeline_class=kernel.NoAliasCompiler)(getattr(kernel, name).py_func)
    called = set()
    compile_ = numba_dispatcher.Dispatcher.compile

    def recording(self, signature):
        called.add(self)
        return compile_(self, signature)

    monkeypatch.setattr(numba_dispatcher.Dispatcher, "compile", recording)
    loop.compile(tuple(loop.typeof_pyval(argument) for argument in arguments))
    assert kernel.sample_index in called and rules.builtin_td_target in called
    if name == "train_batch":  # numba pruned those branches before typing: a first process never compiles them
        assert not called & OTHER_RULES_CALLS
    else:
        assert called >= OTHER_RULES_CALLS


#: Run in a fresh interpreter (no kernel loaded yet): the signatures each statistics kernel has
#: after the forked process's tiny cells, then those a longer cell of each learner (compiled loop)
#: and their comparison add.  Printed as JSON: {kernel: [after tiny, added by the longer cells]}.
_SIGNATURES_SCRIPT = """
import json
from dataclasses import replace
from tableclean_suite.bench import experiments, precompile, statistics
from tableclean_suite.bench.config import RunConfig

config = RunConfig(runs=50, iterations=300, rewards=("r2", "r4"), sweeps=False, progress=False)
model = config.task_model()
cells = experiments.unique_cells(experiments.config_grid(config))
precompile.compile_statistics(cells, config, model)
tiny = {kernel.py_func.__qualname__: set(map(str, kernel.signatures)) for kernel in precompile.statistics_kernels()}
first = {}
for cell in cells:
    first.setdefault(cell.learner, cell)
runs = None
for cell in first.values():
    runs = experiments.train_cell(cell, config, model)[1].runs
statistics.comparison_rows([{"learner": "x", "reward": "a", "runs": runs}, {"learner": "x", "reward": "b", "runs": runs}],
                           config.confidence, config.bootstrap_samples, config.seed)
print(json.dumps({kernel.py_func.__qualname__: [len(tiny[kernel.py_func.__qualname__]),
                  sorted(set(map(str, kernel.signatures)) - tiny[kernel.py_func.__qualname__])]
                  for kernel in precompile.statistics_kernels()}))
"""


@pytest.mark.slow  # a fresh interpreter (its dispatchers have loaded nothing yet)
def test_the_tiny_cells_reach_every_statistics_kernel_with_a_real_cells_types():
    """The forked process's tiny cells (few iterations, reference engine) give every statistics
    kernel all the signatures a longer cell (compiled loop) and a comparison need, so the run
    loads them instead of compiling them."""
    import json
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", _SIGNATURES_SCRIPT], capture_output=True, text=True, check=True)
    signatures = json.loads(done.stdout.strip().splitlines()[-1])
    assert len(signatures) == len(precompile.statistics_kernels())
    assert sum(after_tiny >= 1 for after_tiny, _ in signatures.values()) >= len(signatures) - 1  # (_retire: only
    for name, (after_tiny, added) in signatures.items():  # called from compiled code, no signature of its own)
        assert added == [], f"{name}: the longer cells need signatures the tiny cells did not compile: {added}"
