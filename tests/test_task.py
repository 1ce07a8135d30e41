"""The symbolic task model: encoding, every rule, reachability, Table 1 mapping."""

import numpy as np
import pytest

from tableclean_suite.task import (
    HELD,
    PAPER_OPTIMAL_PLAN,
    PAPER_START,
    START_LAYOUTS,
    TABLE1_STATES,
    Action,
    Outcome,
    TaskModel,
    TaskState,
    as_action,
    decode,
    encode,
    start_layout,
    table1_number,
)

S1, S2 = 0, 1  # segment indices (0-based)
ON1, ON2 = 0, 1  # object locations: lying on segment 1 / 2, or HELD
N_STATES = TaskModel().n_states


def state(c1, c2, obj, arm):
    return TaskState((c1, c2), (obj,), arm)


def all_states():
    return TaskModel().all_states()


def test_encode_decode_round_trip_covers_all_codes():
    codes = [encode(decode(code)) for code in range(N_STATES)]
    assert codes == list(range(N_STATES))
    assert len(set(all_states())) == N_STATES == 24


def test_encoding_formula_matches_docstring():
    s = state(True, False, HELD, S2)
    held_digit = 2  # the paper-era object_location code of "in the gripper"
    assert encode(s) == ((1 * 2 + 0) * 3 + held_digit) * 2 + 1


@pytest.mark.parametrize("bad", [-1, 24, 100])
def test_decode_rejects_out_of_range(bad):
    with pytest.raises(ValueError, match=str(bad)):
        decode(bad)


def test_unique_readable_names():
    names = [s.name for s in all_states()]
    assert len(set(names)) == N_STATES
    assert PAPER_START.name == "S1:unclean+obj S2:unclean | arm@S1"


@pytest.mark.parametrize("obj", [ON1, ON2, HELD])
@pytest.mark.parametrize("arm", [S1, S2])
def test_move_switches_segment_and_carries_held_object(obj, arm):
    nxt, outcome = TaskModel().step(state(False, False, obj, arm), Action.MOVE)
    assert nxt.arm == 1 - arm
    assert nxt.objects == (obj,)  # a held object stays held; a lying one stays where it is
    assert outcome == Outcome.ROUTINE


def test_pick_where_object_lies():
    nxt, outcome = TaskModel().step(state(False, True, ON1, S1), Action.PICK)
    assert (nxt, outcome) == (state(False, True, HELD, S1), Outcome.ROUTINE)


@pytest.mark.parametrize("obj,arm", [(ON2, S1), (ON1, S2), (HELD, S1)])
def test_pick_with_nothing_to_pick_is_ineffective(obj, arm):
    s = state(False, False, obj, arm)
    assert TaskModel().step(s, Action.PICK) == (s, Outcome.INEFFECTIVE)
    assert TaskModel(ineffective="improper").step(s, Action.PICK) == (s, Outcome.IMPROPER)


def test_place_puts_object_on_arm_segment():
    nxt, outcome = TaskModel().step(state(False, True, HELD, S2), Action.PLACE)
    assert (nxt, outcome) == (state(False, True, ON2, S2), Outcome.ROUTINE)


@pytest.mark.parametrize("obj", [ON1, ON2])
def test_place_with_nothing_held_is_ineffective(obj):
    s = state(False, False, obj, S1)
    assert TaskModel().step(s, Action.PLACE) == (s, Outcome.INEFFECTIVE)
    assert TaskModel(ineffective="improper").step(s, Action.PLACE) == (s, Outcome.IMPROPER)


@pytest.mark.parametrize("s", [state(False, False, HELD, S1), state(False, False, ON1, S1), state(True, False, ON2, S2)])
def test_clean_while_holding_or_on_object_is_improper_and_keeps_state(s):
    assert TaskModel().step(s, Action.CLEAN) == (s, Outcome.IMPROPER)
    assert TaskModel().step(s, Action.CLEAN)[1] == Outcome.IMPROPER


def test_relevant_irrelevant_and_terminal_clean():
    model = TaskModel()
    assert model.step(state(False, False, ON2, S1), Action.CLEAN) == (state(True, False, ON2, S1), Outcome.RELEVANT_CLEAN)
    assert model.step(state(True, False, ON2, S1), Action.CLEAN) == (state(True, False, ON2, S1), Outcome.IRRELEVANT_CLEAN)
    assert model.step(state(False, True, ON2, S1), Action.CLEAN) == (state(True, True, ON2, S1), Outcome.TERMINAL)


def test_stepping_terminal_state_is_an_error():
    with pytest.raises(ValueError, match="terminal"):
        TaskModel().step(state(True, True, ON1, S2), Action.MOVE)


def test_action_mask_marks_improper_actions():
    assert TaskModel().action_mask(PAPER_START).tolist() == [1, 1, 1, 0]
    assert TaskModel().action_mask(state(False, False, ON2, S1)).tolist() == [1, 1, 1, 1]


@pytest.mark.parametrize("bad", ["jump", 4, -1, 1.5, True])
def test_unknown_action_is_rejected_with_allowed_list(bad):
    with pytest.raises(ValueError, match="allowed: 0/move"):
        as_action(bad)
    with pytest.raises(ValueError, match="allowed: 0/move"):
        TaskModel().action_index(bad)


def test_actions_by_name_and_number():
    assert as_action("Clean") == Action.CLEAN and as_action(1) == Action.PICK
    assert list(Action) == [Action.MOVE, Action.PICK, Action.PLACE, Action.CLEAN]


@pytest.mark.parametrize("kwargs", [{"ineffective": "sometimes"}, {"start": "anywhere"}])
def test_bad_model_options_are_rejected(kwargs):
    with pytest.raises(ValueError, match="allowed"):
        TaskModel(**kwargs)


