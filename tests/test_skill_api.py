"""The skill-authoring API: a skill composed from primitives with targets named by meaning, and its rule."""

import pytest

from tableclean_suite.controllers import SkillController, compose_skill, get_skill_class, register_skill
from tableclean_suite.controllers.authoring import (
    free_spot,
    grasp,
    lying_object,
    next_segment,
    reach,
    release,
    segment_center,
    wipe,
)
from tableclean_suite.task import Outcome, TaskModel, TaskSpec, TaskState, action_names, get_action_rule


def carry_rule(state):
    lying = state.objects_on(state.arm)
    if state.holding or not lying:
        return state, Outcome.IMPROPER
    to = (state.arm + 1) % state.n_segments
    return state.with_object(lying[0], to).replace(arm=to), Outcome.ROUTINE


def test_a_composed_skill_has_one_phase_per_primitive_phase_and_registers_its_rule():
    skill = compose_skill("api_carry", carry_rule, [grasp(lying_object()), release(free_spot(next_segment()))],
                          description="carry to the next segment", max_steps=300)
    names = [m.name for m in skill.Phase]
    assert names[:2] == ["GRASP1_HOVER", "GRASP1_DESCEND"] and "RELEASE2_DESCEND" in names and names[-1] == "DONE"
    assert skill.DEFAULT_CONFIG["max_steps"] == 300 and "palm_clearance" in skill.DEFAULT_CONFIG
    assert "api_carry" not in action_names()
    register_skill("api_carry", skill, replace=True)
    assert get_skill_class("api_carry") is skill and get_action_rule("api_carry").effect is carry_rule
    model = TaskModel(spec=TaskSpec("api_carry_spec", actions=("move", "pick", "place", "clean", "api_carry")))
    start = model.start_state
    assert model.step(start, "api_carry") == (TaskState((False, False), (1,), 1), Outcome.ROUTINE)
    assert "api_carry" in [model.action_name(a) for a in model.shortest_plan(start)]


def test_a_wiping_skill_takes_the_clean_skills_settings_and_bad_steps_are_refused():
    skill = compose_skill("api_wipe_next", lambda s: (s, Outcome.IMPROPER),
                          [reach(segment_center(next_segment())), wipe(next_segment())])
    assert "press_force" in skill.DEFAULT_CONFIG and "WIPE2_SPONGE_CLOSE" in [m.name for m in skill.Phase]
    with pytest.raises(ValueError, match="at least one step"):
        compose_skill("api_empty", carry_rule, [])
    with pytest.raises(TypeError, match="step 1 is 'grasp'"):
        compose_skill("api_bad", carry_rule, ["grasp"])
    with pytest.raises(KeyError, match="unknown config keys"):
        compose_skill("api_cfg", carry_rule, [grasp(lying_object())], config={"speeed": 1.0})


def test_skill_results_name_built_in_and_user_actions_alike():
    from kinematic_env import KinematicEnv

    register_skill("api_carry", compose_skill("api_carry", carry_rule, [grasp(lying_object())]), replace=True)
    model = TaskModel(spec=TaskSpec("api_names", actions=("move", "pick", "place", "clean", "api_carry")))
    controller = SkillController(KinematicEnv(), model)
    # nothing to do in the stand-in's state (no object on the arm's segment): no motion, the report names the action
    built_in, user = controller.execute(1), controller.execute("api_carry")
    assert (built_in.action, user.action) == ("pick", "api_carry") and built_in.steps == user.steps == 0
