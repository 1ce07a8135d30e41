"""PickSkill: grasp the lowest-numbered object on the arm's segment (a [`Grasp`][tableclean_suite.controllers.primitives.Grasp])."""

from __future__ import annotations

import enum
from typing import Any, Mapping

from tableclean_suite.controllers.configs import PickConfig
from tableclean_suite.controllers.primitives import Grasp, PrimitiveSkill, object_body
from tableclean_suite.controllers.skill import SkillFailure
from tableclean_suite.task import Action


PickPhase = enum.Enum("PickPhase", [*Grasp.PHASES, "DONE"], module=__name__)
"""Phases of a pick, in order: the [`Grasp`][tableclean_suite.controllers.primitives.Grasp] primitive's."""


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
