"""Randomised dynamics of the TableClean scene (``randomization=``) and the skills' measured loops."""

from dataclasses import replace

import numpy as np
import pytest

from tableclean_suite.controllers import SkillController, make_skill_env
from tableclean_suite.controllers.fast_control import fast_stepper_of
from tableclean_suite.controllers.configs import GRASP_SLIP_TOLERANCE
from tableclean_suite.controllers.primitives import Body, Grasp
from tableclean_suite.controllers.skill import SkillFailure
from tableclean_suite.environments.randomization import (
    ALLOWED_SCALE,
    DEFAULT_ON,
    OFF,
    RANGE_FIELDS,
    DynamicsRandomization,
    resolve_randomization,
)
from tableclean_suite.robosuite_adapter import joint_vel_indexes
from tableclean_suite.task import Action, TaskModel, start_layout

MODEL = TaskModel()
N_JOINTS = 7  # the Panda's arm joints
GRAVITY = 9.81  # m/s^2, MuJoCo's default
WEIGHT_TOLERANCE = 0.2  # relative; a resting sponge's contact force is its weight to within this
SETTLE_STEPS = 200  # physics steps for a dropped sponge to come to rest (0.4 s at 2 ms)


# --------------------------------------------------------------------------------------------
# the ranges (no physics)
# --------------------------------------------------------------------------------------------
def test_off_is_the_default_and_draws_nothing_on():
    assert DynamicsRandomization() == OFF and not OFF.enabled
    assert DEFAULT_ON.enabled
    assert resolve_randomization(None) is OFF and resolve_randomization("paper") is OFF
    assert resolve_randomization("on") is DEFAULT_ON and resolve_randomization(True) is DEFAULT_ON
    # a partial mapping starts from the documented defaults, not from "off" (which would silently stop the rest)
    assert resolve_randomization({"friction_scale": (0.8, 1.2)}) == replace(DEFAULT_ON, friction_scale=(0.8, 1.2))
    assert resolve_randomization({"base": "off", "friction_scale": (0.8, 1.2)}) == replace(OFF, friction_scale=(0.8, 1.2))


@pytest.mark.parametrize("field, value", [
    ("friction_scale", (1.2, 0.8)),  # low > high
    ("object_mass_scale", (0.0, 1.0)),  # below the allowed scale
    ("sponge_size_scale", (0.5, 1.0)),  # below the allowed size scale
    ("osc_kp_scale", "fast"),  # not a pair
    ("friction_scale", "12"),  # a two-character string is not a pair of numbers
    ("object_mass_scale", (True, True)),  # bools are not scales
    ("friction_scale", {0.9: 1, 1.1: 2}),  # a two-key mapping is not a pair
    ("joint_damping_scale", (1.0, float("nan"))),
    ("sponge_home_noise", -0.01),  # a negative half-width
    ("object_yaw_noise", 2.0),  # beyond a quarter turn
    ("object_yaw_noise", "0.2"),  # a string is refused like string ranges
    ("sponge_yaw_noise", True),
    ("friction_scale", (0.3, 2.0)),  # beyond what the skills were checked on (they lose the sponge)
    ("friction_scale", (1.5, 4.0)),
])
def test_bad_ranges_raise_naming_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        DynamicsRandomization(**{field: value})


def test_bad_user_values_raise_naming_them():
    with pytest.raises(ValueError, match="'wild'.*allowed"):
        resolve_randomization("wild")
    with pytest.raises(ValueError, match="unknown randomization field.*'gravity'"):
        resolve_randomization({"gravity": (0.9, 1.1)})
    with pytest.raises(ValueError, match="randomization must be"):
        resolve_randomization(3.0)
    with pytest.raises(ValueError, match="'base' must be one of"):
        resolve_randomization({"base": "wild", "friction_scale": (0.8, 1.2)})


def test_friction_beyond_the_checked_range_names_the_reason():
    with pytest.raises(ValueError, match="checked up to this"):
        resolve_randomization({"friction_scale": (0.3, 2.0)})


