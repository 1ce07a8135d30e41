"""PickSkill: grasp the lowest-numbered object on the arm's segment (a [`Grasp`][tableclean_suite.controllers.primitives.Grasp])."""

from __future__ import annotations

import enum
from typing import Any, Mapping

from tableclean_suite.controllers.configs import PickConfig
from tableclean_suite.controllers.primitives import (
    Grasp,
    PrimitiveSkill,
    grasp_point,
    object_body,
)
from tableclean_suite.controllers.skill import SkillFailure
from tableclean_suite.task import Action

__all__ = ["PickPhase", "PickSkill", "grasp_point"]


class PickPhase(enum.Enum):
    """Phases of a pick, in order (the [`Grasp`][tableclean_suite.controllers.primitives.Grasp] primitive's)."""

    HOVER = enum.auto()  # open the gripper above the object
    DESCEND = enum.auto()  # down to the grasp point
    CLOSE = enum.auto()  # close until the fingers settle, then confirm the grasp
    LIFT = enum.auto()  # back up to the hover height
    DONE = enum.auto()


class PickSkill(PrimitiveSkill):
    """Pick the lowest-numbered object lying on the arm's segment, across its narrow side at its holding height."""

    action = Action.PICK
    Phase = PickPhase
    Config = PickConfig
    DEFAULT_CONFIG = PickConfig().as_dict()

    def build(self, info: Mapping[str, Any]):
        lying = self.state.objects_on(self.state.arm)
        if not lying:
            raise SkillFailure(f"no object lies on segment {self.state.arm + 1}")
        self.target = lying[0]
        return [("", Grasp(object_body(self.target, info), "grasp"))]
