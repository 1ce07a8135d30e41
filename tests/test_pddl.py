"""Task specs as PDDL: the export parses, classical planners' plans equal the model's, problems read back."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tableclean_suite.task import ActionRule, HELD, Outcome, TaskModel, TaskSpec, TaskState, register_action
from tableclean_suite.task.spec import BUILTIN_SPECS
from tableclean_suite.task.pddl import FORMS, PDDLError, domain_pddl, problem_pddl, read_problem, start_problems

BUILTIN = [spec.name for spec in BUILTIN_SPECS]
EXAMPLE = Path(__file__).resolve().parents[1] / "docs" / "pddl" / "box_and_cylinder.pddl"
MOVE_BACK_PDDL = """(:action pddl_test_move_back :parameters (?from ?to - segment)
    :precondition (and (arm-at ?from) (next ?to ?from))
    :effect (and (not (arm-at ?from)) (arm-at ?to)))"""
#: A wrong schema: going back also wipes (the model's action only moves the arm).
WIPE_BACK_PDDL = """(:action pddl_test_wipe_back :parameters (?from ?to - segment)
    :precondition (and (arm-at ?from) (next ?to ?from)) :effect (and (not (arm-at ?from)) (arm-at ?to) (wiped ?to)))"""


def _move_back(state):
    return state.replace(arm=(state.arm - 1) % state.n_segments), Outcome.ROUTINE


def _planners_or_skip(*planners):
    pytest.importorskip("unified_planning")
    from tableclean_suite.bench import pddl_check

    try:
        pddl_check.engines(planners)
    except RuntimeError as error:
        pytest.skip(str(error))
    return pddl_check


def _check(spec, planner="pyperplan", sample=None, seed=0):
    """The failures of solving ``spec`` from its reachable states (or a sample) and the rows' frame."""
    pddl_check = _planners_or_skip(planner)
    model = TaskModel(spec=spec)
    states = pddl_check.check_states(model, sample, seed)
    frame = pddl_check.solve(model, planner, states)
    return pddl_check.failures(model.spec.name, planner, frame), frame


# ---------------------------------------------------------------------------------------------
# export
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def parsers():
    """The ``pddl`` package's domain and problem parsers (building one takes a second)."""
    pytest.importorskip("pddl")
    from pddl.parser.domain import DomainParser
    from pddl.parser.problem import ProblemParser

    return DomainParser(), ProblemParser()


@pytest.mark.parametrize("form", FORMS)
@pytest.mark.parametrize("name", BUILTIN)
def test_every_builtin_spec_exports_pddl_the_pddl_package_parses(name, form, parsers):
    spec = TaskModel(spec=name).spec
    domain = parsers[0](domain_pddl(spec, form))
    assert sorted(a.name for a in domain.actions) == sorted(spec.actions)
    problem = parsers[1](problem_pddl(spec, None, form))
    assert problem.domain_name == domain.name
    assert len(problem.goal.operands) == spec.segments


def test_a_uniform_start_is_one_problem_per_layout():
    spec = TaskSpec("uniform", segments=3, objects=2, start="uniform_unclean")
    problems = start_problems(spec, "adl")
    assert len(problems) == 3**2 * 3
    for name, text in problems.items():
        assert read_problem(text).start_state in TaskModel(spec=spec).unclean_layouts()


def test_a_user_action_without_pddl_is_refused_by_name():
    register_action(ActionRule("pddl_test_no_schema", _move_back), overwrite=True)
    spec = TaskSpec("no_schema", segments=3, actions=("move", "pddl_test_no_schema", "pick", "place", "clean"))
    with pytest.raises(ValueError, match="action 'pddl_test_no_schema' has no PDDL"):
        domain_pddl(spec)
    register_action(ActionRule("pddl_test_misnamed", _move_back, pddl=MOVE_BACK_PDDL), overwrite=True)
    with pytest.raises(ValueError, match=r"'\(:action pddl_test_misnamed \.\.\.\)'"):
        domain_pddl(spec.replace(actions=("move", "pddl_test_misnamed")))
    with pytest.raises(ValueError, match="pddl must be a schema string"):
        ActionRule("bad", _move_back, pddl={"strips": MOVE_BACK_PDDL})


# ---------------------------------------------------------------------------------------------
# planners
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["paper", "two_objects"])
def test_pyperplan_plans_equal_the_models_from_every_reachable_state(name):
    failed, frame = _check(name)
    assert not failed
    assert len(frame) == len([s for s in TaskModel(spec=name).reachable_states() if not s.is_terminal])
    assert frame["replay_terminal"].all() and (frame["length"] == frame["optimum"]).all()


@pytest.mark.slow
def test_pyperplan_plans_equal_the_models_on_a_sample_of_a_larger_spec():
    failed, frame = _check("three_segments_two_objects", sample=40, seed=3)
    assert not failed and len(frame) == 40 and frame["replay_terminal"].all()


