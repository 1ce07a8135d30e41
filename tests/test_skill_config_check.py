"""One check of a skill's settings (a skill's constructor, a robot's per-action overrides and
compose_skill refuse alike), a refused skill registration that leaves nothing behind, and the
scenes that stage every start sharing one start-layout default."""

import pickle

import pytest
from kinematic_env import KinematicEnv

from tableclean_suite.controllers import PickSkill, compose_skill, register_skill
from tableclean_suite.controllers.authoring import grasp, lying_object
from tableclean_suite.controllers.configs import PickConfig, SkillConfigError, checked_skill_config
from tableclean_suite.controllers.robot_configs import ROBOT_CONFIGS, RobotSkillConfig, register_robot_config
from tableclean_suite.task import Outcome, action_names

RULE = lambda state: (state, Outcome.IMPROPER)  # noqa: E731


def _refusals(overrides: dict) -> list[SkillConfigError]:
    """What the three places that take a skill's settings raise for ``overrides`` (for the pick skill)."""
    errors = []
    for attempt in (lambda: PickSkill(KinematicEnv(), overrides),
                    lambda: register_robot_config(RobotSkillConfig("CheckArm", skills={"pick": overrides})),
                    lambda: compose_skill("check_probe", RULE, [grasp(lying_object())], config=overrides)):
        with pytest.raises(SkillConfigError) as caught:
            attempt()
        errors.append(caught.value)
    assert "CheckArm" not in ROBOT_CONFIGS
    return errors


def test_an_unknown_key_is_refused_alike_naming_the_skill_the_key_and_the_allowed_keys():
    for error, owner in zip(_refusals({"press_forse": 8.0}), ("PickSkill", "PickSkill (robot 'CheckArm')",
                                                               "skill 'check_probe'")):
        message = str(error)
        assert message.startswith(f"unknown config keys for {owner}: ['press_forse'] (allowed: [")
        assert "'grasp_depth'" in message and "\n" not in message
        assert isinstance(error, KeyError) and isinstance(error, ValueError)  # what callers caught before


def test_a_value_out_of_range_is_refused_alike_naming_the_skill_the_key_and_its_range():
    for error, owner in zip(_refusals({"speed": -0.1}), ("PickSkill", "PickSkill (robot 'CheckArm')",
                                                          "skill 'check_probe'")):
        assert str(error).startswith(f"{owner}: speed must be a number > 0 (m/s), got -0.1")


def test_a_robot_config_may_not_override_the_osc_settings_the_skills_rely_on():
    with pytest.raises(ValueError, match=r"'CheckArm': the OSC keys \['input_ref_frame', 'type'\] are what the skills"):
        register_robot_config(RobotSkillConfig("CheckArm", osc={"type": "OSC_POSITION", "kp": 200,
                                                                "input_ref_frame": "base"}))
    assert "CheckArm" not in ROBOT_CONFIGS


def test_the_check_returns_the_merged_values_and_the_typed_settings():
    merged, settings = checked_skill_config("PickSkill", PickConfig, PickSkill.DEFAULT_CONFIG, {"speed": 0.3})
    assert merged == {**PickSkill.DEFAULT_CONFIG, "speed": 0.3} and settings == PickConfig(**merged)
    skill = PickSkill(KinematicEnv(), {"speed": 0.3})
    assert dict(skill.config) == merged and skill.settings == settings


def test_a_refused_skill_registration_registers_no_action():
    made = compose_skill("check_half", RULE, [grasp(lying_object())])
    elsewhere = type("ElsewhereSkill", (made,), {"action": "move"})  # carries check_half's rule, implements MOVE
    with pytest.raises(ValueError, match="implements MOVE, not CHECK_HALF"):
        register_skill("check_half", elsewhere)
    with pytest.raises(ValueError, match="already has skill"):
        register_skill("check_half", made, registry={"check_half": PickSkill})
    assert "check_half" not in action_names()  # the rule was registered before the checks
    register_skill("check_half", made, registry={})
    assert "check_half" in action_names()


def test_the_layout_default_is_a_sentinel_compared_by_identity_and_kept_through_pickling():
    from tableclean_suite.environments.table_clean import FROM_SPEC

    assert FROM_SPEC != "from_spec"  # a string spelled like it is a value, not the default
    assert pickle.loads(pickle.dumps(FROM_SPEC)) is FROM_SPEC  # executor workers get the same default
    assert repr(FROM_SPEC) == "FROM_SPEC"


def test_scenes_that_stage_every_start_share_one_layout_default(monkeypatch):
    from tableclean_suite.controllers.make import DEFAULT_LAYOUT
    from tableclean_suite.physics_backend import staging_env_kwargs
    from tableclean_suite.task import TaskModel

    model = TaskModel()
    made = staging_env_kwargs(model, {"robots": "Sawyer"})
    assert made == {"robots": "Sawyer", "task": model.spec, "object_segment": DEFAULT_LAYOUT[0],
                    "arm_segment": DEFAULT_LAYOUT[1]}
    assert staging_env_kwargs(model, {"object_segments": (2,)}) == {"object_segments": (2,), "task": model.spec}
    given = {"arm_segment": 2}
    assert staging_env_kwargs(model, given) == {"arm_segment": 2, "task": model.spec} and given == {"arm_segment": 2}

    import tableclean_suite.controllers as controllers
    from tableclean_suite.gym_envs.skills import TableCleanSkillsEnv
    from tableclean_suite.physics_backend import PhysicsStepEnv

    made = []
    monkeypatch.setattr(controllers, "make_skill_env", lambda **kwargs: made.append(kwargs) or KinematicEnv())
    PhysicsStepEnv(model, env_kwargs={"robots": "Panda"})
    TableCleanSkillsEnv(env_kwargs={"robots": "Panda"})
    assert made == [staging_env_kwargs(model, {"robots": "Panda"})] * 2
