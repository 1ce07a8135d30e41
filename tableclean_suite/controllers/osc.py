"""The OSC_POSE controller configuration the skills need, and the action layout they emit.

The skills command *absolute world-frame* end-effector setpoints: position in
metres, orientation as a rotation vector (axis * angle, radians), and a gripper
command in [-1, 1] (-1 open, +1 closed), i.e. the 7-vector robosuite's BASIC
composite controller expects for a single Panda arm with its gripper:
``[x, y, z, rx, ry, rz, gripper]``.
"""

from __future__ import annotations

import copy
from typing import Mapping

import numpy as np
from robosuite import load_composite_controller_config

from tableclean_suite.environments.config import make_config, scene_geometry
from tableclean_suite.environments.robot_registry import osc_overrides

#: Name of the arm part in robosuite's BASIC composite config for single-arm robots.
ARM_PART = "right"
#: Gripper command that opens the fingers fully.
GRIPPER_OPEN = -1.0
#: Gripper command that closes the fingers (force-limited by the actuator).
GRIPPER_CLOSE = 1.0
#: Length of one skill action: position (3) + rotation vector (3) + gripper (1).
ACTION_DIM = 7

#: What the skills need of the arm's controller: robosuite's controller name, input type and frame.
SKILL_ARM_CONTROLLER = {
    "type": "OSC_POSE",
    "input_type": "absolute",  # setpoints are poses, not deltas (~30% fewer steps than delta mode)
    "input_ref_frame": "world",  # setpoints in the world frame, the frame of env.skill_info()
}

#: Overrides applied to the robot's default arm controller config (on top of `SKILL_ARM_CONTROLLER`).
OSC_OVERRIDES = {
    **SKILL_ARM_CONTROLLER,
    # stiffness (robosuite default 150): the skills rate-limit their setpoints, so a stiffer arm only
    # shrinks the tracking lag
    "kp": 300,
}

#: Workspace of the commanded grip-site position, relative to the table top (see [`skill_command_limits`][tableclean_suite.controllers.osc.skill_command_limits]):
#: margin around the table top's xy extent [m],
WORKSPACE_XY_MARGIN = 0.1
#: lowest commanded height below the table top [m] (a pressed sponge is commanded a few mm into the table),
WORKSPACE_BELOW_TABLE = 0.05
#: highest commanded height above the table top [m] (the skills hover 8 cm above it; the arm resets at 15 cm).
WORKSPACE_ABOVE_TABLE = 0.5
#: Bound of each rotation-vector component [rad]: every orientation has a rotation vector of norm <= pi.
ROTVEC_BOUND = np.pi


def skill_command_limits(task_config: Mapping | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(low, high)``, each (6,): the range of the arm's absolute commands in the scene of ``task_config``.

    Grip-site x, y, z [m, world frame] over the table top (grown by `WORKSPACE_XY_MARGIN`) from
    `WORKSPACE_BELOW_TABLE` below to `WORKSPACE_ABOVE_TABLE` above it; rotation vector [rad] in [-pi, pi].
    These are the ranges the env's ``action_spec`` reports (robosuite does not clip absolute OSC inputs).
    """
    geometry = scene_geometry(make_config(task_config))
    xy_low = geometry.table_center[:2] - geometry.table_half_size - WORKSPACE_XY_MARGIN
    xy_high = geometry.table_center[:2] + geometry.table_half_size + WORKSPACE_XY_MARGIN
    low = np.concatenate([xy_low, [geometry.table_top_z - WORKSPACE_BELOW_TABLE], np.full(3, -ROTVEC_BOUND)])
    high = np.concatenate([xy_high, [geometry.table_top_z + WORKSPACE_ABOVE_TABLE], np.full(3, ROTVEC_BOUND)])
    return low, high


def skill_controller_config(robot: str = "Panda", task_config: Mapping | None = None) -> dict:
    """The composite controller config to pass as ``controller_configs=`` when making the env.

    robosuite's default composite config for ``robot`` (``load_composite_controller_config(robot=robot)``)
    with its arm part switched to absolute world-frame OSC_POSE setpoints (see `OSC_OVERRIDES`)
    and its input range set to [`skill_command_limits`][tableclean_suite.controllers.osc.skill_command_limits] of ``task_config`` (so the env's
    ``action_spec`` states the real ranges).  Returns a fresh dict each call, so callers may modify it.

    Raises ``ValueError`` when the robot's config has no `ARM_PART` arm part.
    """
    config = copy.deepcopy(load_composite_controller_config(robot=robot))
    parts = config["body_parts"]
    if ARM_PART not in parts:
        raise ValueError(f"robot {robot!r} has no {ARM_PART!r} arm part in its default controller config "
                         f"(parts: {sorted(parts)})")
    low, high = skill_command_limits(task_config)
    parts[ARM_PART].update(OSC_OVERRIDES, **osc_overrides(robot), input_min=low.tolist(), input_max=high.tolist())
    return config


def check_skill_env(env) -> None:
    """Raise a clear error unless ``env``'s first arm takes the skills' `ACTION_DIM` absolute world-frame
    OSC_POSE commands (`SKILL_ARM_CONTROLLER`; plain ``robosuite.make`` gives delta commands in the base frame).

    Raises:
        TypeError: ``env`` has no robosuite robots.
        ValueError: another arm controller or action size; the message names what was found,
            what is needed, and [`make_skill_env`][tableclean_suite.controllers.make.make_skill_env].
    """
    remedy = ("make the env with tableclean_suite.controllers.make_skill_env(...) "
              "(or pass controller_configs=skill_controller_config(robot) to robosuite.make)")
    robots = getattr(env, "robots", None)
    if not robots:
        raise TypeError(f"SkillController needs a robosuite env with a robot; {type(env).__name__} has none: {remedy}")
    robot = robots[0]
    controller = robot.part_controllers.get(robot.arms[0])
    found = {
        "type": getattr(controller, "name", None),
        "input_type": getattr(controller, "input_type", None),
        "input_ref_frame": getattr(controller, "input_ref_frame", None),
    }
    if found != SKILL_ARM_CONTROLLER:
        raise ValueError(
            f"the arm controller of {type(env).__name__} is {found}, but the skills command absolute world-frame "
            f"poses and need {SKILL_ARM_CONTROLLER}: {remedy}"
        )
    if env.action_dim != ACTION_DIM:
        raise ValueError(
            f"{type(env).__name__} takes {env.action_dim}-dimensional actions, but the skills emit {ACTION_DIM} "
            f"(one arm: position, rotation vector, gripper): {remedy}"
        )
