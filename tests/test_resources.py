"""The resource guard: estimates before allocating, one-line refusals naming estimate and availability,
an explicit override, and vectorised table builds so large accepted specs build in seconds."""

import numpy as np
import pytest

from tableclean_suite import resources
from tableclean_suite.learners import memory
from tableclean_suite.bench import experiments
from tableclean_suite.bench.config import RunConfig
from tableclean_suite.learners import train
from tableclean_suite.task import ActionRule, Outcome, TaskModel, TaskSpec, register_action
from tableclean_suite.task.model import TaskModel as ModelClass
from tableclean_suite.task.state import HELD, TaskState, encode

GIB = 1024**3


def _move_back(state):
    return state.replace(arm=(state.arm - 1) % state.n_segments), Outcome.ROUTINE


def _user_action() -> str:
    name = "faults_move_back"
    register_action(ActionRule(name, _move_back, "test action"), overwrite=True)
    return name


def _rule(state: TaskState, name: str):
    """The model's rules for one state, written from its docstring: the oracle of the vectorised build."""
    here = [j for j, where in enumerate(state.objects) if where == state.arm]
    if name == "move":
        return state.replace(arm=(state.arm + 1) % state.n_segments), Outcome.ROUTINE
    if name == "pick":
        if state.holding or not here:
            return state, Outcome.INEFFECTIVE
        return state.with_object(here[0], HELD), Outcome.ROUTINE
    if name == "place":
        if not state.holding:
            return state, Outcome.INEFFECTIVE
        return state.with_object(state.objects.index(HELD), state.arm), Outcome.ROUTINE
    if state.holding or here:
        return state, Outcome.IMPROPER
    if state.clean[state.arm]:
        return state, Outcome.IRRELEVANT_CLEAN
    clean = list(state.clean)
    clean[state.arm] = True
    return state.replace(clean=tuple(clean)), Outcome.RELEVANT_CLEAN


def _rules_state_by_state(model: TaskModel):
    """``(next_state, outcome)`` of every code and action, state by state (built-ins by `_rule`, user
    actions through ``model.step``), with the model's ineffective and terminal conventions."""
    next_state = np.zeros((model.n_states, model.n_actions), dtype=np.int64)
    outcome = np.zeros((model.n_states, model.n_actions), dtype=np.int64)
    for code in range(model.n_states):
        state = model.decode(code)
        for a, name in enumerate(model.action_names):
            if state.is_terminal:
                nxt, out = state, Outcome.TERMINAL
            elif name in ("move", "pick", "place", "clean"):
                nxt, out = _rule(state, name)
                if out == Outcome.INEFFECTIVE and model.ineffective.value == "improper":
                    out = Outcome.IMPROPER
                out = Outcome.TERMINAL if nxt.is_terminal else out
            else:
                nxt, out = model.step(state, a)
            next_state[code, a], outcome[code, a] = encode(nxt), out
    return next_state, outcome


SPECS = [
    dict(segments=2, objects=1),
    dict(segments=3, objects=2),
    dict(segments=4, objects=3),
    dict(segments=3, objects=2, ineffective="improper"),
    dict(segments=5, objects=2, actions=("clean", "place", "move", "pick")),
    dict(segments=3, objects=1, start="uniform_unclean"),
]


@pytest.mark.parametrize("fields", SPECS, ids=lambda f: "-".join(f"{k}{v}" for k, v in f.items()))
def test_vectorised_table_equals_the_rules_state_by_state(fields):
    model = TaskModel(spec=TaskSpec("faults_spec", **fields))
    fast, slow = model.transition_arrays(), _rules_state_by_state(model)
    assert all(np.array_equal(a, b) for a, b in zip(fast, slow))


def test_a_spec_with_a_user_action_mixes_both_builds_and_matches_the_rules():
    spec = TaskSpec("faults_user", segments=3, objects=2, actions=("move", _user_action(), "pick", "place", "clean"))
    model = TaskModel(spec=spec)
    fast, slow = model.transition_arrays(), _rules_state_by_state(model)
    assert all(np.array_equal(a, b) for a, b in zip(fast, slow))


