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
    """Phases of a clean, in order (PRESS -> WIPE -> SHIFT repeats over the strokes and passes)."""

    TO_SPONGE = enum.auto()  # hover above the sponge, gripper open
    SPONGE_DESCEND = enum.auto()  # down to the sponge's grasp point
    SPONGE_CLOSE = enum.auto()  # close, then confirm the sponge is grasped
    SPONGE_LIFT = enum.auto()  # up to the hover height
    TO_SEGMENT = enum.auto()  # hover above the first stroke's start
    PRESS = enum.auto()  # down at a stroke's start until the sponge touches the table
    WIPE = enum.auto()  # drag the pressed sponge to the stroke's end
    SHIFT = enum.auto()  # sponge just off the table, over to the next stroke's start (next lane or pass)
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
        "wipe_speed": 0.25,  # m/s along the strokes
        "wipe_tolerance": 0.02,  # m (xy); table friction keeps the pressed sponge a little behind its setpoint
        # fraction of the sponge's half extent its centre keeps inside the segment's edges; 1 with no
        # overlap makes the lanes tile the segment exactly (3 lanes on the default 0.24 m segment)
        "edge_inset": 1.0,
        "repeat_lane_shift": 0.5,  # repeated passes shift the lanes by this fraction of the lane spacing
        # fraction of the sponge width shared by neighbouring lanes; the sponge's own footprint plus the
        # env's wipe reach already covers the seams, and every extra lane costs ~25 control steps
        "wipe_overlap": 0.0,
        # m the sponge's bottom is lifted above the table while it shifts to the next stroke: dragged
        # across the fingers' closing axis the pressed sponge tips and slides up into the hand, after
        # which the fingertips, not the sponge, touch the table
        "shift_clearance": 0.005,
        # control steps after which a stroke starts even if no contact was sensed (a sponge slid up in
        # the hand can leave the fingertips on the table); WIPE's integral press then deepens the contact
        "press_max_steps": 12,
        "max_passes": 3,  # wipe passes at most; a pass is repeated only while the segment is dirty
        "place_clearance": 0.004,  # m above its home at which the sponge is released
        "release_min_steps": 3,  # control steps to keep opening before checking the fingers settled
    }

    def on_reset(self, info: Mapping[str, Any]) -> None:
        self.segment = self.state.arm
        self.retries_left = self.config["grasp_retries"]
        self.passes = 0
        self.stroke_index = 0
        self.strokes = np.zeros((0, 2))
        self.extra_press = 0.0
        self.hold_offset = np.zeros(3)
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

    def _wipe_target(self, info: Mapping[str, Any], stroke_point: np.ndarray, depth: float | None = None) -> np.ndarray:
        """(3,) grip-site target that puts the held sponge's centre over ``stroke_point`` (2,, m).

        Uses the grip-site-to-sponge offset measured at the grasp.  (Following the live offset
        instead, as the sponge slips, was tried: a sponge pivoting in the fingers then runs away
        with its own target and is lost in ~1 of 3 cleans.)

        ``depth``: m the sponge's bottom is commanded below the table top (negative: above);
        default: pressing (``press_depth`` plus the integral extra depth).
        """
        offset = self.hold_offset
        if depth is None:
            depth = self.config["press_depth"] + self.extra_press
        half_z = float(info["sponge_half_size"][2])
        z = float(info["table_top_z"]) - depth + half_z + float(offset[2])
        return np.array([*(stroke_point + offset[:2]), z])

    @staticmethod
    def _sponge_gap(info: Mapping[str, Any]) -> float:
        """Height (m) of the sponge's lowest corner above the table top (negative: pressed in)."""
        lowest = box_lowest_z(info["sponge_pos"], info["sponge_quat"], info["sponge_half_size"])
        return lowest - float(info["table_top_z"])

    def update(self, info: Mapping[str, Any]) -> None:
        """Integral contact control while wiping: press deeper while the sponge's lowest corner is off the table."""
        if self.phase != CleanPhase.WIPE:
            return
        gap = self._sponge_gap(info) - self.config["contact_slack"]
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
            pos = self._wipe_target(info, self.strokes[self.stroke_index])
            # judged in xy only: the height is judged by contact (phase_ready); a sponge sliding up in
            # the hand moves this target down, so it may never be reached
            return Waypoint(pos, GRIPPER_CLOSE, self.config["wipe_tolerance"], xy_only=True,
                            speed=self.config["descend_speed"])
        if phase == CleanPhase.SHIFT:
            pos = self._wipe_target(info, self.strokes[self.stroke_index], -self.config["shift_clearance"])
            return Waypoint(pos, GRIPPER_CLOSE, self.config["wipe_tolerance"], xy_only=True)
        if phase == CleanPhase.WIPE:
            pos = self._wipe_target(info, self.strokes[self.stroke_index])
            wipe_tol = self.config["wipe_tolerance"]
            return Waypoint(pos, GRIPPER_CLOSE, wipe_tol, xy_only=True, speed=self.config["wipe_speed"])
        if phase == CleanPhase.WIPE_LIFT:
            return Waypoint(self.hover_point(info, self.strokes[-1]), GRIPPER_CLOSE, tol)
        home = np.asarray(info["sponge_home_pos"], dtype=float)
        if phase == CleanPhase.TO_HOME:
            return Waypoint(self.hover_point(info, home[:2]), GRIPPER_CLOSE, tol)
        if phase == CleanPhase.HOME_DESCEND:
            z = float(home[2]) + self.config["place_clearance"] + float(self.hold_offset[2])
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
            # grip-site minus sponge-centre position (m), measured once the sponge is held
            self.hold_offset = np.asarray(info["eef_pos"], dtype=float) - np.asarray(info["sponge_pos"], dtype=float)
            self.strokes = self._pattern(info, self.passes)
        elif phase == CleanPhase.PRESS:
            self.stroke_index += 1  # the stroke's end
        elif phase == CleanPhase.WIPE:
            if not info["sponge_grasped"]:
                raise SkillFailure("sponge lost while wiping")
            if self.stroke_index + 1 < len(self.strokes):
                self.stroke_index += 1  # the next stroke's start
                return CleanPhase.SHIFT
            self.passes += 1
            # "dirt remains" is the abstraction's call (the sponge is in hand, so it is not checked)
            still_dirty = not self.env.symbolic_state(check_sponge=False).is_clean(self.segment)
            if self.passes < self.config["max_passes"] and still_dirty:
                self.strokes = self._pattern(info, self.passes)
                self.stroke_index = 0
                return CleanPhase.SHIFT
            return CleanPhase.WIPE_LIFT
        elif phase == CleanPhase.SHIFT:
            return CleanPhase.PRESS
        return CleanPhase(phase.value + 1)

    def phase_ready(self, info: Mapping[str, Any]) -> bool:
        if self.phase == CleanPhase.PRESS:  # a stroke starts once the sponge really touches (or on timeout)
            touching = self._sponge_gap(info) <= self.config["contact_slack"]
            return touching or self._phase_steps >= self.config["press_max_steps"]
        return self.phase != CleanPhase.RELEASE or not info["sponge_grasped"]
