"""PickSkill: open, approach the object from above, descend, close, confirm the grasp, lift."""

from __future__ import annotations

import enum
from typing import Any, Mapping

import numpy as np

from tableclean_suite.controllers.geometry import grasp_yaw
from tableclean_suite.controllers.osc import GRIPPER_CLOSE, GRIPPER_OPEN
from tableclean_suite.controllers.skill import BASE_CONFIG, Skill, SkillFailure, Waypoint
from tableclean_suite.task import Action

#: Settings shared by every skill that grasps a box from above (PickSkill, CleanSkill's sponge grasp).
GRASP_CONFIG = {
    "grasp_depth": 0.0,  # m below the box centre at which the grip site closes (if the fingertips allow)
    "fingertip_depth": 0.0135,  # m, lowest point of the Panda's finger collision meshes below its grip site
    "tip_clearance": 0.010,  # m the fingertips stay above the box's bottom (and so above the table)
    "close_min_steps": 4,  # control steps to keep closing before checking the fingers settled
    "descend_speed": 0.25,  # m/s, slower final approach
    "grasp_retries": 1,  # re-approaches after a grasp that was not confirmed
}


def grasp_point(box_pos: np.ndarray, box_half_size: np.ndarray, config: Mapping[str, Any]) -> np.ndarray:
    """(3,) grip-site target to grasp an upright box resting at ``box_pos`` (its centre, m).

    ``grasp_depth`` below the centre, raised if needed so that the fingertips stay
    ``tip_clearance`` above the box's bottom: a flat box (the sponge) is gripped
    high, so the fingers never drag on the surface it rests on.
    """
    bottom = float(box_pos[2]) - float(box_half_size[2])
    floor = bottom + config["fingertip_depth"] + config["tip_clearance"]
    z = max(float(box_pos[2]) - config["grasp_depth"], floor)
    return np.array([box_pos[0], box_pos[1], z])


class PickPhase(enum.Enum):
    """Phases of a pick, in order."""

    HOVER = enum.auto()  # open the gripper above the object
    DESCEND = enum.auto()  # down to the grasp point
    CLOSE = enum.auto()  # close until the fingers settle, then confirm the grasp
    LIFT = enum.auto()  # back up to the hover height
    DONE = enum.auto()


class PickSkill(Skill):
    """Pick the object lying on the arm's segment."""

    action = Action.PICK
    Phase = PickPhase
    DEFAULT_CONFIG = {**BASE_CONFIG, **GRASP_CONFIG, "max_steps": 250}

    def on_reset(self, info: Mapping[str, Any]) -> None:
        self.retries_left = self.config["grasp_retries"]
        self.yaw = grasp_yaw(info["object_quat"], info["object_half_size"], self.config["nominal_yaw"])

    def waypoint(self, info: Mapping[str, Any]) -> Waypoint:
        obj = np.asarray(info["object_pos"], dtype=float)
        tol = self.config["reach_tolerance"]
        if self.phase == PickPhase.HOVER:
            return Waypoint(self.hover_point(info, obj[:2]), GRIPPER_OPEN, tol)
        if self.phase == PickPhase.DESCEND:
            grasp = grasp_point(obj, info["object_half_size"], self.config)
            return Waypoint(grasp, GRIPPER_OPEN, tol, speed=self.config["descend_speed"])
        if self.phase == PickPhase.CLOSE:
            return Waypoint(self._setpoint.copy(), GRIPPER_CLOSE, np.inf, min_steps=self.config["close_min_steps"])
        return Waypoint(self.hover_point(info, obj[:2]), GRIPPER_CLOSE, tol)

    def next_phase(self, info: Mapping[str, Any]) -> PickPhase:
        if self.phase == PickPhase.CLOSE and not info["object_grasped"]:
            if self.retries_left <= 0:
                raise SkillFailure("grasp not confirmed")
            self.retries_left -= 1
            return PickPhase.HOVER
        return PickPhase(self.phase.value + 1)
