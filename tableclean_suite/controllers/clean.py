"""CleanSkill: fetch the sponge, wipe the arm's segment until clean (bounded), bring the sponge home."""

from __future__ import annotations

import enum
from typing import Any, Mapping

import numpy as np

from tableclean_suite.controllers.geometry import box_lowest_z, grasp_yaw, world_footprint
from tableclean_suite.controllers.osc import GRIPPER_CLOSE, GRIPPER_OPEN
from tableclean_suite.controllers.pick import GRASP_CONFIG, grasp_point
from tableclean_suite.controllers.skill import BASE_CONFIG, Skill, SkillFailure, Waypoint
from tableclean_suite.controllers.wipe_pattern import boustrophedon
from tableclean_suite.task import Action


class CleanPhase(enum.Enum):
    """Phases of a clean, in order (WIPE repeats over the stroke points and passes)."""

    TO_SPONGE = enum.auto()  # hover above the sponge, gripper open
    SPONGE_DESCEND = enum.auto()  # down to the sponge's grasp point
    SPONGE_CLOSE = enum.auto()  # close, then confirm the sponge is grasped
    SPONGE_LIFT = enum.auto()  # up to the hover height
    TO_SEGMENT = enum.auto()  # hover above the first stroke point
    PRESS = enum.auto()  # down until the sponge touches the table
    WIPE = enum.auto()  # follow the stroke points pressing down; repeat passes while dirty
    WIPE_LIFT = enum.auto()  # up to the hover height
    TO_HOME = enum.auto()  # hover above the sponge home
    HOME_DESCEND = enum.auto()  # lower the sponge to its home
    RELEASE = enum.auto()  # open until the fingers settle
    HOME_RETREAT = enum.auto()  # up to the hover height
    RETURN = enum.auto()  # hover above the arm's segment centre
    DONE = enum.auto()


