"""MoveSkill: lift to a safe height and travel above the next segment (k -> k + 1, N -> 1), carrying anything held."""

from __future__ import annotations

import enum
from typing import Any, Mapping

import numpy as np

from tableclean_suite.controllers.configs import MoveConfig
from tableclean_suite.controllers.osc import GRIPPER_CLOSE, GRIPPER_OPEN
from tableclean_suite.controllers.primitives import PrimitiveSkill, Reach
from tableclean_suite.task import Action


MovePhase = enum.Enum("MovePhase", ["LIFT", "TRAVEL", "DONE"], module=__name__)
"""Phases of a move, in order: two [`Reach`][tableclean_suite.controllers.primitives.Reach] primitives, LIFT straight
up to the hover height and TRAVEL above the target segment's centre."""


class MoveSkill(PrimitiveSkill):
    """Move the arm above the next segment; a held object stays gripped (gripper closed).

    Subclasses change the destination with [`target_segment`][tableclean_suite.controllers.move.MoveSkill.target_segment] (e.g. a MOVE_BACK skill).
    """

    action = Action.MOVE
    Phase = MovePhase
    Config = MoveConfig
    DEFAULT_CONFIG = MoveConfig().as_dict()

    def target_segment(self) -> int:
        """The 0-based segment to end above: the next one, k -> k + 1 (N -> 1)."""
        return (self.state.arm + 1) % self.state.n_segments

    def build(self, info: Mapping[str, Any]):
        self.goal_segment = self.target_segment()
        self.gripper = GRIPPER_CLOSE if self.state.holding else GRIPPER_OPEN
        self.start_xy = np.array(info["eef_pos"][:2], dtype=float)
        # m, lift target height: the hover height, or where the gripper already is if that is higher
        # (no pointless descent before travelling, e.g. from the reset pose)
        self.lift_z = max(float(info["eef_pos"][2]), self.hover_z(info))
        return [
            ("", Reach("LIFT", lambda skill, info: np.array([*self.start_xy, self.lift_z]), self.gripper,
                       self.config["lift_tolerance"])),
            ("", Reach("TRAVEL", lambda skill, info: skill.hover_point(
                info, skill.segment_center(info, self.goal_segment)[:2]), self.gripper)),
        ]
