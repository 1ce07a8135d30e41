"""Tests of the skills and the SkillController.

Unit tests (no physics) cover the registry, bad input, the pure geometry and the
waypoint machinery on a kinematic fake env.  Physics tests (``slow``) run the skills on
TableClean and compare the abstraction's state after each action with the task model's.
"""

from __future__ import annotations

import enum

import numpy as np
import pytest

from kinematic_env import KinematicEnv, fake_robot
from tableclean_suite.controllers import (
    SKILL_REGISTRY,
    CleanSkill,
    MoveSkill,
    PickSkill,
    PlaceSkill,
    Skill,
    SkillController,
    Waypoint,
    get_skill_class,
    register_skill,
    skill_controller_config,
)
from tableclean_suite.controllers.geometry import gripper_yaw, quat_to_matrix
from tableclean_suite.controllers.primitives import box_geometry
from tableclean_suite.environments.object_geometry import ObjectGeometry
from tableclean_suite.environments.object_geometry import grasp_yaw as geometry_grasp_yaw
from tableclean_suite.controllers import make as make_module
from tableclean_suite.controllers import osc
from tableclean_suite.controllers.osc import ACTION_DIM, ARM_PART, check_skill_env, skill_command_limits
from tableclean_suite.controllers.setpoint import advance_command
from tableclean_suite.controllers.wipe_pattern import boustrophedon
from tableclean_suite.task import (
    START_LAYOUTS,
    Action,
    Outcome,
    TaskModel,
    start_layout,
)

MODEL = TaskModel()


# ---------------------------------------------------------------------------------------------
# unit tests: registry, bad input, geometry
# ---------------------------------------------------------------------------------------------
def test_registry_maps_every_action_to_its_skill():
    assert {a: get_skill_class(a) for a in Action} == {
        Action.MOVE: MoveSkill,
        Action.PICK: PickSkill,
        Action.PLACE: PlaceSkill,
        Action.CLEAN: CleanSkill,
    }
    assert get_skill_class("clean") is CleanSkill and get_skill_class(1) is PickSkill


class _FasterMove(MoveSkill):
    pass


def test_register_skill_adds_and_replaces_without_touching_the_controller():
    registry = {}
    with pytest.raises(KeyError, match="no skill registered for MOVE; registered: none"):
        get_skill_class(Action.MOVE, registry)
    register_skill(Action.MOVE, MoveSkill, registry=registry)
    with pytest.raises(ValueError, match="already has skill MoveSkill"):
        register_skill(Action.MOVE, _FasterMove, registry=registry)
    register_skill("move", _FasterMove, replace=True, registry=registry)
    assert get_skill_class(Action.MOVE, registry) is _FasterMove
    assert SKILL_REGISTRY[Action.MOVE] is MoveSkill  # the global table is untouched


def test_register_skill_rejects_bad_input():
    with pytest.raises(TypeError, match="must be a Skill subclass"):
        register_skill(Action.MOVE, object, registry={})
    with pytest.raises(ValueError, match="PickSkill implements PICK, not MOVE"):
        register_skill(Action.MOVE, PickSkill, registry={})
    with pytest.raises(ValueError, match="unknown action 'fly'"):
        register_skill("fly", MoveSkill, registry={})


class _FakeEnv(KinematicEnv):
    """:class:`KinematicEnv` whose arm controller is ``arm_controller`` (name, input type, reference frame)."""

    def __init__(self, arm_segment: int = 0, frozen: bool = False,
                 arm_controller=("OSC_POSE", "absolute", "world")):
        super().__init__(arm_segment, frozen, fake_robot(*arm_controller))


def test_execute_rejects_unknown_actions_before_touching_the_env():
    env = _FakeEnv()
    controller = SkillController(env)
    for bad in ("fly", 7, -1, 1.5, None, True):
        with pytest.raises(ValueError, match="unknown action"):
            controller.execute(bad)
    assert env.steps == 0


def test_skill_config_rejects_unknown_keys():
    with pytest.raises(KeyError, match="unknown config keys for MoveSkill: \\['sped'\\]"):
        MoveSkill(_FakeEnv(), {"sped": 1.0})


