"""The typed, frozen skill configs: defaults, ranges, the merge order and the override paths."""

import dataclasses

import pytest

from tableclean_suite.controllers import (
    BASE_CONFIG,
    CleanSkill,
    Grasp,
    MoveSkill,
    PickPhase,
    PickSkill,
    PlaceSkill,
    PrimitiveSkill,
    Reach,
    Release,
    SkillController,
    Wipe,
    compose_skill,
)
from tableclean_suite.controllers.authoring import grasp, lying_object
from tableclean_suite.controllers.configs import (
    CleanConfig,
    ComposedConfig,
    GraspConfig,
    MoveConfig,
    PickConfig,
    PlaceConfig,
    ReleaseConfig,
    SkillConfig,
    WipeConfig,
)
from tableclean_suite.controllers.primitives import SPONGE
from tableclean_suite.controllers.robot_configs import register_robot_config
from tableclean_suite.environments.robot_registry import ROBOT_CONFIGS, RobotSkillConfig
from tableclean_suite.task import Action, Outcome

from kinematic_env import KinematicEnv, fake_robot

ALL_CONFIGS = [SkillConfig, GraspConfig, ReleaseConfig, WipeConfig, MoveConfig, PickConfig, PlaceConfig,
               CleanConfig, ComposedConfig]


@pytest.mark.parametrize("config_type", ALL_CONFIGS)
def test_every_field_has_a_unit_a_range_and_a_default_inside_it(config_type):
    config = config_type()
    for field in dataclasses.fields(config_type):
        meta = field.metadata
        assert meta["unit"], field.name
        assert meta["low"] <= meta["high"], field.name
        # the default itself is in range (a config built from the defaults validated them)
        assert getattr(config, field.name) is None or meta["low"] <= getattr(config, field.name) <= meta["high"]


@pytest.mark.parametrize("config_type", ALL_CONFIGS)
def test_configs_are_frozen(config_type):
    with pytest.raises(dataclasses.FrozenInstanceError):
        config_type().max_steps = 1


def test_skill_defaults_are_the_config_types_defaults():
    for skill, config_type in [(MoveSkill, MoveConfig), (PickSkill, PickConfig), (PlaceSkill, PlaceConfig),
                               (CleanSkill, CleanConfig)]:
        assert skill.Config is config_type
        assert skill.DEFAULT_CONFIG == config_type().as_dict()
        assert set(BASE_CONFIG) <= set(skill.DEFAULT_CONFIG)
    assert set(GraspConfig.keys()) <= set(PickSkill.DEFAULT_CONFIG) and set(GraspConfig.keys()) <= set(CleanSkill.DEFAULT_CONFIG)
    # the paper's tuned numbers (an optimal episode's control steps depend on them)
    assert (MoveConfig().max_steps, PickConfig().max_steps, PlaceConfig().max_steps, CleanConfig().max_steps) \
        == (200, 250, 250, 900)
    assert (CleanConfig().tip_clearance, PickConfig().tip_clearance) == (0.004, 0.010)
    assert (CleanConfig().place_clearance, PlaceConfig().place_clearance) == (0.004, 0.006)


@pytest.mark.parametrize("config_type, field, value, message", [
    (SkillConfig, "speed", 0.0, r"speed must be a number > 0 \(m/s\), got 0\.0"),
    (SkillConfig, "speed", float("inf"), r"speed must be a number > 0 \(m/s\), got inf"),
    (SkillConfig, "max_steps", 2.5, r"max_steps must be an int >= 1 \(control steps\), got 2\.5"),
    (SkillConfig, "max_steps", True, r"max_steps must be an int >= 1 \(control steps\), got True"),
    (SkillConfig, "yaw_tolerance", 4.0, r"yaw_tolerance must be a number in \(0, 3\.14159\] \(rad\), got 4\.0"),
    (SkillConfig, "hover_height", "0.1", r"hover_height must be a number >= 0 \(m\), got '0\.1'"),
    (GraspConfig, "retries", -1, r"retries must be an int >= 0 \(retries\), got -1 \(GraspConfig\)"),
    (SkillConfig, "retries", 1.5, r"retries must be an int >= 0"),
    (WipeConfig, "wipe_overlap", 1.5, r"wipe_overlap must be a number in \[0, 1\]"),
    (CleanConfig, "press_force", -8.0, r"press_force must be a number > 0 \(N\), got -8\.0 \(CleanConfig\)"),
])
def test_a_value_outside_its_range_is_refused_naming_field_value_and_range(config_type, field, value, message):
    with pytest.raises(ValueError, match=message):
        config_type(**{field: value})


def test_cross_field_check():
    with pytest.raises(ValueError, match=r"min_press_depth \(0\.03 m\) must be <= max_press_depth \(0\.02 m\)"):
        WipeConfig(min_press_depth=0.03)