def test_a_user_actions_pddl_is_checked_and_a_wrong_one_fails_naming_the_state():
    register_action(ActionRule("pddl_test_move_back", _move_back, pddl=MOVE_BACK_PDDL), overwrite=True)
    spec = TaskSpec("back", segments=3, actions=("move", "pddl_test_move_back", "pick", "place", "clean"))
    failed, frame = _check(spec, sample=12, seed=1)
    assert not failed and len(frame) == 12
    assert frame["optimum"].min() < TaskModel(spec="three_segments").distances_to_terminal().max()
    register_action(ActionRule("pddl_test_wipe_back", _move_back, pddl=WIPE_BACK_PDDL), overwrite=True)
    jump = spec.replace(name="jump", actions=("move", "pddl_test_wipe_back", "pick", "place", "clean"))
    failed, _ = _check(jump, sample=12, seed=1)
    assert failed and all(line.startswith("jump, pyperplan, state ") for line in failed)


def test_the_adl_form_has_the_same_shortest_plans():
    """The ADL form, its quantifiers and negations compiled away by unified-planning, solved by pyperplan."""
    pddl_check = _planners_or_skip("pyperplan")
    from unified_planning.engines import CompilationKind
    from unified_planning.io import PDDLReader
    from unified_planning.shortcuts import Compiler, OneshotPlanner

    model = TaskModel(spec="three_segments_two_objects")
    domain = domain_pddl(model.spec, "adl")
    for state in pddl_check.check_states(model, 4, seed=2):
        problem = PDDLReader().parse_problem_string(domain, problem_pddl(model.spec, state, "adl"))
        for kind in (CompilationKind.QUANTIFIERS_REMOVING, CompilationKind.NEGATIVE_CONDITIONS_REMOVING):
            with Compiler(problem_kind=problem.kind, compilation_kind=kind) as compiler:
                problem = compiler.compile(problem).problem
        with OneshotPlanner(name="pyperplan-opt") as planner:
            plan = [a.action.name for a in planner.solve(problem).plan.actions]
        assert len(plan) == len(model.shortest_plan(state)) and pddl_check.replay(model, state, plan)


@pytest.mark.cli
def test_fast_downward_plans_equal_the_models():
    failed, frame = _check("paper", planner="fast-downward")
    assert not failed and len(frame) == 18


def test_the_replay_refuses_a_plan_that_stops_short_or_acts_improperly():
    from tableclean_suite.bench.pddl_check import replay

    model = TaskModel()
    plan = [a.rule_name for a in model.shortest_plan(model.start_state)]
    assert replay(model, model.start_state, plan)
    assert not replay(model, model.start_state, plan[:-1])
    assert not replay(model, model.start_state, ["clean"] + plan)  # improper: the object lies there


# ---------------------------------------------------------------------------------------------
# command line
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("argv, message", [
    (["--planners", "lpg"], "unknown planner 'lpg'; allowed: pyperplan, fast-downward"),
    (["--states", "0"], "expected 'all' or a positive integer, got '0'"),
    (["--task", "nope"], "unknown task spec 'nope'"),
])
def test_bad_flags_exit_2_with_one_line(argv, message, capsys):
    from tableclean_suite.bench.commands import main

    assert main(["pddl", *argv]) == 2
    error = capsys.readouterr().err
    assert message in error and len(error.strip().splitlines()) == 1


def test_missing_planners_name_the_extra(monkeypatch, capsys):
    import sys

    from tableclean_suite.bench.commands import main

    monkeypatch.setitem(sys.modules, "unified_planning.shortcuts", None)
    assert main(["pddl", "--task", "paper"]) == 2
    assert 'pip install -e ".[planning]"' in capsys.readouterr().err


def test_the_command_writes_its_table_and_fails_naming_a_wrong_state(tmp_path, capsys):
    _planners_or_skip("pyperplan")
    from tableclean_suite.bench.commands import main

    assert main(["pddl", "--task", "paper", "--planners", "pyperplan", "--out", str(tmp_path)]) == 0
    assert "| paper | 18 | pyperplan | 18 | 18 | 18 |" in capsys.readouterr().out
    assert (tmp_path / "pddl_check.csv").exists() and (tmp_path / "paper" / "domain-adl.pddl").exists()
    register_action(ActionRule("pddl_test_wipe_back", _move_back, pddl=WIPE_BACK_PDDL), overwrite=True)
    spec = tmp_path / "jump.json"
    TaskSpec("jump", segments=3, actions=("move", "pddl_test_wipe_back", "pick", "place", "clean")).to_json(spec)
    assert main(["pddl", "--task", str(spec), "--planners", "pyperplan", "--states", "5"]) == 1
    assert "FAIL jump, pyperplan, state " in capsys.readouterr().err
    register_action(ActionRule("pddl_test_no_schema", _move_back), overwrite=True)
    TaskSpec("bare", segments=3, actions=("move", "pddl_test_no_schema")).to_json(spec)
    assert main(["pddl", "--task", str(spec), "--planners", "pyperplan"]) == 2
    error = capsys.readouterr().err
    assert "action 'pddl_test_no_schema' has no PDDL" in error and len(error.strip().splitlines()) == 1


# ---------------------------------------------------------------------------------------------
# read back
# ---------------------------------------------------------------------------------------------
U3 = (False, False, False)