def test_skill_base_cannot_be_instantiated_without_its_hooks():
    class Incomplete(Skill):
        action = Action.MOVE
        Phase = enum.Enum("Phase", "A DONE")

    with pytest.raises(TypeError, match="abstract"):
        Incomplete(_FakeEnv())


def test_move_skill_rate_limits_and_ends_above_the_other_segment():
    env = _FakeEnv(0)
    controller = SkillController(env)
    result = controller.execute(Action.MOVE)
    assert result.success and result.reason == "ok" and result.final_phase == "DONE"
    assert result.state_after.arm == 1
    np.testing.assert_allclose(env.eef[:2], env.centers[1, :2], atol=MoveSkill.DEFAULT_CONFIG["reach_tolerance"])
    # rate limit: the setpoint never moves faster than speed / control_freq per step
    config = MoveSkill.DEFAULT_CONFIG
    distance = np.linalg.norm(env.centers[1, :2] - env.centers[0, :2]) - config["reach_tolerance"]
    assert result.steps >= distance / (config["speed"] / env.control_freq)
    assert result.outcome == Outcome.ROUTINE and result.steps == env.steps


def test_on_step_is_called_after_every_control_step():
    env = _FakeEnv(0)
    seen = []
    result = SkillController(env, on_step=lambda: seen.append(env.steps)).execute(Action.MOVE)
    assert result.steps > 0 and seen == list(range(1, result.steps + 1))


def test_a_skill_that_cannot_reach_its_waypoint_fails_on_its_step_budget():
    env = _FakeEnv(frozen=True)
    result = SkillController(env, skill_configs={Action.MOVE: {"max_steps": 15}}).execute(Action.MOVE)
    assert not result.success and result.steps == 15
    assert "step budget of 15 exhausted in phase TRAVEL" in result.reason


def test_waypoint_skill_config_is_per_skill_and_named():
    for cls in (MoveSkill, PickSkill, PlaceSkill, CleanSkill):
        assert set(Skill.DEFAULT_CONFIG) <= set(cls.DEFAULT_CONFIG)
        assert list(cls.Phase)[-1].name == "DONE"
    assert Waypoint(np.zeros(3), -1.0, 0.01).xy_only is False


def test_controller_config_is_absolute_world_osc_pose():
    arm = skill_controller_config()["body_parts"][ARM_PART]
    assert (arm["type"], arm["input_type"], arm["input_ref_frame"]) == ("OSC_POSE", "absolute", "world")
    assert skill_controller_config() is not skill_controller_config()  # fresh copies
    low, high = skill_command_limits()
    assert (arm["input_min"], arm["input_max"]) == (low.tolist(), high.tolist())  # action_spec states them


@pytest.mark.parametrize(
    "controller, match",
    [
        (("OSC_POSE", "delta", "base"), r"'input_type': 'delta'.*need.*'absolute'.*make_skill_env"),
        (("OSC_POSE", "absolute", "base"), r"'input_ref_frame': 'base'.*need.*'world'.*make_skill_env"),
        (("OSC_POSITION", "absolute", "world"), r"'type': 'OSC_POSITION'.*make_skill_env"),
    ],
)
def test_skill_controller_refuses_an_env_whose_arm_is_not_absolute_world_osc_pose(controller, match):
    env = _FakeEnv(arm_controller=controller)
    with pytest.raises(ValueError, match=match):
        SkillController(env)
    assert env.steps == 0


def test_skill_controller_refuses_envs_without_a_robot_or_with_another_action_size():
    class NoRobot:
        pass

    with pytest.raises(TypeError, match="NoRobot has none.*make_skill_env"):
        SkillController(NoRobot())
    env = _FakeEnv()
    env.action_dim = ACTION_DIM + 1
    with pytest.raises(ValueError, match=f"takes {ACTION_DIM + 1}-dimensional actions.*emit {ACTION_DIM}.*make_skill_env"):
        check_skill_env(env)


