"""MoveSkill: lift to a safe height and travel above the other segment, carrying anything held."""

from __future__ import annotations

import enum
from typing import Any, Mapping

import numpy as np

from tableclean_suite.controllers.osc import GRIPPER_CLOSE, GRIPPER_OPEN
from tableclean_suite.controllers.skill import BASE_CONFIG, Skill, Waypoint
from tableclean_suite.task import Action


class MovePhase(enum.Enum):
    """Phases of a move, in order."""

    LIFT = enum.auto()  # straight up to the hover height
    TRAVEL = enum.auto()  # across to above the other segment's centre
    DONE = enum.auto()


class MoveSkill(Skill):
    """Move the arm above the other segment; a held object stays gripped (gripper closed)."""

    action = Action.MOVE
    Phase = MovePhase
    DEFAULT_CONFIG = {
        **BASE_CONFIG,
        "max_steps": 200,
        "lift_tolerance": 0.03,  # m; the lift only needs to clear the table, not be exact
    }

    def on_reset(self, info: Mapping[str, Any]) -> None:
        self.target_segment = (self.state.arm + 1) % self.state.n_segments
        self.gripper = GRIPPER_CLOSE if self.state.holding else GRIPPER_OPEN
        self.start_xy = np.array(info["eef_pos"][:2], dtype=float)
        # m, lift target height: the hover height, or where the gripper already is if that is higher
        # (no pointless descent before travelling, e.g. from the reset pose)
        self.lift_z = max(float(info["eef_pos"][2]), float(info["table_top_z"]) + self.config["hover_height"])

    def waypoint(self, info: Mapping[str, Any]) -> Waypoint:
        if self.phase == MovePhase.LIFT:
            lift = np.array([self.start_xy[0], self.start_xy[1], self.lift_z])
            return Waypoint(lift, self.gripper, self.config["lift_tolerance"])
        goal_xy = self.segment_center(info, self.target_segment)[:2]
        return Waypoint(self.hover_point(info, goal_xy), self.gripper, self.config["reach_tolerance"])

    def next_phase(self, info: Mapping[str, Any]) -> MovePhase:
        return MovePhase(self.phase.value + 1)