class CleanSkill(Skill):
    """Wipe the segment the arm is above with the sponge from its home, then return it."""

    action = Action.CLEAN
    Phase = CleanPhase
    DEFAULT_CONFIG = {
        **BASE_CONFIG,
        **GRASP_CONFIG,
        "max_steps": 900,
        "press_depth": 0.006,  # m the sponge's bottom is commanded below the table top (firm contact)
        "press_gain": 5.0,  # 1/s, integral gain pushing deeper while the sponge's lowest corner is above the table
        "max_extra_press": 0.015,  # m, bound of that extra depth
        "contact_slack": 0.0005,  # m; the sponge counts as touching when its lowest corner is this close
        "contact_tolerance": 0.006,  # m; PRESS ends when the grip site is this close to the contact height
        "wipe_speed": 0.25,  # m/s along the strokes
        "wipe_tolerance": 0.02,  # m (xy); table friction keeps the pressed sponge a little behind its setpoint
        "edge_inset": 0.6,  # fraction of the sponge's half extent its centre keeps inside the segment's edges
        "repeat_lane_shift": 0.5,  # repeated passes shift the lanes by this fraction of the lane spacing
        "wipe_overlap": 0.4,  # fraction of the sponge width shared by neighbouring lanes
        "max_passes": 3,  # wipe passes at most; a pass is repeated only while the segment is dirty
        "place_clearance": 0.004,  # m above its home at which the sponge is released
        "release_min_steps": 3,  # control steps to keep opening before checking the fingers settled
    }

    def on_reset(self, info: Mapping[str, Any]) -> None:
        self.segment = self.state.arm_segment
        self.retries_left = self.config["grasp_retries"]
        self.passes = 0
        self.stroke_index = 0
        self.strokes = np.zeros((0, 2))
        self.hold_offset_z = 0.0
        self.extra_press = 0.0
        self.yaw = grasp_yaw(info["sponge_quat"], info["sponge_half_size"], self.config["nominal_yaw"])

    # -- geometry -------------------------------------------------------------------
    def _pattern(self, info: Mapping[str, Any], pass_index: int) -> np.ndarray:
        # the held sponge's footprint in world axes (computed once it is grasped)
        footprint = world_footprint(info["sponge_quat"], info["sponge_half_size"])
        return boustrophedon(
            self.segment_center(info, self.segment),
            np.asarray(info["segment_half_sizes"], dtype=float)[int(self.segment)],
            footprint,
            self.config["wipe_overlap"],
            # stroke along the fingers' closing axis (grip-site x): dragging across it would twist
            # the sponge about the finger contact line
            along_x=abs(np.cos(self.yaw)) > abs(np.sin(self.yaw)),
            lane_shift=self.config["repeat_lane_shift"] * (pass_index % 2),
            edge_inset=self.config["edge_inset"],
        )

    def _wipe_z(self, info: Mapping[str, Any]) -> float:
        """Grip-site height (m) that puts the sponge's bottom ``press_depth`` below the table top."""
        half_z = float(info["sponge_half_size"][2])
        depth = self.config["press_depth"] + self.extra_press
        return float(info["table_top_z"]) - depth + half_z + self.hold_offset_z

    def update(self, info: Mapping[str, Any]) -> None:
        """Integral contact control while wiping: press deeper while the sponge's lowest corner is off the table."""
        if self.phase != CleanPhase.WIPE:
            return
        lowest = box_lowest_z(info["sponge_pos"], info["sponge_quat"], info["sponge_half_size"])
        gap = lowest - float(info["table_top_z"]) - self.config["contact_slack"]
        extra = self.extra_press + self.config["press_gain"] * self.dt * gap
        self.extra_press = float(np.clip(extra, 0.0, self.config["max_extra_press"]))

    # -- state machine -----------------------------------------------------------------
    def waypoint(self, info: Mapping[str, Any]) -> Waypoint:
        tol = self.config["reach_tolerance"]
        phase = self.phase
        if phase == CleanPhase.TO_SPONGE:
            return Waypoint(self.hover_point(info, info["sponge_pos"][:2]), GRIPPER_OPEN, tol)
        if phase == CleanPhase.SPONGE_DESCEND:
            grasp = grasp_point(np.asarray(info["sponge_pos"]), info["sponge_half_size"], self.config)
            return Waypoint(grasp, GRIPPER_OPEN, tol, speed=self.config["descend_speed"])
        if phase in (CleanPhase.SPONGE_CLOSE, CleanPhase.RELEASE):
            gripper = GRIPPER_CLOSE if phase == CleanPhase.SPONGE_CLOSE else GRIPPER_OPEN
            key = "close_min_steps" if phase == CleanPhase.SPONGE_CLOSE else "release_min_steps"
            return Waypoint(self._setpoint.copy(), gripper, np.inf, min_steps=self.config[key])
        if phase == CleanPhase.SPONGE_LIFT:
            return Waypoint(self.hover_point(info, info["eef_pos"][:2]), GRIPPER_CLOSE, tol)
        if phase == CleanPhase.TO_SEGMENT:
            return Waypoint(self.hover_point(info, self.strokes[0]), GRIPPER_CLOSE, tol)
        if phase == CleanPhase.PRESS:
            pos = np.array([*self.strokes[0], self._wipe_z(info)])
            tolerance = self.config["press_depth"] + self.config["contact_tolerance"]
            return Waypoint(pos, GRIPPER_CLOSE, tolerance, speed=self.config["descend_speed"])
        if phase == CleanPhase.WIPE:
            pos = np.array([*self.strokes[self.stroke_index], self._wipe_z(info)])
            wipe_tol = self.config["wipe_tolerance"]
            return Waypoint(pos, GRIPPER_CLOSE, wipe_tol, xy_only=True, speed=self.config["wipe_speed"])
        if phase == CleanPhase.WIPE_LIFT:
            return Waypoint(self.hover_point(info, self.strokes[-1]), GRIPPER_CLOSE, tol)
        home = np.asarray(info["sponge_home_pos"], dtype=float)
        if phase == CleanPhase.TO_HOME:
            return Waypoint(self.hover_point(info, home[:2]), GRIPPER_CLOSE, tol)
        if phase == CleanPhase.HOME_DESCEND:
            z = float(home[2]) + self.config["place_clearance"] + self.hold_offset_z
            return Waypoint(np.array([home[0], home[1], z]), GRIPPER_CLOSE, tol, speed=self.config["descend_speed"])
        if phase == CleanPhase.HOME_RETREAT:
            return Waypoint(self.hover_point(info, home[:2]), GRIPPER_OPEN, tol)
        # RETURN
        center = self.segment_center(info, self.segment)
        return Waypoint(self.hover_point(info, center[:2]), GRIPPER_OPEN, tol)

    def next_phase(self, info: Mapping[str, Any]) -> CleanPhase:
        phase = self.phase
        if phase == CleanPhase.SPONGE_CLOSE:
            if not info["sponge_grasped"]:
                if self.retries_left <= 0:
                    raise SkillFailure("sponge grasp not confirmed")
                self.retries_left -= 1
                return CleanPhase.TO_SPONGE
            eef, sponge = np.asarray(info["eef_pos"]), np.asarray(info["sponge_pos"])
            # the sponge centre's height below the grip site, measured once it is held
            self.hold_offset_z = float(eef[2] - sponge[2])
            self.strokes = self._pattern(info, self.passes)
        elif phase == CleanPhase.WIPE:
            if not info["sponge_grasped"]:
                raise SkillFailure("sponge lost while wiping")
            if self.stroke_index + 1 < len(self.strokes):
                self.stroke_index += 1
                return CleanPhase.WIPE
            self.passes += 1
            # "dirt remains" is the abstraction's call (the sponge is in hand, so it is not checked)
            still_dirty = not self.env.symbolic_state(check_sponge=False).is_clean(self.segment)
            if self.passes < self.config["max_passes"] and still_dirty:
                self.strokes = self._pattern(info, self.passes)
                self.stroke_index = 0
                return CleanPhase.WIPE
        return CleanPhase(phase.value + 1)

    def phase_ready(self, info: Mapping[str, Any]) -> bool:
        return self.phase != CleanPhase.RELEASE or not info["sponge_grasped"]