def test_make_skill_env_builds_the_controller_config_of_the_requested_robot(monkeypatch):
    loaded, made = [], []
    real_load = osc.load_composite_controller_config
    monkeypatch.setattr(osc, "load_composite_controller_config", lambda robot: loaded.append(robot) or real_load(robot=robot))
    monkeypatch.setattr(make_module.robosuite, "make", lambda name, **kwargs: made.append(kwargs))
    make_module.make_skill_env(robots="UR5e")
    make_module.make_skill_env(robots=["Kinova3"], task_config={"table_offset": (0.0, 0.0, 0.9)})
    make_module.make_skill_env()
    assert loaded == ["UR5e", "Kinova3", "Panda"]
    assert made[0]["controller_configs"] == skill_controller_config("UR5e")
    arm = made[1]["controller_configs"]["body_parts"][ARM_PART]
    assert arm["input_min"][2] == pytest.approx(0.9 - osc.WORKSPACE_BELOW_TABLE)  # the scene's table height
    custom = {"type": "BASIC"}
    loads = len(loaded)
    make_module.make_skill_env(robots="UR5e", controller_configs=custom)
    assert made[-1]["controller_configs"] is custom and len(loaded) == loads  # given configs are kept
    with pytest.raises(ValueError, match=r"robots must name one robot.*\['Panda', 'Panda'\]"):
        make_module.make_skill_env(robots=["Panda", "Panda"])


def _down_rotvec(yaw: float) -> np.ndarray:
    """The rotation vector (3,) the skills command for a gripper pointing down at ``yaw`` (rad)."""
    action, here = np.empty(ACTION_DIM), np.zeros(3)
    advance_command(here, yaw, yaw, here.copy(), 0.01, 0.1, 0.0, action)
    return action[3:6]


@pytest.mark.parametrize("yaw", np.linspace(-np.pi, np.pi, 9))
def test_skill_command_limits_contain_every_down_pose_over_the_table(yaw):
    low, high = skill_command_limits()
    rotvec = _down_rotvec(yaw)
    assert np.all(low[3:] <= rotvec) and np.all(rotvec <= high[3:])
    assert low.shape == high.shape == (6,) and np.all(low < high)


@pytest.mark.parametrize("yaw", [0.0, 0.5 * np.pi, 2.0, -2.5])
def test_the_commanded_rotation_points_the_gripper_down_with_the_given_yaw(yaw):
    from scipy.spatial.transform import Rotation  # robosuite's OSC reads the rotation vector with it

    rot = Rotation.from_rotvec(_down_rotvec(yaw)).as_matrix()
    c, s = np.cos(yaw), np.sin(yaw)  # x axis turned by yaw about world z, approach (z) axis world -z
    np.testing.assert_allclose(rot, [[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]], atol=1e-12)


def grasp_yaw(quat, half_size, nominal_yaw):
    """The grasp yaw of an upright box of ``half_size`` turned by ``quat`` (xyzw)."""
    return geometry_grasp_yaw(box_geometry(half_size), gripper_yaw(quat), nominal_yaw)


def test_grasp_yaw_puts_the_fingers_across_the_short_side():
    identity = np.array([0.0, 0.0, 0.0, 1.0])
    long_x = np.array([0.04, 0.025, 0.015])  # the sponge: short side along y
    yaw = grasp_yaw(identity, long_x, nominal_yaw=0.5 * np.pi)
    closing_axis = np.array([np.cos(yaw), np.sin(yaw)])  # fingers close along the grip site's x axis
    assert abs(closing_axis[1]) == pytest.approx(1.0)
    assert grasp_yaw(identity, long_x, nominal_yaw=-0.5 * np.pi) == pytest.approx(-0.5 * np.pi)
    cube = np.full(3, 0.02)
    assert grasp_yaw(identity, cube, nominal_yaw=0.1) == pytest.approx(0.0)
    turned = np.array([0.0, 0.0, np.sin(0.15), np.cos(0.15)])  # cube turned 0.3 rad about z
    assert grasp_yaw(turned, cube, nominal_yaw=0.5 * np.pi) == pytest.approx(0.3 + 0.5 * np.pi)
    np.testing.assert_allclose(quat_to_matrix(identity), np.eye(3))


