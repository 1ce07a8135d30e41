"""Task specifications: the registry, JSON, encoding for any N and M, every rule on a
three-segment two-object task, reachability and plans, user actions."""

import json

import numpy as np
import pytest

from tableclean_suite.task import (
    HELD,
    ActionEffectError,
    ActionRule,
    Outcome,
    TaskModel,
    TaskSpec,
    TaskState,
    get_task_spec,
    load_task_spec,
    register_action,
    register_task_spec,
    state_count,
    task_spec_names,
)

REQUIRED_SPECS = ("paper", "three_segments", "two_objects", "three_segments_two_objects", "four_segments_two_objects")


def s3(clean, objects, arm):
    """A three-segment state from 1-based numbers: objects as segment numbers or 'held'."""
    return TaskState(tuple(clean), tuple(HELD if o == "held" else o - 1 for o in objects), arm - 1)


@pytest.fixture(scope="module")
def m32():
    return TaskModel(spec="three_segments_two_objects")


def test_registry_has_the_required_specs():
    assert set(REQUIRED_SPECS) <= set(task_spec_names())
    sizes = {name: (get_task_spec(name).segments, get_task_spec(name).n_objects) for name in REQUIRED_SPECS}
    assert sizes == {"paper": (2, 1), "three_segments": (3, 1), "two_objects": (2, 2),
                     "three_segments_two_objects": (3, 2), "four_segments_two_objects": (4, 2)}
    assert TaskModel().spec == get_task_spec("paper")


@pytest.mark.parametrize("name", REQUIRED_SPECS)
def test_encode_decode_round_trip_for_every_registered_spec(name):
    model = TaskModel(spec=name)
    assert model.n_states == state_count(model.n_segments, model.n_objects)
    for code in range(model.n_states):
        state = model.decode(code)
        assert state.index == code


def test_codes_with_two_held_objects_exist_but_are_never_reached():
    model = TaskModel(spec="two_objects")
    both_held = [s for s in model.all_states() if s.objects.count(HELD) == 2]
    assert len(both_held) == 2 ** 2 * 2  # clean flags x arm
    assert not set(both_held) & set(model.reachable_states())


@pytest.mark.parametrize("name,reachable,plan", [
    ("paper", 20, 8), ("three_segments", 90, 11), ("three_segments_two_objects", 327, 16)])
def test_reachable_counts_and_plan_lengths(name, reachable, plan):
    model = TaskModel(spec=name)
    assert len(model.reachable_states()) == reachable
    assert len(model.shortest_plan(model.start_state)) == plan
    assert model.shortest_plan_lengths([model.start_state]) == {model.start_state.index: plan}


def test_default_start_is_all_unclean_with_everything_on_segment_1(m32):
    assert m32.start_state == s3((False, False, False), (1, 1), 1)
    uniform = TaskModel(spec="three_segments_two_objects", start="uniform_unclean").start_states()
    assert len(uniform) == 3 ** 2 * 3 and all(not any(s.clean) and not s.holding for s in uniform)


# -- every rule on a three-segment, two-object state -------------------------------------------
def test_move_goes_to_the_next_segment_and_wraps_around(m32):
    assert m32.step(s3((0, 0, 0), (1, 2), 1), "move") == (s3((0, 0, 0), (1, 2), 2), Outcome.ROUTINE)
    assert m32.step(s3((0, 0, 0), (1, "held"), 3), "move") == (s3((0, 0, 0), (1, "held"), 1), Outcome.ROUTINE)


def test_pick_takes_the_lowest_numbered_object_on_the_arms_segment(m32):
    both_on_2 = s3((0, 0, 0), (2, 2), 2)
    assert m32.step(both_on_2, "pick") == (s3((0, 0, 0), ("held", 2), 2), Outcome.ROUTINE)
    second_only = s3((0, 0, 0), (1, 2), 2)
    assert m32.step(second_only, "pick") == (s3((0, 0, 0), (1, "held"), 2), Outcome.ROUTINE)


@pytest.mark.parametrize("state", [s3((0, 0, 0), (1, 1), 2), s3((0, 0, 0), ("held", 2), 2)])
def test_pick_with_nothing_to_pick_or_full_gripper_is_ineffective(m32, state):
    assert m32.step(state, "pick") == (state, Outcome.INEFFECTIVE)
    improper = TaskModel(spec="three_segments_two_objects", ineffective="improper")
    assert improper.step(state, "pick") == (state, Outcome.IMPROPER)


def test_place_puts_the_held_object_beside_others(m32):
    assert m32.step(s3((0, 0, 0), ("held", 3), 3), "place") == (s3((0, 0, 0), (3, 3), 3), Outcome.ROUTINE)
    nothing_held = s3((0, 0, 0), (1, 2), 3)
    assert m32.step(nothing_held, "place") == (nothing_held, Outcome.INEFFECTIVE)