def test_a_skill_validates_its_merged_config_and_keeps_it_read_only():
    env = KinematicEnv()
    skill = PickSkill(env, {"grasp_slip_tolerance": 0.02, "speed": 0.3})
    assert isinstance(skill.settings, PickConfig)
    assert (skill.settings.grasp_slip_tolerance, skill.config["grasp_slip_tolerance"]) == (0.02, 0.02)
    assert skill.settings.speed == 0.3 and skill.settings.max_steps == 250
    with pytest.raises(TypeError):
        skill.config["speed"] = 1.0
    with pytest.raises(ValueError, match="grasp_slip_tolerance must be a number > 0"):
        PickSkill(env, {"grasp_slip_tolerance": 0.0})
    with pytest.raises(KeyError, match="unknown config keys for PickSkill"):
        PickSkill(env, {"press_force": 8.0})


def test_merge_order_robot_then_caller():
    robot = "ConfigTestArm"
    register_robot_config(RobotSkillConfig(robot, skills={"*": {"speed": 0.3, "hover_height": 0.1},
                                                          "pick": {"speed": 0.2}}))
    try:
        env = KinematicEnv(robot=fake_robot(robot=robot))
        controller = SkillController(env, skill_configs={Action.PICK: {"hover_height": 0.12}})
        assert controller.skill_config(Action.PICK) == {"speed": 0.2, "hover_height": 0.12}
        assert controller.skill_config(Action.MOVE) == {"speed": 0.3, "hover_height": 0.1}
        skill = PickSkill(env, controller.skill_config(Action.PICK))
        assert (skill.settings.speed, skill.settings.hover_height, skill.settings.descend_speed) == (0.2, 0.12, 0.25)
    finally:
        ROBOT_CONFIGS.pop(robot, None)


def test_robot_overrides_are_range_checked_at_registration():
    with pytest.raises(ValueError, match=r"fingertip_depth must be a number >= 0 \(m\), got -0\.02"):
        register_robot_config(RobotSkillConfig("ConfigTestArm2", skills={"*": {"fingertip_depth": -0.02}}))
    assert "ConfigTestArm2" not in ROBOT_CONFIGS


def test_composed_skill_config_type_and_checks():
    rule = lambda state: (state, Outcome.IMPROPER)  # noqa: E731
    skill = compose_skill("config_probe", rule, [grasp(lying_object())], max_steps=300, config={"palm_clearance": 0.01})
    assert skill.Config is ComposedConfig
    assert skill.DEFAULT_CONFIG == ComposedConfig(max_steps=300, palm_clearance=0.01).as_dict()
    with pytest.raises(ValueError, match="max_steps must be an int >= 1"):
        compose_skill("config_probe", rule, [grasp(lying_object())], max_steps=0)
    with pytest.raises(KeyError, match=r"unknown config keys for skill 'config_probe': \['press_force'\]"):
        compose_skill("config_probe", rule, [grasp(lying_object())], config={"press_force": 8.0})


def test_a_skill_whose_config_lacks_a_primitives_settings_is_refused_when_it_starts():
    class NoGraspSettings(PrimitiveSkill):
        action = Action.PICK
        Phase = PickPhase  # DEFAULT_CONFIG: BASE_CONFIG only

        def build(self, info):
            return [("", Grasp(SPONGE, "grasp"))]

    env = KinematicEnv()
    skill = NoGraspSettings(env)
    with pytest.raises(TypeError, match=r"NoGraspSettings's config lacks the settings \['grasp_depth', .*\] of Grasp "
                                        r"\(its Config: GraspConfig\)"):
        skill.on_reset(env.skill_info())
    assert (Grasp.Config, Release.Config, Wipe.Config, Reach.Config) == (GraspConfig, ReleaseConfig, WipeConfig,
                                                                         SkillConfig)


@pytest.mark.parametrize("skills, message", [
    ({"pick": {"grasp_slip_tolerance": -0.01}}, r"grasp_slip_tolerance must be a number > 0 \(m\), got -0\.01 "
                                                r"\(PickConfig\)"),
    ({Action.CLEAN: {"wipe_overlap": 2.0}}, r"wipe_overlap must be a number in \[0, 1\]"),
    ({"place": {"press_force": 8.0}}, r"unknown config keys for PlaceSkill \(robot 'ConfigTestArm3'\): "
                                      r"\['press_force'\]"),
])
def test_robot_per_action_overrides_are_checked_against_the_skills_config(skills, message):
    with pytest.raises(ValueError, match=message):
        register_robot_config(RobotSkillConfig("ConfigTestArm3", skills=skills))
    assert "ConfigTestArm3" not in ROBOT_CONFIGS