def test_geometry_finds_the_narrow_side_of_any_shape_and_calls_a_disc_round():
    angles = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    disc = ObjectGeometry(np.column_stack([0.03 * np.cos(angles), 0.03 * np.sin(angles), np.zeros(64)]))
    assert disc.is_round and disc.narrow_width == pytest.approx(0.06, abs=1e-3)
    # a right triangle's narrowest width is its height onto the hypotenuse, not a bounding-box side
    triangle = ObjectGeometry(np.array([[0.0, 0.0, 0.0], [0.06, 0.0, 0.0], [0.0, 0.06, 0.0]]))
    assert not triangle.is_round
    assert triangle.narrow_width == pytest.approx(0.06 / np.sqrt(2), abs=1e-4)
    long_box = box_geometry([0.05, 0.015, 0.075])  # robosuite's cereal box: fingers across its 3 cm side
    assert long_box.narrow_width == pytest.approx(0.03) and long_box.footprint_radius == pytest.approx(np.hypot(0.05, 0.015))
    assert long_box.narrow_side() == (0.5 * np.pi, np.pi)


def test_boustrophedon_sweeps_the_whole_rectangle_lane_by_lane():
    center, half, foot = np.array([0.0, 0.14, 0.8]), np.array([0.12, 0.12]), np.array([0.04, 0.025])
    points = boustrophedon(center, half, foot, overlap=0.4, along_x=False, edge_inset=1.0)
    assert points.shape[1] == 2 and len(points) % 2 == 0
    offsets = points - center[:2]
    assert np.all(np.abs(offsets) <= half - foot + 1e-12)  # the sponge stays on the rectangle
    lanes = np.unique(offsets[:, 0].round(9))
    assert lanes[0] == pytest.approx(-(half[0] - foot[0])) and lanes[-1] == pytest.approx(half[0] - foot[0])
    assert np.max(np.diff(lanes)) <= 2 * foot[0] * (1 - 0.4) + 1e-12  # no gap between lanes
    assert np.all(offsets[::2, 0] == offsets[1::2, 0])  # each stroke runs along y
    shifted = boustrophedon(center, half, foot, overlap=0.4, along_x=False, lane_shift=0.5)
    assert not np.allclose(shifted, points)
    with pytest.raises(ValueError, match="footprint"):
        boustrophedon(center, half, np.array([0.0, 0.02]), 0.2, True)
    with pytest.raises(ValueError, match="overlap"):
        boustrophedon(center, half, foot, 1.0, True)


# ---------------------------------------------------------------------------------------------
# physics tests
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def envs():
    """One TableClean env per start layout, made lazily and shared by this module's tests."""
    from tableclean_suite.controllers import make_skill_env

    made = {}

    def get(object_segment: int, arm_segment: int):
        key = (object_segment, arm_segment)
        if key not in made:
            made[key] = make_skill_env(object_segment, arm_segment, seed=key[0] * 10 + key[1], hard_reset=False)
        env = made[key]
        env.reset()
        return env

    yield get
    for env in made.values():
        env.close()


def _run(controller, actions):
    """Execute ``actions``; each must succeed with the task model's successor."""
    results = []
    for action in actions:
        result = controller.execute(action)
        expected, _ = MODEL.step(result.state_before, action)
        assert result.state_after == expected, f"{action.name}: {result.reason}"
        assert result.success, f"{action.name}: {result.reason}"
        results.append(result)
    return results


# (layout, prefix actions that reach the canonical state, the skill under test, what it checks)
CANONICAL = {
    "move_empty": ((1, 1), [], Action.MOVE),
    "move_holding": ((1, 1), [Action.PICK], Action.MOVE),
    "pick": ((1, 1), [], Action.PICK),
    "place_other_segment": ((1, 1), [Action.PICK, Action.MOVE], Action.PLACE),
    "clean_segment_1": ((2, 1), [], Action.CLEAN),
}