def test_clean_is_improper_with_an_object_on_the_segment_but_not_elsewhere(m32):
    object_here = s3((0, 0, 0), (3, 2), 2)
    assert m32.step(object_here, "clean") == (object_here, Outcome.IMPROPER)
    holding = s3((0, 0, 0), ("held", 3), 1)
    assert m32.step(holding, "clean") == (holding, Outcome.IMPROPER)
    objects_elsewhere = s3((0, 0, 0), (3, 3), 2)
    assert m32.step(objects_elsewhere, "clean") == (s3((0, 1, 0), (3, 3), 2), Outcome.RELEVANT_CLEAN)
    already = s3((0, 1, 0), (3, 3), 2)
    assert m32.step(already, "clean") == (already, Outcome.IRRELEVANT_CLEAN)
    last = s3((1, 0, 1), (1, 1), 2)
    assert m32.step(last, "clean") == (s3((1, 1, 1), (1, 1), 2), Outcome.TERMINAL)


def test_action_mask_and_tables_are_sized_from_the_spec(m32):
    next_state, outcome = m32.transition_arrays()
    assert next_state.shape == outcome.shape == (384, 4)
    assert m32.action_mask(s3((0, 0, 0), (1, 1), 1)).tolist() == [1, 1, 1, 0]
    assert m32.record_dtype == np.int16 and TaskModel().record_dtype == np.int8


# -- specs: validation and JSON ---------------------------------------------------------------
@pytest.mark.parametrize("kwargs,match", [
    ({"segments": 1}, "segments must be an integer >= 2"),
    ({"segments": 2.5}, "segments must be an integer >= 2"),
    ({"objects": 0}, "objects must be >= 1"),
    ({"objects": "box"}, "objects must be an int >= 1"),
    ({"objects": ["Box"]}, "lower_snake"),
    ({"actions": ["move", "jump"]}, "unknown action 'jump'"),
    ({"actions": ["move", "move"]}, "must not repeat"),
    ({"start": "anywhere"}, "allowed: fixed, uniform_unclean"),
    ({"ineffective": "sometimes"}, "allowed: ineffective, improper"),
    ({"segments": 30, "objects": 30}, "state codes"),
])
def test_bad_specs_are_rejected_with_the_allowed_values(kwargs, match):
    with pytest.raises(ValueError, match=match):
        TaskSpec("bad", **kwargs)


def test_start_state_must_fit_the_spec():
    with pytest.raises(ValueError, match="3 segments"):
        TaskSpec("bad", segments=2, start_state=s3((0, 0, 0), (1,), 1))
    with pytest.raises(ValueError, match="terminal"):
        TaskSpec("bad", segments=3, start_state=s3((1, 1, 1), (1,), 1))
    with pytest.raises(ValueError, match="only allowed with start='fixed'"):
        TaskSpec("bad", segments=3, start="uniform_unclean", start_state=s3((0, 0, 0), (1,), 1))


def test_spec_json_round_trip_and_file_loading(tmp_path):
    spec = TaskSpec("mine", segments=3, objects=("box", "can"), start_state=s3((0, 1, 0), (2, "held"), 2),
                    ineffective="improper")
    path = tmp_path / "mine.json"
    spec.to_json(path)
    assert load_task_spec(path) == spec == get_task_spec(str(path))
    assert json.loads(path.read_text())["start_state"] == {"clean": [False, True, False], "objects": [2, "held"], "arm": 2}
    model = TaskModel(spec=str(path))
    assert model.start_state == spec.start_state and model.ineffective.value == "improper"


@pytest.mark.parametrize("document,match", [
    ({"segments": 3}, "needs a 'name'"),
    ({"name": "x", "segmentz": 3}, "unknown field"),
    ({"name": "x", "segments": 3, "start_state": {"clean": [False] * 3, "objects": [4], "arm": 1}},
     r"objects\[0\] must be a segment number in 1..3"),
    ({"name": "x", "format_version": 99}, "unsupported format_version"),
])
def test_bad_json_specs_name_the_problem(tmp_path, document, match):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(document))
    with pytest.raises(ValueError, match=match):
        load_task_spec(path)


def test_unknown_spec_names_list_the_registered_ones(tmp_path):
    with pytest.raises(ValueError, match="allowed: paper, three_segments"):
        TaskModel(spec="five_tables")
    with pytest.raises(ValueError, match="does not exist"):
        get_task_spec(str(tmp_path / "missing.json"))


def test_registering_a_spec_needs_overwrite_to_replace():
    spec = TaskSpec("test_only_spec", segments=3)
    register_task_spec(spec, overwrite=True)
    assert TaskModel(spec="test_only_spec").n_segments == 3
    with pytest.raises(ValueError, match="already registered"):
        register_task_spec(spec)