@pytest.mark.parametrize("state", [TaskState(U3, (0, 0), 0), TaskState((True, False, True), (HELD, 2), 1),
                                   TaskState((False, True, False), (1, 1), 2)])
def test_an_exported_problem_reads_back_as_the_same_task(state):
    spec = TaskSpec("three_segments_two_objects", segments=3, objects=("box", "cylinder"), start_state=state)
    back = read_problem(problem_pddl(spec, state, "adl"))
    assert back == spec


BROKEN = {
    "unclosed": ("(define (problem p) (:domain tableclean)\n(:objects s1 s2 - segment o - box)", 1, "never closed"),
    "domain": ("(define (problem p) (:domain other)\n(:objects s1 s2 - segment o - box)\n(:init (arm-at s1) "
               "(on o s1) (next s1 s2) (next s2 s1))\n(:goal (and (wiped s1) (wiped s2))))", 1, "must be 'tableclean'"),
    "untyped": ("(define (problem p) (:domain tableclean)\n(:objects s1 s2 - segment o)\n(:init)\n(:goal (and)))", 2,
                "o has no type"),
    "predicate": ("(define (problem p) (:domain tableclean)\n(:objects s1 s2 - segment o - box)\n(:init (arm-at s1)\n"
                  "(dirty s1))\n(:goal (and (wiped s1) (wiped s2))))", 4, r"unsupported fact \(dirty s1\)"),
    "two_places": ("(define (problem p) (:domain tableclean)\n(:objects s1 s2 - segment o - box)\n(:init (arm-at s1)\n"
                   "(on o s1)\n(holding o))\n(:goal (and (wiped s1) (wiped s2))))", 5, "o is already placed"),
    "ring": ("(define (problem p) (:domain tableclean)\n(:objects s1 s2 s3 - segment o - box)\n(:init (arm-at s1)\n"
             "(on o s1) (next s1 s3))\n(:goal (and (wiped s1) (wiped s2) (wiped s3))))", 4, "around the ring"),
    "missing_next": ("(define (problem p) (:domain tableclean)\n(:objects s1 s2 - segment o - box)\n(:init (arm-at s1)"
                     " (on o s1) (next s1 s2))\n(:goal (and (wiped s1) (wiped s2))))", 3, r"missing \(next s2 s1\)"),
    "goal": ("(define (problem p) (:domain tableclean)\n(:objects s1 s2 - segment o - box)\n(:init (arm-at s1) (on o s1)"
             " (next s1 s2) (next s2 s1))\n(:goal (wiped s1)))", 4, "every segment wiped"),
    "done": ("(define (problem p) (:domain tableclean)\n(:objects s1 s2 - segment o - box)\n(:init (arm-at s1) (on o s1)"
             " (next s1 s2) (next s2 s1) (wiped s1) (wiped s2))\n(:goal (and (wiped s1) (wiped s2))))", 3,
             "already wiped"),
    "wrong_type": ("(define (problem p) (:domain tableclean)\n(:objects s1 s2 - segment o - box)\n(:init (arm-at o))\n"
                   "(:goal (and (wiped s1) (wiped s2))))", 3, r"must be \(arm-at segment\)"),
}


@pytest.mark.parametrize("case", list(BROKEN))
def test_malformed_problems_are_refused_naming_the_line_and_the_reason(case):
    text, line, reason = BROKEN[case]
    with pytest.raises(PDDLError, match=rf"^problem:{line}: .*{reason}"):
        read_problem(text)


def test_the_hand_written_problem_reads_back_and_trains_symbolically():
    from tableclean_suite.learners import train

    spec = read_problem(EXAMPLE)
    assert (spec.segments, spec.objects, spec.name) == (3, ("box", "cylinder"), "box_and_cylinder")
    assert spec.start_state == TaskState((True, False, False), (0, 1), 1)
    result = train("q_learning", "r4", runs=2, iterations=4000, seed=0, task=spec)
    assert result.q.shape == (2, spec.n_states, 4)
    assert (np.asarray(result.outcomes) == Outcome.TERMINAL).any()  # episodes from the problem's start end clean


@pytest.mark.slow
def test_the_hand_written_problems_optimal_plan_runs_in_physics():
    from tableclean_suite.controllers import SkillController, make_skill_env

    spec = read_problem(EXAMPLE)
    model = TaskModel(spec=spec)
    env = make_skill_env(task=spec, seed=0)
    try:
        env.reset()
        assert env.symbolic_state() == spec.start_state
        plan = model.shortest_plan(spec.start_state)
        results = SkillController(env, model).execute_plan(plan)
        assert all(r.success for r in results), [r.reason for r in results if not r.success]
        assert len(results) == len(plan) and results[-1].state_after.is_terminal
    finally:
        env.close()


def test_a_pddl_path_is_a_task_wherever_a_task_is_named(tmp_path):
    from tableclean_suite.task.spec import get_task_spec

    assert get_task_spec(str(EXAMPLE)) == read_problem(EXAMPLE)
    assert get_task_spec(Path(EXAMPLE)) == read_problem(EXAMPLE)
    with pytest.raises(PDDLError, match="cannot read the problem"):
        get_task_spec(str(tmp_path / "missing.pddl"))