def test_samples_lie_in_the_ranges_and_a_seed_reproduces_them():
    samples = [DEFAULT_ON.sample(np.random.default_rng(seed), 2, N_JOINTS) for seed in range(50)]
    for sample in samples:
        values = {
            "object_mass_scale": sample.object_mass_scale, "sponge_mass_scale": [sample.sponge_mass_scale],
            "object_size_scale": sample.object_size_scale, "sponge_size_scale": [sample.sponge_size_scale],
            "friction_scale": [sample.table_friction_scale, *sample.object_friction_scale,
                               sample.sponge_friction_scale],
            "joint_damping_scale": sample.joint_damping_scale, "osc_kp_scale": [sample.osc_kp_scale],
            "osc_damping_ratio_scale": [sample.osc_damping_ratio_scale],
        }
        for name, drawn in values.items():
            low, high = getattr(DEFAULT_ON, name)
            assert all(low <= v <= high for v in drawn), (name, drawn)
        assert len(sample.object_mass_scale) == 2 and len(sample.joint_damping_scale) == N_JOINTS
        assert np.all(np.abs(sample.sponge_home_offset) <= DEFAULT_ON.sponge_home_noise)
        assert abs(sample.sponge_yaw) <= DEFAULT_ON.sponge_yaw_noise
    assert samples[0] == DEFAULT_ON.sample(np.random.default_rng(0), 2, N_JOINTS)
    assert samples[0] != samples[1]
    assert set(RANGE_FIELDS) <= set(DEFAULT_ON.to_dict()) and min(ALLOWED_SCALE) > 0


# --------------------------------------------------------------------------------------------
# the grasp's slip check (a hand-written body and skill, no physics)
# --------------------------------------------------------------------------------------------
class _Skill:
    config = {"nominal_yaw": 0.0, "grasp_slip_tolerance": GRASP_SLIP_TOLERANCE}
    yaw = 0.0


def _held(z_of):
    return Body(pos=lambda info: np.array([0.0, 0.0, z_of(info)]), quat=lambda info: np.array([0.0, 0.0, 0.0, 1.0]),
                half_size=lambda info: np.array([0.02, 0.02, 0.02]), grasped=lambda info: info["grasped"],
                yaw_rule="any")


def test_grasp_confirms_by_slip_and_a_slip_or_a_drop_is_a_retryable_failure():
    eef0, body0, lift = 0.85, 0.82, 0.08
    closed = {"eef_pos": np.array([0, 0, eef0]), "eef_quat": np.array([0.0, 0.0, 0.0, 1.0]), "grasped": True,
              "body_z": body0}
    for trail in (0.0, GRASP_SLIP_TOLERANCE / 2, 0.05):
        grasp = Grasp(_held(lambda info: info["body_z"]), "test grasp")
        grasp.start(_Skill(), closed)
        assert grasp.next(_Skill(), closed, "CLOSE") == "LIFT"
        lifted = {**closed, "eef_pos": np.array([0, 0, eef0 + lift]), "body_z": body0 + lift - trail}
        assert grasp.slipped(_Skill(), lifted) == pytest.approx(trail)
        if trail <= GRASP_SLIP_TOLERANCE:
            assert grasp.next(_Skill(), lifted, "LIFT") is None  # the grasp ends confirmed
            continue
        with pytest.raises(SkillFailure, match="slipped 50 mm") as failure:  # the skill's retries re-grasp
            grasp.next(_Skill(), lifted, "LIFT")
        assert failure.value.redo == 0
    grasp = Grasp(_held(lambda info: info["body_z"]), "test grasp")
    grasp.start(_Skill(), closed)
    grasp.next(_Skill(), closed, "CLOSE")
    dropped = {**closed, "eef_pos": np.array([0, 0, eef0 + lift]), "grasped": False}
    with pytest.raises(SkillFailure, match="lost while lifting") as failure:  # lost contact: re-grasp
        grasp.next(_Skill(), dropped, "LIFT")
    assert failure.value.redo == 0


# --------------------------------------------------------------------------------------------
# the scene (physics)
# --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def envs():
    made = {}

    def get(name, randomization):
        if name not in made:
            made[name] = make_skill_env(object_segment=2, arm_segment=1, randomization=randomization)
        return made[name]

    yield get
    for env in made.values():
        env.close()


def _reset(env, seed):
    env.rng = np.random.default_rng(seed)
    env.reset()
    return env


def _scene(env):
    """What the randomisation changes, read back from the live model, data and controller."""
    model = env.sim.model
    robot = env.robots[0]
    osc = robot.composite_controller.part_controllers[robot.arms[0]]
    bodies = [*env.object_body_ids, env.sponge_body_id]
    return {
        "body_mass": model.body_mass[bodies].copy(),
        "geom_friction": model.geom_friction.copy(),
        "geom_size": model.geom_size.copy(),
        "dof_damping": model.dof_damping.copy(),
        "kp": np.array(osc.kp, dtype=float), "kd": np.array(osc.kd, dtype=float),
        "qpos": env.sim.data.qpos.copy(),
    }


