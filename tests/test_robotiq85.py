"""The corrected Robotiq 2F-85 (``gripper_types="Robotiq85Gripper"``): alone, hand down, opened and closed at
20 Hz control as robosuite drives it, its joints stay in range and its links do not press on each other, where
robosuite's own model fails both; mounted in the scene, it is the one the skills measure."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest
import robosuite
from robosuite.models import MujocoWorldBase
from robosuite.models.grippers import Robotiq85Gripper

import tableclean_suite  # noqa: F401  (registers the TableClean env)
from tableclean_suite.environments.gripper_models import CORRECTED, CorrectedRobotiq85Gripper

pytestmark = pytest.mark.slow


def open_close(gripper, control_steps: int = 15) -> tuple[float, float, float]:
    """(most self-contact normal force [N], most any joint left its range [rad], pad gap closed on nothing [m])
    of ``gripper`` over ``control_steps`` opening, then as many closing, control steps (25 steps of 2 ms each, the
    command moving 0.2 a step as robosuite's ``format_action``).  The hand points down on a joint of its own."""
    world = MujocoWorldBase()
    world.merge(gripper)
    hand = world.worldbody.find("body")
    world.worldbody.remove(hand)
    mount = ET.SubElement(world.worldbody, "body", name="mount", pos="0 0 0.5", quat="0 1 0 0")
    ET.SubElement(mount, "joint", name="mount", type="slide", axis="0 0 1", range="-1e-5 1e-5", limited="true")
    ET.SubElement(mount, "inertial", pos="0 0 0", mass="1", diaginertia="0.01 0.01 0.01")
    mount.append(hand)
    model = world.get_model(mode="mujoco")
    data = mujoco.MjData(model)
    joints = [j for j in range(model.njnt) if model.joint(j).name.startswith(gripper.naming_prefix)]
    actuators = [model.actuator(name).id for name in gripper.actuators]
    low, high = model.actuator_ctrlrange[actuators].T
    pads = [model.geom(gripper.important_geoms[side][0]).id for side in ("left_fingerpad", "right_fingerpad")]
    command, force, worst, past = np.zeros(len(actuators)), np.zeros(6), 0.0, 0.0
    for sign in (-1.0, 1.0):
        for _ in range(control_steps):
            command = np.clip(command + 0.2 * sign, -1.0, 1.0)
            data.ctrl[actuators] = 0.5 * (high + low) + 0.5 * (high - low) * command
            for _ in range(25):
                mujoco.mj_step(model, data)
                for i in range(data.ncon):  # every contact is the gripper's own: nothing else collides
                    mujoco.mj_contactForce(model, data, i, force)
                    worst = max(worst, abs(force[0]))
                for j in joints:
                    q, (a, b) = data.qpos[model.jnt_qposadr[j]], model.jnt_range[j]
                    past = max(past, a - q, q - b)
    return worst, past, mujoco.mj_geomDistance(model, data, pads[0], pads[1], 0.5, np.zeros(6))


def test_the_corrected_model_opens_and_closes_in_range_without_pressing_on_itself():
    worst, past, gap = open_close(CorrectedRobotiq85Gripper())
    assert worst < 1.0 and past < 0.01 and gap < 0.005, (worst, past, gap)


def test_robosuites_own_model_presses_on_itself_and_leaves_its_ranges():
    worst, past, _ = open_close(Robotiq85Gripper())
    assert worst > 20.0 and past > 0.1, (worst, past)


def test_the_scene_mounts_the_corrected_model_and_measures_its_opening():
    assert CORRECTED["Robotiq85Gripper"] is CorrectedRobotiq85Gripper
    env = robosuite.make("TableClean", robots="UR5e", gripper_types="Robotiq85Gripper")
    try:
        gripper = env.robots[0].gripper["right"]
        assert isinstance(gripper, CorrectedRobotiq85Gripper) and len(gripper.joints) == 2
        assert 0.08 < env.gripper_geometry.open_width < 0.09
    finally:
        env.close()