@pytest.mark.slow
@pytest.mark.parametrize("case", list(CANONICAL))
def test_skill_from_its_canonical_state_reaches_the_models_successor(envs, case):
    layout, prefix, action = CANONICAL[case]
    env = envs(*layout)
    assert env.symbolic_state() == start_layout(*layout)
    controller = SkillController(env, MODEL)
    _run(controller, prefix)
    result = controller.execute(action)
    expected, outcome = MODEL.step(result.state_before, action)
    assert result.success, result.reason
    assert env.symbolic_state() == expected == result.state_after
    assert result.outcome == outcome and not result.improper
    assert 0 < result.steps <= get_skill_class(action).DEFAULT_CONFIG["max_steps"]
    if action == Action.CLEAN:
        assert env.skill_info()["sponge_grasped"] is False  # the sponge is back and released
        env.symbolic_state(check_sponge=True)  # no SPONGE_AWAY_FROM_HOME fault


def _qpos(env):
    return np.array(env.sim.data.qpos, copy=True)


@pytest.mark.slow
def test_improper_actions_are_refused_without_motion(envs):
    env = envs(1, 1)
    controller = SkillController(env, MODEL)
    # clean where the object lies
    before = _qpos(env)
    result = controller.execute(Action.CLEAN)
    assert result.improper and not result.success and result.steps == 0
    assert result.outcome == Outcome.IMPROPER and result.state_after == result.state_before
    np.testing.assert_array_equal(_qpos(env), before)
    # clean while holding the object
    _run(controller, [Action.PICK])
    before = _qpos(env)
    result = controller.execute(Action.CLEAN)
    assert result.improper and result.steps == 0 and result.reason.startswith("improper")
    np.testing.assert_array_equal(_qpos(env), before)


@pytest.mark.slow
@pytest.mark.parametrize("layout, action", [((1, 1), Action.PLACE), ((2, 1), Action.PICK)])
def test_ineffective_actions_do_nothing(envs, layout, action):
    env = envs(*layout)
    before = _qpos(env)
    result = SkillController(env, MODEL).execute(action)
    assert result.steps == 0 and not result.improper and result.success
    assert result.outcome == Outcome.INEFFECTIVE and result.state_after == result.state_before
    np.testing.assert_array_equal(_qpos(env), before)


@pytest.mark.slow
def test_plain_robosuite_env_is_refused_and_the_skill_env_action_spec_states_the_absolute_ranges():
    import robosuite

    plain = robosuite.make("TableClean", robots="Panda", has_renderer=False, has_offscreen_renderer=False,
                           use_camera_obs=False)
    try:
        with pytest.raises(ValueError, match="'input_type': 'delta'.*make_skill_env"):
            SkillController(plain)
    finally:
        plain.close()
    from tableclean_suite.controllers import make_skill_env

    env = make_skill_env(robots="UR5e")  # another robot's own config, switched the same way
    try:
        SkillController(env)  # accepted
        low, high = env.action_spec
        limits = skill_command_limits()
        np.testing.assert_array_equal(low[:6], limits[0])
        np.testing.assert_array_equal(high[:6], limits[1])
        assert env.robots[0].name == "UR5e" and high[2] > 1.0  # not the [-1, 1] of delta commands
    finally:
        env.close()


@pytest.mark.slow
@pytest.mark.parametrize("layout", START_LAYOUTS)
def test_optimal_plan_reaches_the_terminal_state_in_physics(envs, layout):
    env = envs(*layout)
    start = env.symbolic_state()
    assert start == start_layout(*layout)
    plan = MODEL.shortest_plan(start)
    from tableclean_suite.controllers.fast_control import fast_stepper_of

    commands = []
    stepper = fast_stepper_of(env) or env  # the path the SkillController sends its commands along
    step = stepper.step
    stepper.step = lambda action: commands.append(np.array(action)) or step(action)
    try:
        results = SkillController(env, MODEL).execute_plan(plan)
    finally:
        del stepper.step  # back to the class's method
    low, high = env.action_spec
    outside = [c for c in commands if np.any(c < low) or np.any(c > high)]
    assert commands and not outside, f"{len(outside)} commands outside action_spec, e.g. {outside[:1]}"
    assert [r.action for r in results] == [MODEL.action_name(a) for a in plan]  # names, as for user actions
    for result in results:
        assert result.success, f"{result.action}: {result.reason}"
        assert result.state_after == MODEL.step(result.state_before, result.action)[0]
    assert results[-1].state_after.is_terminal and results[-1].outcome == Outcome.TERMINAL
    assert env.symbolic_state().is_terminal