def test_terminal_start_is_rejected():
    with pytest.raises(ValueError, match="terminal"):
        TaskModel(start_state=state(True, True, ON1, S1))


def test_start_modes():
    assert TaskModel().start_states() == [TABLE1_STATES[4]]
    uniform = TaskModel(start="uniform_unclean").start_states()
    assert sorted(uniform) == sorted(start_layout(o, a) for o, a in START_LAYOUTS)
    assert [TaskModel(start="uniform_unclean").sample_start(u) for u in (0.0, 0.3, 0.6, 0.99)] == uniform
    assert TaskModel(start_state=7).start_states() == [decode(7)]


def test_reachable_counts_from_unclean_starts():
    reachable = TaskModel().reachable_states()
    assert len(reachable) == 20
    assert sum(s.is_terminal for s in reachable) == 2
    assert sum(not s.is_terminal for s in reachable) == 18
    # every non-terminal combination of the 3 cleanliness pairs x 6 layouts is reachable
    assert {s.clean for s in reachable if not s.is_terminal} == {
        (False, False), (True, False), (False, True)
    }


def test_shortest_plan_from_table1_state4_is_the_papers_length():
    model = TaskModel()
    plan = model.shortest_plan(TABLE1_STATES[4])
    assert len(plan) == 8
    assert tuple(plan) == PAPER_OPTIMAL_PLAN
    assert model.rollout(TABLE1_STATES[4], plan)[-1].is_terminal


def test_shortest_plans_are_valid_and_minimal():
    model = TaskModel()
    lengths = model.shortest_plan_lengths()
    for code, length in lengths.items():
        plan = model.shortest_plan(code)
        assert len(plan) == length
        visited = model.rollout(code, plan)
        assert visited[-1].is_terminal
        assert all(model.step(s, a)[1] != Outcome.IMPROPER for s, a in zip(visited, plan))
    assert max(lengths.values()) == 9  # holding the object over the other segment, both unclean


def _first_shortest_plan(model, start):
    """Breadth-first search over ``model.successors``, actions in the spec's order: the oracle of
    ``shortest_plan`` (the first of the shortest plans) and of the distances."""
    from collections import deque

    parent, frontier = {start: None}, deque([start])
    while frontier:
        current = frontier.popleft()
        if current.is_terminal:
            plan = []
            while parent[current] is not None:
                current, action = parent[current]
                plan.append(action)
            return plan[::-1]
        for action, nxt, _ in model.successors(current):
            if nxt not in parent:
                parent[nxt] = (current, action)
                frontier.append(nxt)
    return None


@pytest.mark.parametrize("spec", ["paper", "three_segments", "two_objects", "three_segments_two_objects"])
def test_shortest_plans_and_distances_match_a_breadth_first_search(spec):
    model = TaskModel(spec=spec)
    distance = model.distances_to_terminal()
    for state in model.reachable_states():
        expected = _first_shortest_plan(model, state)
        assert [int(a) for a in model.shortest_plan(state)] == expected
        assert distance[state.index] == len(expected)


def test_table1_mapping():
    mapping = TaskModel().table1_mapping()
    assert len(mapping["rows"]) == 18
    assert mapping["unreachable_rows"] == [14, 15, 16, 18]
    omitted = [decode(c) for c in mapping["omitted_reachable"]]
    assert len(omitted) == 6 and all(table1_number(s) is None for s in omitted)
    on_plan = {decode(c) for c in mapping["omitted_on_paper_plan"]}
    assert on_plan == {state(False, True, HELD, S2), state(False, True, ON2, S2), state(False, True, ON2, S1)}


def test_table1_examples_from_the_text():
    # "in State 1 ... the object is located in Segment 2, and the manipulator is positioned above Segment 1.
    #  If the agent performs the clean action from this state, it transitions to state-7."
    nxt, outcome = TaskModel().step(TABLE1_STATES[1], Action.CLEAN)
    assert table1_number(nxt) == 7 and outcome == Outcome.RELEVANT_CLEAN


def test_classify_agrees_with_model_on_predicted_transitions():
    model = TaskModel()
    for s in model.reachable_states():
        if s.is_terminal:
            continue
        for a in Action:
            nxt, outcome = model.step(s, a)
            assert model.classify(s, a, nxt) == outcome


def test_transition_arrays_match_step():
    model = TaskModel()
    nxt, out = model.transition_arrays()
    assert nxt.shape == out.shape == (24, 4)
    for s in all_states():
        if not s.is_terminal:
            for a in Action:
                assert (decode(int(nxt[s.index, a])), Outcome(out[s.index, a])) == model.step(s, a)
    assert np.all(out[[s.index for s in all_states() if s.is_terminal]] == Outcome.TERMINAL)


def test_built_in_effects_called_on_one_state_agree_with_the_model():
    """The built-in effects (written once, on code digits) give one state what the model's table gives."""
    from tableclean_suite.task import clean_effect, move_effect, pick_effect, place_effect

    model = TaskModel(spec="three_segments_two_objects")
    effects = dict(zip(("move", "pick", "place", "clean"), (move_effect, pick_effect, place_effect, clean_effect)))
    for state in model.reachable_states():
        if state.is_terminal:
            continue
        for name, effect in effects.items():
            after, outcome = effect(state)
            expected, expected_outcome = model.step(state, name)
            assert after == expected
            assert outcome == expected_outcome or expected_outcome == Outcome.TERMINAL
    held = model.decode(next(s.index for s in model.reachable_states() if s.holding and not s.is_terminal))
    assert pick_effect(held) == (held, Outcome.INEFFECTIVE) and clean_effect(held) == (held, Outcome.IMPROPER)
