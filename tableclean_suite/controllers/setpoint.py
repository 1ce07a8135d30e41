"""The skills' rate-limited setpoint and the command it gives, in one compiled function.

[Skill.step][tableclean_suite.controllers.skill.Skill.step] and the compiled
[control_loop][tableclean_suite.controllers.fast_control.control_loop] both call
[advance_command][tableclean_suite.controllers.setpoint.advance_command], so a phase run either way
produces bit-identical commands.
"""

from __future__ import annotations

import numba
import numpy as np

from tableclean_suite.controllers.osc import ACTION_DIM
from tableclean_suite.environments.object_geometry import wrap_angle

#: Index of the gripper command in the skill action (7,) [position (3), rotation vector (3), gripper].
GRIPPER_INDEX = ACTION_DIM - 1

wrap = numba.njit(cache=True)(wrap_angle)


@numba.njit(cache=True)
def advance_command(setpoint: np.ndarray, yaw_setpoint: float, yaw: float, target: np.ndarray,
                    max_move: float, max_turn: float, gripper: float, action: np.ndarray) -> float:
    """Move the setpoint one control step towards its target and write the skill action; returns the new yaw setpoint.

    Args:
        setpoint: (3,) position setpoint (m), moved in place at most ``max_move`` (m) towards ``target`` (3,) m.
        yaw_setpoint: commanded gripper yaw (rad), turned at most ``max_turn`` (rad) towards ``yaw`` (rad).
        gripper: gripper command in [-1, 1].
        action: (7,) output: the new setpoint, the rotation vector of a downward gripper at the new
            yaw setpoint (pi times (cos(yaw / 2), sin(yaw / 2), 0): a half turn about a horizontal axis), ``gripper``.

    Returns:
        the new yaw setpoint (rad, in [-pi, pi)).
    """
    turn = wrap(yaw - yaw_setpoint)
    yaw_setpoint = wrap(yaw_setpoint + min(max(turn, -max_turn), max_turn))
    d0, d1, d2 = target[0] - setpoint[0], target[1] - setpoint[1], target[2] - setpoint[2]
    distance = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if distance > max_move:
        scale = max_move / distance
        d0, d1, d2 = d0 * scale, d1 * scale, d2 * scale
    setpoint[0] += d0
    setpoint[1] += d1
    setpoint[2] += d2
    half = 0.5 * yaw_setpoint
    action[0], action[1], action[2] = setpoint[0], setpoint[1], setpoint[2]
    action[3], action[4], action[5] = np.pi * np.cos(half), np.pi * np.sin(half), 0.0
    action[GRIPPER_INDEX] = gripper
    return yaw_setpoint
