"""PickSkill: grasp the lowest-numbered object on the arm's segment (a :class:`~.primitives.Grasp`)."""

from __future__ import annotations

import enum
from typing import Any, Mapping

from tableclean_suite.controllers.primitives import (
    GRASP_SLIP_TOLERANCE,
    Grasp,
    PrimitiveSkill,
    grasp_point,
    object_body,
)
from tableclean_suite.controllers.skill import BASE_CONFIG, SkillFailure
from tableclean_suite.task import Action

__all__ = ["GRASP_CONFIG", "PickPhase", "PickSkill", "grasp_point"]

#: Settings shared by every skill that grasps from above (PickSkill, CleanSkill's sponge grasp).
GRASP_CONFIG = {
    "grasp_depth": 0.0,  # m below the sponge's centre at which the grip site closes (objects: the holding height)
    "fingertip_depth": BASE_CONFIG["fingertip_depth"],  # m, lowest point of the finger meshes below the grip site
    "tip_clearance": 0.010,  # m the fingertips stay above the body's bottom (and so above the table)
    "palm_clearance": 0.005,  # m a grasped object's top stays below the hand (the gripper's measured palm height)
    "close_min_steps": 4,  # control steps to keep closing before checking the fingers settled
    "descend_speed": 0.25,  # m/s, slower final approach
    "grasp_retries": 1,  # re-approaches after a grasp that was not confirmed
    "grasp_slip_tolerance": GRASP_SLIP_TOLERANCE,  # m a lifted body may trail the grip site's rise
}


class PickPhase(enum.Enum):
    """Phases of a pick, in order (the :class:`~.primitives.Grasp` primitive's)."""

    HOVER = enum.auto()  # open the gripper above the object
    DESCEND = enum.auto()  # down to the grasp point
    CLOSE = enum.auto()  # close until the fingers settle, then confirm the grasp
    LIFT = enum.auto()  # back up to the hover height
    DONE = enum.auto()


class PickSkill(PrimitiveSkill):
    """Pick the lowest-numbered object lying on the arm's segment, across its narrow side at its holding height."""

    action = Action.PICK
    Phase = PickPhase
    DEFAULT_CONFIG = {**BASE_CONFIG, **GRASP_CONFIG, "max_steps": 250}

    def build(self, info: Mapping[str, Any]):
        lying = self.state.objects_on(self.state.arm)
        if not lying:
            raise SkillFailure(f"no object lies on segment {self.state.arm + 1}")
        self.target = lying[0]
        return [("", Grasp(object_body(self.target, info), "grasp"))]
