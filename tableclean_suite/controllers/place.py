"""PlaceSkill: descend over the arm's segment, release the object, retreat up."""

from __future__ import annotations

import enum
from typing import Any, Mapping

import numpy as np

from tableclean_suite.controllers.osc import GRIPPER_CLOSE, GRIPPER_OPEN
from tableclean_suite.controllers.skill import BASE_CONFIG, Skill, Waypoint
from tableclean_suite.task import Action


class PlacePhase(enum.Enum):
    """Phases of a place, in order."""

    ALIGN = enum.auto()  # hover above the segment centre
    DESCEND = enum.auto()  # lower the object to just above the table
    RELEASE = enum.auto()  # open until the fingers settle
    RETREAT = enum.auto()  # up to the hover height
    DONE = enum.auto()


class PlaceSkill(Skill):
    """Put the held object down at the centre of the arm's segment."""

    action = Action.PLACE
    Phase = PlacePhase
    DEFAULT_CONFIG = {
        **BASE_CONFIG,
        "max_steps": 250,
        "place_clearance": 0.006,  # m between the object's bottom and the table top at release
        "descend_speed": 0.25,  # m/s, slower final approach
        "release_min_steps": 3,  # control steps to keep opening before checking the fingers settled
    }

    def on_reset(self, info: Mapping[str, Any]) -> None:
        eef = np.asarray(info["eef_pos"], dtype=float)
        obj = np.asarray(info["object_pos"], dtype=float)
        # height of the grip site above the held object's centre, measured now (the grasp may have slipped)
        self.hold_offset_z = float(eef[2] - obj[2])
        self.place_xy = self.segment_center(info, self.state.arm)[:2]

    def waypoint(self, info: Mapping[str, Any]) -> Waypoint:
        tol = self.config["reach_tolerance"]
        if self.phase == PlacePhase.ALIGN:
            return Waypoint(self.hover_point(info, self.place_xy), GRIPPER_CLOSE, tol)
        if self.phase == PlacePhase.DESCEND:
            half_z = float(info["object_half_size"][2])
            z = float(info["table_top_z"]) + half_z + self.config["place_clearance"] + self.hold_offset_z
            pos = np.array([self.place_xy[0], self.place_xy[1], z])
            return Waypoint(pos, GRIPPER_CLOSE, tol, speed=self.config["descend_speed"])
        if self.phase == PlacePhase.RELEASE:
            return Waypoint(self._setpoint.copy(), GRIPPER_OPEN, np.inf, min_steps=self.config["release_min_steps"])
        return Waypoint(self.hover_point(info, self.place_xy), GRIPPER_OPEN, tol)

    def phase_ready(self, info: Mapping[str, Any]) -> bool:
        return self.phase != PlacePhase.RELEASE or not info["object_grasped"]

    def next_phase(self, info: Mapping[str, Any]) -> PlacePhase:
        return PlacePhase(self.phase.value + 1)