def test_a_seed_reproduces_the_randomised_scene_and_skill_outcome(envs):
    first, second = envs("a", "on"), envs("b", "on")
    runs = []
    for env in (first, second, first):
        _reset(env, 7)
        scene = _scene(env)
        result = SkillController(env, MODEL).execute(Action.PICK)
        runs.append((scene, result.success, result.steps, env.sim.data.qpos.copy()))
    for scene, success, steps, qpos in runs[1:]:
        for key, value in runs[0][0].items():
            np.testing.assert_array_equal(scene[key], value, err_msg=key)
        assert (success, steps) == runs[0][1:3]
        np.testing.assert_array_equal(qpos, runs[0][3])
    assert runs[0][1], "the pick failed in the randomised scene"
    other = _scene(_reset(first, 8))
    for key in ("body_mass", "geom_friction", "geom_size", "dof_damping", "kp", "qpos"):
        assert not np.array_equal(other[key], runs[0][0][key]), key


def test_randomised_values_lie_in_the_ranges_and_reach_the_controllers(envs):
    plain, env = envs("off", None), envs("a", "on")
    nominal = _scene(_reset(plain, 3))
    assert plain.dynamics_sample is None and "randomization" not in plain.get_ep_meta()
    for seed in range(4):
        scene = _scene(_reset(env, seed))
        sample = env.dynamics_sample
        mass = scene["body_mass"] / nominal["body_mass"]
        # a mass follows the resized volume (density constant), times the mass scale
        assert mass[-1] == pytest.approx(sample.sponge_mass_scale * sample.sponge_size_scale ** 3)
        assert mass[0] == pytest.approx(sample.object_mass_scale[0] * sample.object_size_scale[0] ** 3)
        for name, drawn in (("sponge_mass_scale", sample.sponge_mass_scale), ("object_mass_scale", mass[0] /
                                                                             sample.object_size_scale[0] ** 3)):
            low, high = getattr(DEFAULT_ON, name)
            assert low <= drawn <= high, name
        np.testing.assert_allclose(env.object_measures.half_sizes[0],
                                   plain.object_measures.half_sizes[0] * sample.object_size_scale[0])
        np.testing.assert_allclose(env.skill_info()["sponge_half_size"],
                                   np.array(plain.task_config["sponge_half_size"]) * sample.sponge_size_scale)
        arm = np.asarray(joint_vel_indexes(env.robots[0]))
        np.testing.assert_allclose(scene["dof_damping"][arm] / nominal["dof_damping"][arm], sample.joint_damping_scale)
        np.testing.assert_allclose(scene["kp"], nominal["kp"] * sample.osc_kp_scale)
        ratio = scene["kd"] / (2 * np.sqrt(scene["kp"]))
        np.testing.assert_allclose(ratio, nominal["kd"] / (2 * np.sqrt(nominal["kp"])) * sample.osc_damping_ratio_scale)
        # the abstraction reads the start state with the resized bodies
        assert env.symbolic_state() == start_layout(2, 1)
        meta = env.get_ep_meta()
        assert meta["dynamics_sample"] == sample.to_dict() and meta["randomization"] == DEFAULT_ON.to_dict()
        # the compiled control path steps with the controller holding the randomised gains
        assert SkillController(env, MODEL).execute(Action.MOVE).success
        osc = fast_stepper_of(env).osc
        np.testing.assert_allclose(np.stack([osc.kp, osc.kd]), np.stack([scene["kp"], scene["kd"]]))


def test_bad_randomization_is_refused_naming_it():
    with pytest.raises(ValueError, match="'wild'"):
        make_skill_env(randomization="wild")
    with pytest.raises(ValueError, match="friction_scale"):
        make_skill_env(randomization={"friction_scale": (2.0, 1.0)})


def test_press_force_measures_the_resting_sponge_weight(envs):
    env = _reset(envs("off", None), 0)
    assert env.sponge_press_force() == 0.0  # at home, on its stand
    info = env.skill_info()
    centre = info["segment_centers"][0] + [0.0, 0.0, info["sponge_half_size"][2]]
    env.sim.data.set_joint_qpos(env.sponge.joints[0], np.concatenate([centre, [1, 0, 0, 0]]))
    env.sim.forward()
    for _ in range(SETTLE_STEPS):
        env.sim.step()
    weight = env.sim.model.body_mass[env.sponge_body_id] * GRAVITY
    assert env.sponge_press_force() == pytest.approx(weight, rel=WEIGHT_TOLERANCE)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_optimal_paper_episode_succeeds_under_randomisation(seed):
    env = make_skill_env(object_segment=None, arm_segment=None, randomization="on")
    try:
        _reset(env, seed)
        results = SkillController(env, MODEL).execute_plan(MODEL.shortest_plan(env.symbolic_state()))
        for result in results:
            assert result.success, f"{MODEL.action_name(result.action)}: {result.reason}"
        assert results[-1].state_after.is_terminal
    finally:
        env.close()