def test_model_options_override_the_spec():
    model = TaskModel(spec="three_segments", start="uniform_unclean", ineffective="improper")
    assert len(model.start_states()) == 9 and model.ineffective.value == "improper"
    assert model.spec.name == "three_segments" and get_task_spec("three_segments").start == "fixed"


# -- user actions ----------------------------------------------------------------------------
def _move_back(state):
    return state.replace(arm=(state.arm - 1) % state.n_segments), Outcome.ROUTINE


def test_a_user_action_changes_the_action_space_and_the_plans():
    register_action(ActionRule("test_move_back", _move_back, "previous segment"), overwrite=True)
    spec = TaskSpec("three_back", segments=3, actions=("move", "test_move_back", "pick", "place", "clean"))
    model = TaskModel(spec=spec)
    assert model.n_actions == 5 and model.transition_arrays()[0].shape == (96, 5)
    assert model.step(model.start_state, "test_move_back")[0].arm == 2
    assert len(model.shortest_plan(model.start_state)) < len(TaskModel(spec="three_segments").shortest_plan(
        TaskModel(spec="three_segments").start_state))


@pytest.mark.parametrize("effect,match", [
    (lambda s: (s.replace(clean=(True,) + s.clean[1:]), Outcome.INEFFECTIVE), "must leave the state unchanged"),
    (lambda s: (s, Outcome.TERMINAL), "non-terminal Outcome"),
    (lambda s: ("not a state", Outcome.ROUTINE), "non-terminal Outcome"),
    (lambda s: (s.replace(objects=(HELD, HELD)), Outcome.ROUTINE), "more than one object"),
])
def test_a_broken_user_effect_is_reported_not_used(effect, match):
    register_action(ActionRule("test_broken", effect), overwrite=True)
    model = TaskModel(spec=TaskSpec("broken", objects=2, actions=("move", "test_broken")))
    with pytest.raises(ActionEffectError, match=match):
        model.step(model.start_state, "test_broken")


def test_the_task_digest_changes_with_the_rules_and_the_spec():
    from tableclean_suite.bench.digests import task_digest

    register_action(ActionRule("test_digest", _move_back), overwrite=True)
    spec = TaskSpec("digest", segments=3, actions=("move", "test_digest"))
    before = task_digest(TaskModel(spec=spec))
    assert before == task_digest(TaskModel(spec=spec))
    register_action(ActionRule("test_digest", lambda s: (s, Outcome.INEFFECTIVE)), overwrite=True)
    assert task_digest(TaskModel(spec=spec)) != before
    assert task_digest(TaskModel(spec="three_segments")) != task_digest(TaskModel(spec="paper"))


def test_the_shipped_example_specs_load():
    from pathlib import Path

    specs = sorted((Path(__file__).resolve().parents[1] / "examples" / "specs").glob("*.json"))
    assert specs, "examples/specs holds the JSON specs the README uses"
    for path in specs:
        spec = load_task_spec(path)
        assert spec.name == path.stem and TaskModel(spec=str(path)).n_states == spec.n_states


@pytest.mark.parametrize("document, named", [
    ({"name": "x", "segments": "3"}, "segments"),
    ({"name": "x", "segments": "3", "start_state": {"clean": [False] * 3, "objects": [1], "arm": 1}}, "segments"),
    ({"name": "x", "segments": 3.0}, "segments"),
    ({"name": "x", "objects": "2"}, "objects"),
    ({"name": "x", "objects": [["box"]]}, "object type"),
    ({"name": "x", "actions": "move"}, "actions"),
    ({"name": "x", "description": 5}, "description"),
    ({"name": "x", "start_state": {"clean": [False, False], "objects": [1], "arm": "1"}}, "arm"),
    ({"name": 5}, "name"),
])
def test_a_json_spec_of_wrong_types_is_one_value_error(document, named):
    from tableclean_suite.task import TaskSpec

    with pytest.raises(ValueError, match=named):
        TaskSpec.from_dict(document)


@pytest.mark.parametrize("text", ['{"name": "x", "objects": ' + "[" * 100000 + "]" * 100000 + "}",
                                  "\udcff", '{"name": "x", "segments": ' + "{" * 5000])
def test_a_deeply_nested_or_undecodable_spec_file_is_one_value_error(tmp_path, text):
    from tableclean_suite.task.spec import load_task_spec

    path = tmp_path / "spec.json"
    path.write_bytes(text.encode("utf-8", "surrogateescape"))
    with pytest.raises(ValueError, match="spec.json"):
        load_task_spec(path)


def test_a_deeply_nested_transition_table_is_a_corrupt_table(tmp_path):
    from tableclean_suite.learners.transitions import CorruptTableError, TransitionTable

    path = tmp_path / "t.json"
    path.write_text("[" * 100000 + "]" * 100000)
    with pytest.raises(CorruptTableError, match="nested too deeply"):
        TransitionTable.from_json(path)
