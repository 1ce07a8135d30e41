"""The corrected Robotiq 2F-140 (``gripper_types="Robotiq140Gripper"``): mounted by name while robosuite keeps its own;
its per-gripper skill settings merge after the robot's; alone, closed as robosuite drives it, its pads stay
parallel, its links do not press on each other and it comes to rest, where robosuite's model does neither; (slow)
in the scene its fingertip setting is what the model measures and a paper episode from a random start completes."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest
from robosuite.models import MujocoWorldBase
from robosuite.models.grippers import GRIPPER_MAPPING, Robotiq140Gripper

from tableclean_suite.bench import robot_table
from tableclean_suite.environments.gripper_models import CorrectedRobotiq140Gripper, mounted_gripper
from tableclean_suite.environments.grippers import GRIPPER_SKILLS
from tableclean_suite.environments.robot_registry import scene_gripper_types, skill_overrides


def test_the_scene_mounts_the_corrected_model_and_robosuite_keeps_its_own():
    assert scene_gripper_types("UR5e", "Robotiq140Gripper") == "CorrectedRobotiq140Gripper"
    assert GRIPPER_MAPPING["Robotiq140Gripper"] is Robotiq140Gripper
    assert GRIPPER_MAPPING["CorrectedRobotiq140Gripper"] is CorrectedRobotiq140Gripper
    assert mounted_gripper("PandaGripper") == "PandaGripper" and mounted_gripper(None) is None
    assert robot_table.gripper_name("UR5e", "Robotiq140Gripper") == "CorrectedRobotiq140Gripper"  # the one that ran


def test_gripper_settings_merge_after_the_robots_and_leave_the_panda_alone():
    gripper = GRIPPER_SKILLS["Robotiq140Gripper"]["*"]
    assert skill_overrides("Sawyer", "clean", "Robotiq140Gripper") == {"hover_still_speed": 0.05, **gripper}
    assert skill_overrides("Panda", "clean", "PandaGripper") == skill_overrides("Panda", "clean") == {}


def close_alone(gripper, control_steps: int = 30) -> tuple[float, int, float]:
    """(most self-contact normal force [N], the first control step after which every finger joint moves under 2e-4
    rad a step, most the left pad leaves parallel [rad]) of ``gripper`` hand down, closing on nothing for
    ``control_steps`` control steps at 20 Hz (25 physics steps of 2 ms each), commanded as robosuite's
    ``format_action``."""
    world = MujocoWorldBase()
    world.merge(gripper)
    hand = world.worldbody.find("body")
    world.worldbody.remove(hand)
    mount = ET.SubElement(world.worldbody, "body", name="mount", pos="0 0 0.5", quat="0 1 0 0")
    mount.append(hand)
    model = world.get_model(mode="mujoco")
    data = mujoco.MjData(model)
    joints = [model.jnt_qposadr[j] for j in range(model.njnt) if model.joint(j).name.startswith(gripper.naming_prefix)]
    actuators = [model.actuator(name).id for name in gripper.actuators]
    low, high = model.actuator_ctrlrange[actuators].T
    left, left_finger = (model.jnt_qposadr[model.joint(gripper.naming_prefix + name).id]
                         for name in ("finger_joint", "left_inner_finger_joint"))
    force, worst, skew, settled = np.zeros(6), 0.0, 0.0, None
    gripper.current_action = np.zeros(len(actuators))
    for step in range(control_steps):
        command = gripper.format_action(np.array([1.0]))
        data.ctrl[actuators] = 0.5 * (high + low) + 0.5 * (high - low) * command
        before = data.qpos[joints].copy()
        for _ in range(25):
            mujoco.mj_step(model, data)
            for i in range(data.ncon):  # every contact is the gripper's own: nothing else collides
                mujoco.mj_contactForce(model, data, i, force)
                worst = max(worst, abs(force[0]))
        skew = max(skew, abs(data.qpos[left_finger] - data.qpos[left]))
        still = np.max(np.abs(data.qpos[joints] - before)) < 2e-4
        settled = (step if settled is None else settled) if still else None
    return worst, settled, skew


@pytest.mark.slow
def test_the_corrected_model_closes_parallel_and_comes_to_rest_where_robosuites_does_not():
    worst, settled, skew = close_alone(CorrectedRobotiq140Gripper())
    assert worst < 1.0 and settled is not None and settled < 28 and skew < 0.02, (worst, settled, skew)
    worst, settled, skew = close_alone(Robotiq140Gripper())
    assert worst > 100.0 and settled is None and skew > 0.1, (worst, settled, skew)


@pytest.mark.slow
def test_in_the_scene_its_fingertips_are_measured_and_a_random_start_completes():
    from tableclean_suite.controllers import SkillController, make_skill_env
    from tableclean_suite.environments.object_geometry import collision_points

    env = make_skill_env(None, None, robots="UR5e", gripper_types="Robotiq140Gripper", task="paper", seed=0)
    try:
        gripper = env.robots[0].gripper["right"]
        assert isinstance(gripper, CorrectedRobotiq140Gripper) and len(gripper.joints) == 2
        # the pads at the knuckles' open end, the followers moved with them (left at 0: 4.8 cm)
        assert 0.084 < env.gripper_geometry.open_width < 0.086
        # the fingertip setting is the closed fingers' lowest point below the grip site, read from the model
        model, data = env.sim.model._model, mujoco.MjData(env.sim.model._model)
        data.qpos[:] = env.sim.data.qpos
        prefix = gripper.naming_prefix
        for follower, leader, factor in CorrectedRobotiq140Gripper.COUPLING:
            closed = 0.7 * (1.0 if leader == "finger_joint" else -1.0)
            data.qpos[model.joint(prefix + leader).qposadr[0]] = closed
            data.qpos[model.joint(prefix + follower).qposadr[0]] = factor * closed
        mujoco.mj_kinematics(model, data)
        site = model.site(gripper.important_sites["grip_site"]).id
        down = data.site_xmat[site].reshape(3, 3)[:, 2]
        depth = max(float(np.max((data.xpos[b] + collision_points(model, data, b, [g]) @ data.xmat[b].reshape(3, 3).T
                                  - data.site_xpos[site]) @ down))
                    for key in ("left_finger", "right_finger") for name in gripper.important_geoms[key]
                    for g in [model.geom(name).id] for b in [int(model.geom_bodyid[g])])
        assert GRIPPER_SKILLS["Robotiq140Gripper"]["*"]["fingertip_depth"] == pytest.approx(depth, abs=1e-3)
        controller = SkillController(env)
        assert controller.skill_config("clean")["fingertip_depth"] == pytest.approx(depth, abs=1e-3)
        env.reset()
        results = controller.execute_plan(controller.model.shortest_plan(env.symbolic_state()))
        assert all(r.success for r in results), [r.reason for r in results]
        assert env.symbolic_state().is_terminal
    finally:
        env.close()