def test_built_in_actions_never_step_state_by_state(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("the per-state rules were called")

    model = TaskModel(spec=TaskSpec("faults_wide", segments=9, objects=2))  # 460800 codes
    monkeypatch.setattr(ModelClass, "step", refuse)
    next_state, outcome = model.transition_arrays()
    assert next_state.shape == (model.n_states, 4) and (outcome == Outcome.TERMINAL).any()


def test_a_large_spec_with_a_user_action_is_refused_before_its_loop():
    spec = TaskSpec("faults_user_big", segments=10, objects=2, actions=("move", _user_action(), "clean"))
    with pytest.raises(resources.TooMuchWorkError, match=f"{resources.MAX_USER_EFFECT_CALLS}.*{resources.OVERRIDE_ENV}"):
        TaskModel(spec=spec).transition_arrays()


def test_require_memory_names_the_estimate_what_is_available_and_the_override(monkeypatch):
    monkeypatch.delenv(resources.OVERRIDE_ENV, raising=False)
    estimate = resources.MemoryEstimate({"Q-tables": 3 * GIB, "records": GIB})
    with pytest.raises(resources.InsufficientMemoryError) as caught:
        resources.require_memory(estimate, "the test allocation", available=2 * GIB)
    message = str(caught.value)
    assert "4.0 GiB" in message and "Q-tables 3.0 GiB" in message and "2.0 GiB" in message
    assert resources.OVERRIDE_ENV in message and "\n" not in message
    resources.require_memory(estimate, "fits", available=10 * GIB)
    monkeypatch.setenv(resources.OVERRIDE_ENV, "1")
    resources.require_memory(estimate, "overridden by the environment", available=GIB)


def test_require_time_refuses_beyond_the_limit(monkeypatch):
    monkeypatch.delenv(resources.OVERRIDE_ENV, raising=False)
    resources.require_time(resources.MAX_TRAINING_SECONDS, "at the limit")
    with pytest.raises(resources.TooMuchWorkError, match="days"):
        resources.require_time(resources.MAX_TRAINING_SECONDS * 3, "beyond it")


@pytest.mark.parametrize("budget", [dict(runs=10**7, iterations=10**8), dict(runs=10**5, iterations=10**6)])
def test_train_refuses_a_budget_whose_records_cannot_fit(monkeypatch, budget):
    monkeypatch.delenv(resources.OVERRIDE_ENV, raising=False)
    monkeypatch.setattr(resources, "available_bytes", lambda: 16 * GIB)
    with pytest.raises(resources.InsufficientMemoryError, match="records .*16.0 GiB"):
        train(**budget)


def test_train_refuses_a_spec_whose_q_tables_cannot_fit(monkeypatch):
    monkeypatch.delenv(resources.OVERRIDE_ENV, raising=False)
    monkeypatch.setattr(resources, "available_bytes", lambda: 16 * GIB)
    spec = TaskSpec("faults_many", segments=12, objects=2)  # 8.3 M codes: 266 MB per Q-table
    with pytest.raises(resources.InsufficientMemoryError, match="Q-tables"):
        train(task=spec, runs=100, iterations=10)


def test_the_chunk_counts_the_q_tables_too():
    assert experiments.chunk_runs(1000) == experiments.CHUNK_BYTES // (1000 * experiments.RECORD_BYTES_PER_ITERATION)
    assert experiments.chunk_runs(1000, q_table_bytes=experiments.CHUNK_BYTES) == 1
    assert experiments.chunk_runs(1000, q_table_bytes=10**6) < experiments.chunk_runs(1000)


@pytest.mark.parametrize("case", ["22 segments", "huge budget"])
def test_a_grid_is_refused_before_any_cell_trains(monkeypatch, case):
    monkeypatch.delenv(resources.OVERRIDE_ENV, raising=False)
    if case == "22 segments":
        config = RunConfig(task=None, out="unused")
        model = TaskModel(spec=TaskSpec("faults_huge", segments=22, objects=1))
        error = resources.InsufficientMemoryError
    else:
        config = RunConfig(runs=10**7, iterations=10**8, out="unused")
        model = config.task_model()
        error = resources.TooMuchWorkError
    cells = experiments.unique_cells(experiments.config_grid(config))
    with pytest.raises(error):
        experiments.check_grid_resources(experiments.CellRun(c, config, model) for c in cells)


def test_the_paper_default_grid_passes_the_guard():
    config = RunConfig(out="unused")
    model = config.task_model()
    cells = experiments.unique_cells(experiments.config_grid(config))
    assert 0 < experiments.check_grid_resources(experiments.CellRun(c, config, model) for c in cells) < experiments.LONG_GRID_SECONDS


def test_per_state_python_walks_of_a_huge_spec_are_refused_at_once(monkeypatch):
    monkeypatch.delenv(resources.OVERRIDE_ENV, raising=False)
    model = TaskModel(spec=TaskSpec("faults_walk", segments=12, objects=2))
    for walk in (model.reachable_states, model.all_states, model.shortest_plan_lengths):
        with pytest.raises(resources.TooMuchWorkError, match="state by state"):
            walk()
    small = TaskModel(spec=TaskSpec("faults_small", segments=3, objects=2))
    assert len(small.reachable_states()) == 327  # the documented count, unaffected


# -- the estimates count what training really allocates ----------------------------------------------
MEASURED_MODEL = TaskModel(spec=TaskSpec("faults_measured", segments=6, objects=2))  # 18816 codes x 4 actions
#: How far above the traced peak an estimate may be: the compiled loop's arrays are counted exactly
#: (the slack is the table build); the reference loop's Python tables are counted for a fully learned table.
ESTIMATE_FACTOR = {"compiled": 1.5, "reference": 2.5}


@pytest.mark.parametrize("learner, checkpoint, engine, runs", [
    ("q_learning", 0, "compiled", 16), ("q_learning", 150, "compiled", 16),
    ("double_q_learning", 0, "compiled", 16), ("double_q_learning", 150, "compiled", 16),
    ("dyna_q", 0, "compiled", 16), ("q_lambda", 150, "compiled", 16),
    ("q_learning", 150, "reference", 2), ("double_q_learning", 150, "reference", 2),
])
def test_the_memory_estimate_covers_the_traced_peak_of_training(learner, checkpoint, engine, runs):
    """tracemalloc sees numpy's and the compiled loop's (numba's runtime) allocations alike."""
    import tracemalloc

    from tableclean_suite.learners import get_learner

    iterations = 200
    train(learner=learner, task=MEASURED_MODEL, runs=1, iterations=10)  # compiled and the tables built outside the trace
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        result = train(learner=learner, task=MEASURED_MODEL, runs=runs, iterations=iterations, checkpoint=checkpoint,
                       engine=engine)
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    del result
    estimate = memory.learner_training_memory(MEASURED_MODEL, get_learner(learner), runs,
                                                 iterations, checkpoint=checkpoint > 0, engine=engine)
    assert peak <= estimate.total <= ESTIMATE_FACTOR[engine] * peak, (peak, estimate.describe())


def test_double_q_and_checkpoints_count_every_table_they_keep():
    assert [resources.q_table_copies(1), resources.q_table_copies(1, checkpoint=True)] == [1, 2]
    assert [resources.q_table_copies(2), resources.q_table_copies(2, checkpoint=True)] == [5, 8]


@pytest.mark.parametrize("learner", ["q_lambda", "dyna_q", "learned_affordance_q_learning", "q_learning"])
def test_the_run_working_memory_covers_the_compiled_loops_per_run_arrays(learner):
    from tableclean_suite.learners import get_learner
    from tableclean_suite.learners.assist import AFFORD_LEARNED
    from tableclean_suite.learners.kernel import run_memory
    from tableclean_suite.learners.rules import METHOD_DOUBLE_Q, METHOD_DYNA, METHOD_TRACES

    chosen = get_learner(learner)
    s, a = 50, 4
    arrays = run_memory(s, a, chosen.method == METHOD_DOUBLE_Q, chosen.method == METHOD_TRACES, False,
                        chosen.method == METHOD_DYNA)
    masks = s * a if chosen.affordance_code == AFFORD_LEARNED else 0
    actual = sum(x.nbytes for x in arrays) + masks
    assert actual - a * resources.WORD_BYTES <= memory.run_working_bytes(chosen, s, a) <= actual


def _job(engine: str, runs: int, iterations: int):
    from tableclean_suite.backends import TrainingJob
    from tableclean_suite.learners import get_learner
    from tableclean_suite.rewards import get_reward_pattern

    return TrainingJob(learner=get_learner("q_learning"), reward=get_reward_pattern("r4"), model=TaskModel(),
                       runs=runs, iterations=iterations, alpha=0.3, gamma=0.3, epsilon=0.1, max_itr=500, seed=0,
                       engine=engine)


def test_the_time_guard_uses_the_engines_own_rate(monkeypatch):
    from tableclean_suite.backends.tabular import check_job_resources

    monkeypatch.delenv(resources.OVERRIDE_ENV, raising=False)
    monkeypatch.setattr(resources, "available_bytes", lambda: 2**62)  # only the time guard decides
    steps = 2 * resources.MAX_TRAINING_SECONDS * resources.REFERENCE_STEPS_PER_SECOND  # 2 days in Python, minutes compiled
    runs = 10**4
    check_job_resources(_job("compiled", runs, steps // runs), measured=False)
    with pytest.raises(resources.TooMuchWorkError, match="reference engine"):
        check_job_resources(_job("reference", runs, steps // runs), measured=False)
    assert resources.steps_per_second("reference") < resources.steps_per_second("compiled")
    with pytest.raises(ValueError, match="unknown engine 'fast'.*compiled, reference"):
        resources.steps_per_second("fast")


def test_the_grid_estimate_counts_double_q_and_the_settling_snapshots(monkeypatch):
    seen = []
    monkeypatch.setattr(resources, "require_memory", lambda estimate, what: seen.append(estimate.parts["Q-tables"]))
    model = TaskModel()
    for learners, backend in ((("q_learning",), "physics"), (("q_learning",), "symbolic"),
                              (("q_learning", "double_q_learning"), "symbolic")):
        config = RunConfig(learners=learners, rewards=("r4",), out="unused", backend=backend)
        experiments.check_grid_resources(experiments.CellRun(c, config, model) for c in experiments.unique_cells(experiments.config_grid(config)))
    plain, settling, double = seen
    assert settling == 2 * plain and double == 8 * plain  # the checkpoint copy; double Q's 5 tables and 3 snapshots


def _grid_plans(backend: str, analysis: str = "auto"):
    """(estimated seconds, the cells' analysis plans) of a two-learner grid on the paper task."""
    config = RunConfig(learners=("q_learning", "double_q_learning"), rewards=("r4",), runs=500, iterations=4000,
                       out="unused", backend=backend, analysis=analysis, sweeps=False, literature=False)
    model = TaskModel()
    cells = experiments.unique_cells(experiments.config_grid(config))
    return (experiments.check_grid_resources(experiments.CellRun(c, config, model) for c in cells),
            [experiments.CellRun(cell, config, model).plan for cell in cells])


def test_the_grid_time_counts_training_once_and_each_cells_planned_analysis(monkeypatch):
    """Settling (symbolic) keeps the checkpoint's Q-tables in the same training pass as without it
    (physics): the same training estimate; only the checkpoint's asymptote analysis is extra.  A
    forced simulation is costed as a simulation."""
    monkeypatch.delenv(resources.OVERRIDE_ENV, raising=False)
    (settling, checked), (plain, unchecked) = _grid_plans("symbolic"), _grid_plans("physics")
    assert [p.training_seconds for p in checked] == [p.training_seconds for p in unchecked]
    q_learning = checked[0].training_seconds
    assert q_learning == pytest.approx(500 * 4000 / resources.steps_per_second(resources.DEFAULT_ENGINE)
                                       + 500 * TaskModel().n_states * 4 / resources.TABLE_ENTRIES_PER_SECOND)
    assert checked[1].training_seconds > q_learning  # double Q-learning's second table
    assert all(p.kind == "exact" and p.exact_seconds > u.exact_seconds for p, u in zip(checked, unchecked))
    assert settling - plain == pytest.approx(sum(p.exact_seconds - u.exact_seconds
                                                 for p, u in zip(checked, unchecked)))
    simulated, plans = _grid_plans("symbolic", "simulated")
    assert [p.kind for p in plans] == ["simulated"] * 2
    assert simulated == pytest.approx(sum(p.training_seconds + p.simulated_seconds for p in plans))
    assert simulated != pytest.approx(settling)


@pytest.mark.parametrize("terms", [[(2, 10**30), (10**30 + 1, 1), (10**30, 1)],  # segments of 10**30
                                   [(2, 3), (4, 2 * 10**8), (3, 1)],  # objects of 2 x 10**8
                                   [(2, 10**400)],  # an exponent too large for a float
                                   [(2, 31)], [(3, 20), (2, 1)]])
def test_bounded_product_refuses_huge_sizes_without_computing_them(terms):
    """Sizes that grow with a spec are decided on logarithms: no power of a huge exponent is formed
    (each of these would hang or exhaust memory if it were)."""
    import time

    started = time.perf_counter()
    assert resources.bounded_product(terms, 2**31 - 1) is None
    assert time.perf_counter() - started < 0.1


def test_bounded_product_is_exact_up_to_the_limit():
    assert resources.bounded_product([(2, 3), (4, 2), (3, 1)], 10**6) == 8 * 16 * 3
    assert resources.bounded_product([(2, 30)], 2**30) == 2**30  # at the limit
    assert resources.bounded_product([(2, 30)], 2**30 - 1) is None  # one past it, within the log margin
    assert resources.bounded_product([(2, 0), (1, 10**100), (7, 1)], 7) == 7  # trivial terms cost nothing
    assert resources.bounded_product([(0, 10**100), (2, 10**100)], 5) == 0
    with pytest.raises(ValueError, match=r"non-negative.*2\*\*-1"):
        resources.bounded_product([(2, -1)], 5)


def test_the_training_estimate_counts_dyna_planning_and_each_runs_setup(monkeypatch):
    """Dyna-Q's planning updates cost about a step each: 10 000 of them per step make a budget that
    trains in minutes without planning take days, and the refusal says so before any work."""
    monkeypatch.delenv(resources.OVERRIDE_ENV, raising=False)
    rate = resources.steps_per_second(resources.DEFAULT_ENGINE)
    plain = resources.training_seconds(1000, 10**6, 24, 4)
    assert plain == pytest.approx(10**9 / rate + 1000 * 96 / resources.TABLE_ENTRIES_PER_SECOND)
    planned = resources.training_seconds(1000, 10**6, 24, 4, planning_steps=10_000)
    assert planned == pytest.approx(10**9 * 10_001 / rate + 1000 * 96 / resources.TABLE_ENTRIES_PER_SECOND)
    assert plain < resources.MAX_TRAINING_SECONDS < planned
    assert resources.require_training_time(1000, 10**6, 24, 4, "plain") == pytest.approx(plain)
    with pytest.raises(resources.TooMuchWorkError, match=r"about \d+\.\d days .*10000 planning updates per step"):
        resources.require_training_time(1000, 10**6, 24, 4, "dyna", planning_steps=10_000)
    # a large table's setup counts even for a short budget; double Q-learning's two tables twice
    setup = resources.training_seconds(20, 1, 3_244_032, 4) - 20 / rate
    assert setup == pytest.approx(20 * 3_244_032 * 4 / resources.TABLE_ENTRIES_PER_SECOND)
    assert resources.training_seconds(20, 1, 3_244_032, 4, q_tables=2) - 20 / rate == pytest.approx(2 * setup)
    with pytest.raises(resources.TooMuchWorkError, match=r"asymptotes about"):
        resources.require_training_time(1, 1, 24, 4, "with an analysis", extra_seconds=3 * 86400,
                                        extra_detail="asymptotes about 3 days")


def test_format_seconds_keeps_short_times_readable():
    assert resources.format_seconds(0.25) == "0.25 s"
    assert resources.format_seconds(1.3) == "1.3 s"
    assert resources.format_seconds(17.4) == "17 s"
    assert resources.format_seconds(9720) == "2.7 hours"
    assert resources.format_seconds(3 * 86400) == "3.0 days"
