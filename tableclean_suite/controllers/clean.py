"""CleanSkill: fetch the sponge, wipe the arm's segment until clean (bounded), bring the sponge home.

Built from primitives: [`Grasp`][tableclean_suite.controllers.primitives.Grasp] (the sponge), [`Wipe`][tableclean_suite.controllers.clean.Wipe] (the arm's
segment, wherever it lies), [`Release`][tableclean_suite.controllers.primitives.Release] (the sponge at its home) and a
[`Reach`][tableclean_suite.controllers.primitives.Reach] back above the segment.

The wipe never touches what stands around the segment: its strokes stay inside the segment's
area shrunk until the hand (the gripper's measured box, long along the strokes) keeps
`HAND_CLEARANCE` from every lying object whose top reaches the hand's underside
([`hand_obstacles`][tableclean_suite.controllers.clean.hand_obstacles], [`clear_area`][tableclean_suite.controllers.wipe_pattern.clear_area]).  When such an object stands ahead of
the strokes' ends, the hand turns a quarter (`Wipe._choose_yaw`) so that its narrow side
faces it, and strokes toward the arm's base; travel above the segment and to the sponge's home
is at the skill's travel height, which clears every lying object's top.
"""

from __future__ import annotations

import enum
from typing import Any, Mapping

import numpy as np

from tableclean_suite.controllers.configs import CleanConfig, WipeConfig
from tableclean_suite.controllers.geometry import box_lowest_z, clip_scalar, quat_to_matrix, world_footprint
from tableclean_suite.controllers.loop_state import MODE_PRESS, MODE_SHIFT, MODE_WIPE, WIPE_STATE, loop_record
from tableclean_suite.controllers.osc import GRIPPER_CLOSE, GRIPPER_OPEN
from tableclean_suite.controllers.primitives import SPONGE, Grasp, Primitive, PrimitiveSkill, Reach, Release, line_yaw
from tableclean_suite.controllers.skill import SkillFailure, Waypoint
from tableclean_suite.controllers.wipe_pattern import boustrophedon, clear_area
from tableclean_suite.environments.abstraction import AbstractionError
from tableclean_suite.environments.object_geometry import wrap_angle
from tableclean_suite.task import Action

#: m kept between the wiping hand and every object standing near the segment, horizontally (the wipe
#: area shrinks by it) and vertically (an object whose top comes within it of the hand's underside counts).
HAND_CLEARANCE = 0.01
#: m the grip site may come below its height with the held sponge resting flat on the table top while
#: it presses and wipes (the sponge's soft contact and its tilt in the fingers).
PRESS_SINK = 0.005
#: rad the hand turns about the vertical, sponge in hand, to wipe with its narrow side toward the objects
#: around the segment (`Wipe._choose_yaw`); the strokes then run along the other world axis.
QUARTER_TURN = 0.5 * np.pi
#: Fraction of the segment's area the sponge must sweep more at the turned yaw than at the grasp's for the
#: wipe to turn (a clean may leave 10 % of the dirt; a smaller shrink of the grasp yaw's area costs no row).
TURN_AREA_GAIN = 0.05
#: The wipe's phases the compiled control loop can run
#: ([`Wipe.run_loop`][tableclean_suite.controllers.clean.Wipe.run_loop]): its mode, the config key of the speed.
LOOP_MODES = {"PRESS": (MODE_PRESS, "descend_speed"), "WIPE": (MODE_WIPE, "wipe_speed"), "SHIFT": (MODE_SHIFT, "speed")}


def _rotation(angle: float) -> np.ndarray:
    """(2, 2) rotation by ``angle`` rad about the world z axis."""
    c, sn = np.cos(angle), np.sin(angle)
    return np.array([[c, -sn], [sn, c]])


def turned_quat(quat: np.ndarray, angle: float) -> np.ndarray:
    """(4,) xyzw quaternion ``quat`` turned by ``angle`` rad about the world z axis."""
    x, y, z, w = (float(q) for q in quat)
    c, sn = np.cos(0.5 * angle), np.sin(0.5 * angle)  # (0, 0, sn, c) * (x, y, z, w)
    return np.array([c * x - sn * y, c * y + sn * x, c * z + sn * w, c * w - sn * z])


def hand_obstacles(info: Mapping[str, Any], hand_bottom_z: float, clearance: float = HAND_CLEARANCE) -> np.ndarray:
    """(K, 4) world boxes ``[x_min, y_min, x_max, y_max]`` [m] of the lying objects a hand at ``hand_bottom_z`` meets.

    Read from the scene: each lying (not grasped) object's collision points at its current pose
    (``objects_geometry``); the box covers those whose height comes within ``clearance`` of
    ``hand_bottom_z`` (world z, m).  A missing key of ``info`` is a ``KeyError`` naming it.
    """
    positions = np.asarray(info["objects_pos"], dtype=float)
    grasped = np.asarray(info["objects_grasped"], dtype=bool)
    shapes = info["objects_geometry"]
    boxes = []
    for j in np.flatnonzero(~grasped):
        world = positions[j] + shapes[j].points @ quat_to_matrix(info["objects_quat"][j]).T
        high = world[world[:, 2] >= hand_bottom_z - clearance]
        if len(high):
            boxes.append([*high[:, :2].min(axis=0), *high[:, :2].max(axis=0)])
    return np.asarray(boxes, dtype=float).reshape(-1, 4)


def wiping_hand_underside_z(info: Mapping[str, Any], hold_offset_z: float) -> float:
    """World z [m] of the hand's underside (its palm, ``gripper_palm_height`` above the grip site) while wiping.

    The held sponge's bottom cannot go below the table top, so the grip site stays about
    ``sponge half height + hold_offset_z`` (m, grip site minus sponge centre) above it, down to
    `PRESS_SINK` lower.  (Not the commanded target: the force loop may command the sponge
    ``max_press_depth`` into the table, a setpoint the hand never reaches.)  Only the fingers,
    closed on the sponge, come lower.
    """
    grip_z = float(info["table_top_z"]) + float(info["sponge_half_size"][2]) + float(hold_offset_z) - PRESS_SINK
    return grip_z + float(info["gripper_palm_height"])


def spare_clear_of(bounds: np.ndarray, area: np.ndarray, hand_half: np.ndarray, obstacles: np.ndarray,
                   margin: float) -> np.ndarray:
    """(2, 2) ``[low, high]`` world xy [m] the grip site may reach: ``bounds`` (the wipe area ``area`` (2, 2), in
    grip-site coordinates, with the drift correction's spare), each side's spare cut where the hand's box (half
    extents ``hand_half`` (2,) [m] about the grip site) would come within ``margin`` [m] of one of ``obstacles``
    (K, 4) world boxes ``[x_min, y_min, x_max, y_max]`` ([`hand_obstacles`][tableclean_suite.controllers.clean.hand_obstacles]) beyond that side; a side never
    comes inside ``area``.  An obstacle counts for a side when its box, grown by the hand's and ``margin``,
    overlaps ``area`` across that side's axis (the lead moves the grip site along the strokes, never across).
    Without obstacles near the spare: ``bounds`` as they were (the same values)."""
    out = np.array(bounds, dtype=float)
    if len(obstacles) == 0:
        return out
    boxes = np.asarray(obstacles, dtype=float)
    grown_low = boxes[:, :2] - np.asarray(hand_half, dtype=float) - margin
    grown_high = boxes[:, 2:] + np.asarray(hand_half, dtype=float) + margin
    for axis in (0, 1):
        other = 1 - axis
        # the lead moves the grip site along the strokes only: across them it stays inside the area
        beside = (grown_low[:, other] < area[1, other]) & (grown_high[:, other] > area[0, other])
        for box in np.flatnonzero(beside):
            if grown_high[box, axis] > area[1, axis] and grown_low[box, axis] < out[1, axis]:
                out[1, axis] = max(float(area[1, axis]), float(grown_low[box, axis]))
            if grown_low[box, axis] < area[0, axis] and grown_high[box, axis] > out[0, axis]:
                out[0, axis] = min(float(area[0, axis]), float(grown_high[box, axis]))
    return out


class Wipe(Primitive):
    """Sweep ``segment`` with the held sponge: boustrophedon strokes, pressed, pass after pass while dirty.

    The press closes its loop on the measured sponge-table contact force (the env's ``sponge_press_force()``),
    not on a depth: the commanded depth of the sponge's bottom below the table top is integrated from the force
    error (``press_force`` target, ``press_force_gain``) while the sponge is on the table, and a stroke starts
    once ``touch_force`` is measured.  A different sponge size, mass, friction, arm damping or gains thus end at
    the same pressing force.  Retries (the skill's ``retries``): a sponge lost while wiping is grasped again
    where it lies and the wipe starts anew; a segment still dirty once the sponge is lifted is wiped again.
    The settings: [`WipeConfig`][tableclean_suite.controllers.configs.WipeConfig].
    """

    PHASES = ("TO_SEGMENT", "PRESS", "WIPE", "SHIFT", "WIPE_LIFT")
    Config = WipeConfig

    def __init__(self, segment: int):
        self.segment = int(segment)

    def start(self, skill, info):
        self.config = skill.config
        self.passes = 0
        self.stroke_index = 0
        #: m the sponge's bottom is commanded below the table top (negative: above), from the force loop
        self.depth = float(self.config["press_start_depth"])
        self.force = 0.0  # N, the last measured pressing force
        self.lift_point = None  # (2,) where a SHIFT lifts the sponge off the table before it moves on
        self.lifted = False  # the SHIFT measured the sponge off the table
        # control steps a PRESS may take beyond press_max_steps: its descent from above hover_height
        # (tall objects raise the travel height) before the timeout starts counting
        self.press_grace = 0
        # grip-site minus sponge-centre position (m), measured once the sponge is held and lifted
        self.hold_offset = np.asarray(info["eef_pos"], dtype=float) - np.asarray(info["sponge_pos"], dtype=float)
        self.grasp_yaw = self.yaw = skill.yaw
        self.turned = False  # the strokes run at the grasp's yaw (True: a quarter turn from it, _choose_yaw)
        self.dt = skill.dt
        # m, the wipe height's terms, fixed for the execution
        self._table_z, self._half_z = float(info["table_top_z"]), float(info["sponge_half_size"][2])
        self.strokes = self._choose_yaw(info)
        skill.yaw = self.yaw  # TO_SEGMENT turns the hand, sponge in hand, on its way (if it turns)

    def _choose_yaw(self, info: Mapping[str, Any]) -> np.ndarray:
        """The first pass's strokes (n, 2), at the grasp's yaw or a `QUARTER_TURN` from it: the one whose
        clear wipe area (`_wipe_area`) lets the sponge sweep more of the segment.

        The hand is long along the fingers' closing axis (the strokes' axis) and narrow across it; an
        object standing near the segment's edge ahead of a stroke's end shrinks the area by the
        hand's reach (~10 cm), one beside the strokes only by its half width (~3 cm).  Turning,
        the hand keeps its grip; `hold_offset` turns with it.  Sets `yaw`,
        `turned`, `hold_offset`, `hand_bounds`.
        """
        grasp_offset = self.hold_offset.copy()
        strokes = self._pattern(info, 0)
        kept, bounds = self._swept_area, self.hand_bounds
        turn = self._quarter_turn()
        self.yaw, self.turned = wrap_angle(self.grasp_yaw + turn), True
        self.hold_offset = grasp_offset.copy()
        self.hold_offset[:2] = _rotation(turn) @ grasp_offset[:2]
        turned_strokes = self._pattern(info, 0, turn)
        segment_area = float(np.prod(2.0 * np.asarray(info["segment_half_sizes"], dtype=float)[self.segment]))
        if self._swept_area > kept + TURN_AREA_GAIN * segment_area:
            return turned_strokes
        self.yaw, self.turned, self.hold_offset, self.hand_bounds = self.grasp_yaw, False, grasp_offset, bounds
        return strokes

    def _quarter_turn(self) -> float:
        """rad, about +-`QUARTER_TURN`: from the grasp's yaw to the turned one, the yaw along the line across
        the grasp's nearest a quarter turn clockwise of ``nominal_yaw`` (away from the wrist's joint limits)."""
        turned = line_yaw(self.grasp_yaw + QUARTER_TURN, self.config["nominal_yaw"] - QUARTER_TURN)
        return wrap_angle(turned - self.grasp_yaw)

    def _hand_half(self, info: Mapping[str, Any]) -> np.ndarray:
        """(2,) m: world-axis half extents of the hand's box about the grip site while wiping.

        The gripper's measures (``gripper_hand_reach`` along the fingers' closing axis,
        ``gripper_hand_half_width`` across it) turned to the hand's yaw.  (The wipe target's lead
        over a lagging sponge, ``max_drift_correction``, is clipped to `hand_bounds` instead.)"""
        extent = np.array([float(info["gripper_hand_reach"]), float(info["gripper_hand_half_width"])])
        return np.abs(_rotation(self.yaw)) @ extent

    def _wipe_area(self, info: Mapping[str, Any], footprint: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(center, half_size)`` (2,), (2,) m of the sponge-centre rectangle the strokes may use.

        The segment inset by ``edge_inset`` of the sponge's footprint, shrunk ([`clear_area`][tableclean_suite.controllers.wipe_pattern.clear_area]) so
        that the hand stays `HAND_CLEARANCE` away from every object whose top reaches its
        underside while wiping ([`wiping_hand_underside_z`][tableclean_suite.controllers.clean.wiping_hand_underside_z]; objects on the neighbouring segments,
        read from their collision geometry; the palm passes over lower ones).  Between two lanes and
        two passes the sponge moves inside it too.
        Sets `hand_bounds`, the (2, 2) ``[low, high]`` world xy the grip site may reach while
        wiping: the shrunk sides exactly, the others with ``max_drift_correction`` to spare, but never so
        far that the hand comes within `HAND_CLEARANCE` of an object it clears at the strokes' ends
        ([`spare_clear_of`][tableclean_suite.controllers.clean.spare_clear_of]).
        """
        center = np.asarray(info["segment_centers"], dtype=float)[self.segment][:2]
        half = np.asarray(info["segment_half_sizes"], dtype=float)[self.segment]
        reach = np.maximum(half - self.config["edge_inset"] * footprint, 0.0)
        spare = self.config["max_drift_correction"]
        self.hand_bounds = np.array([center - reach - spare, center + reach + spare]) + self.hold_offset[:2]
        obstacles = hand_obstacles(info, wiping_hand_underside_z(info, self.hold_offset[2]))
        clear_center, clear_reach = clear_area(center, reach, self.hold_offset[:2], self._hand_half(info), obstacles,
                                               HAND_CLEARANCE)
        low, high = clear_center - clear_reach, clear_center + clear_reach
        shrunk = ~np.isclose(np.array([low, high]), np.array([center - reach, center + reach]))
        self.hand_bounds[shrunk] = (np.array([low, high]) + self.hold_offset[:2])[shrunk]
        self.hand_bounds = spare_clear_of(self.hand_bounds, np.array([low, high]) + self.hold_offset[:2],
                                          self._hand_half(info), obstacles, HAND_CLEARANCE)
        #: m^2 the sponge sweeps over: the clear area grown by the sponge's inset footprint
        self._swept_area = float(np.prod(2.0 * (clear_reach + self.config["edge_inset"] * footprint)))
        return clear_center, clear_reach

    def _pattern(self, info: Mapping[str, Any], pass_index: int, turn: float = 0.0) -> np.ndarray:
        """Sponge-centre stroke points (n, 2) of pass ``pass_index`` at `yaw`; ``turn`` (rad): how far the
        hand will still turn about the vertical before the strokes (the sponge's footprint turns with it)."""
        # the held sponge's footprint in world axes (computed once it is grasped)
        if turn == 0.0:
            footprint = world_footprint(info["sponge_quat"], info["sponge_half_size"])
        else:
            footprint = world_footprint(turned_quat(info["sponge_quat"], turn), info["sponge_half_size"])
        center, reach = self._wipe_area(info, footprint)
        return boustrophedon(
            center,
            reach + self.config["edge_inset"] * footprint,  # boustrophedon insets the sponge centre by this again
            footprint,
            self.config["wipe_overlap"],
            # stroke along the fingers' closing axis (grip-site x): dragging across it would twist
            # the sponge about the finger contact line
            along_x=self._stroke_axis() == 0,
            lane_shift=self.config["repeat_lane_shift"] * (pass_index % 2),
            edge_inset=self.config["edge_inset"],
            direction=self._stroke_direction(info),
        )

    def _stroke_direction(self, info: Mapping[str, Any]) -> int:
        """0 (strokes back and forth) at the grasp's yaw; turned, the sign (-1, +1) of the stroke axis toward the
        arm's base (``robot_base_pos``): every stroke then pulls the sponge toward the arm (pushed away
        along the arm's radius, the sponge sticks under a rising force)."""
        if not self.turned:
            return 0
        axis = self._stroke_axis()
        toward = float(info["robot_base_pos"][axis]) - float(info["segment_centers"][self.segment][axis])
        return int(np.sign(toward))

    def _stroke_axis(self) -> int:
        """World axis (0: x, 1: y) the strokes run along: the fingers' closing axis (grip-site x at ``yaw``)."""
        return 0 if abs(np.cos(self.yaw)) > abs(np.sin(self.yaw)) else 1

    def _drift(self, info: Mapping[str, Any]) -> np.ndarray:
        """(2,) m: how far the sponge trails its grasp-time place in the hand along the strokes (bounded).

        Dragged along the fingers' closing axis, table friction pushes the sponge and the yielding
        fingers back, so a stroke would stop short of the segment's edge; the wipe
        target leads by the measured drift, at most ``max_drift_correction``.  Only the stroke axis
        is corrected (across it a pivoting sponge would run away with its own target).
        """
        axis = self._stroke_axis()
        # the stroke axis' entries alone, as Python floats (the same IEEE subtractions as numpy's on the arrays)
        live = float(info["eef_pos"][axis]) - float(info["sponge_pos"][axis])
        bound = self.config["max_drift_correction"]
        drift = np.zeros(2)
        drift[axis] = clip_scalar(live - float(self.hold_offset[axis]), -bound, bound)
        return drift

    def _wipe_target(self, stroke_point: np.ndarray, depth: float | None = None) -> np.ndarray:
        """(3,) grip-site target that puts the held sponge's centre over ``stroke_point`` (2,, m).

        Uses the grip-site-to-sponge offset measured at the grasp (with the live offset, a sponge pivoting
        in the fingers would run away with its own target).

        ``depth``: m the sponge's bottom is commanded below the table top (negative: above);
        default: the force loop's `depth`.
        """
        x, y, _ = self.hold_offset.tolist()
        px, py = stroke_point.tolist()
        # Python floats (the same IEEE sums as numpy's stroke_point + offset[:2])
        return np.array([px + x, py + y, self._wipe_z(depth)])

    def _wipe_z(self, depth: float | None = None) -> float:
        """`_wipe_target`'s height (m): the grip site's z that puts the held sponge's bottom ``depth`` (m,
        default `depth`) below the table top."""
        return self._table_z - (self.depth if depth is None else depth) + self._half_z + float(self.hold_offset[2])

    @staticmethod
    def _sponge_gap(info: Mapping[str, Any]) -> float:
        """Height (m) of the sponge's lowest corner above the table top (negative: pressed in)."""
        lowest = box_lowest_z(info["sponge_pos"], info["sponge_quat"], info["sponge_half_size"])
        return lowest - float(info["table_top_z"])

    def update(self, skill, info: Mapping[str, Any], phase: str) -> None:
        """Integral force control while pressing and wiping: the depth follows the contact-force error.

        ``d depth / dt = press_force_gain * (press_force - force) + gap_gain * max(gap - contact_slack, 0)``:
        the measured force sets the depth; the measured gap of the sponge's lowest corner above
        the table (while wiping) only speeds up the way back down after the sponge lost contact.  While pressing
        down the depth integrates only once the rate-limited setpoint has arrived at the commanded
        height or the sponge touches (so the descent itself winds nothing up).
        """
        if phase == "SHIFT":
            self._update_lift(skill, info)
            return
        if phase not in ("PRESS", "WIPE"):
            return
        self.force = skill.env.sponge_press_force()
        target_z = self._wipe_z()
        arrived = abs(float(skill.setpoint[2]) - target_z) <= self.config["setpoint_arrival"]
        if phase == "PRESS" and self.force <= 0.0 and not arrived:
            return
        error = self.config["press_force"] - self.force
        # the gap term only while wiping: while pressing down the sponge is still on its way
        gap = max(self._sponge_gap(info) - self.config["contact_slack"], 0.0) if phase == "WIPE" else 0.0
        rate = self.config["press_force_gain"] * error + self.config["gap_gain"] * gap
        depth = self.depth + rate * self.dt
        self.depth = clip_scalar(depth, self.config["min_press_depth"], self.config["max_press_depth"])

    def _update_lift(self, skill, info: Mapping[str, Any]) -> None:
        """A SHIFT moves on once no contact force is measured and the sponge's lowest corner is off the table.

        Dragged sideways while still pressed (across the fingers' closing axis) the sponge tips in
        the hand; a shift therefore lifts straight up first (or moves on after ``lift_max_steps``).
        """
        if self.lifted:
            return
        self.force = skill.env.sponge_press_force()
        clear = self.force <= 0.0 and self._sponge_gap(info) > self.config["contact_slack"]
        self.lifted = clear or skill._phase_steps >= self.config["lift_max_steps"]

    def waypoint(self, skill, info: Mapping[str, Any], phase: str) -> Waypoint:
        tol = self.config["reach_tolerance"]
        if phase == "TO_SEGMENT":
            return Waypoint(skill.hover_point(info, self.strokes[0]), GRIPPER_CLOSE, tol)
        if phase == "PRESS":
            pos = self._wipe_target(self.strokes[self.stroke_index])
            # judged in xy only: the height is judged by contact (ready); a sponge sliding up in
            # the hand moves this target down, so it may never be reached
            return Waypoint(pos, GRIPPER_CLOSE, self.config["wipe_tolerance"], xy_only=True,
                            speed=self.config["descend_speed"], loop=True)
        if phase == "SHIFT":
            point = self.strokes[self.stroke_index] if self.lifted else self.lift_point
            pos = self._wipe_target(point, -self.config["shift_clearance"])
            return Waypoint(pos, GRIPPER_CLOSE, self.config["wipe_tolerance"], xy_only=True, loop=True)
        if phase == "WIPE":
            pos = self._wipe_target(self.strokes[self.stroke_index])
            # the lead over a lagging sponge, but never beyond the sides shrunk for the objects around
            lead, (low, high) = pos[:2] + self._drift(info), self.hand_bounds
            pos[:2] = [clip_scalar(lead[k], low[k], high[k]) for k in range(2)]  # np.clip's values
            # a stroke the arm cannot finish (a corner at the edge of its reach) ends after stroke_max_steps
            tol = np.inf if skill._phase_steps >= self.config["stroke_max_steps"] else self.config["wipe_tolerance"]
            return Waypoint(pos, GRIPPER_CLOSE, tol, xy_only=True, speed=self.config["wipe_speed"], loop=True)
        return Waypoint(skill.hover_point(info, self.strokes[-1]), GRIPPER_CLOSE, tol)  # WIPE_LIFT

    def run_loop(self, skill, stepper, phase: str) -> int:
        """Run a PRESS's, WIPE's or SHIFT's next control steps in the stepper's compiled control loop
        ([`run_phase`][tableclean_suite.controllers.fast_control.FastSkillStepper.run_phase]): this
        primitive's [`update`][tableclean_suite.controllers.clean.Wipe.update] and `waypoint` and the skill's step, the same operations on the
        same values, so the same commands; it stops before a step whose completion check might pass or
        whose update it cannot take exactly (the skill's [`step`][tableclean_suite.controllers.skill.Skill.step] then takes it).  Returns
        how many control steps ran (0 in other phases)."""
        if phase not in LOOP_MODES:
            return 0
        config = self.config
        mode, speed_key = LOOP_MODES[phase]
        # the loop computes the waypoint's position itself
        state = skill.loop_state(Waypoint(np.zeros(3), GRIPPER_CLOSE, config["wipe_tolerance"], xy_only=True,
                                          speed=config[speed_key]))
        stroke = self.strokes[self.stroke_index]
        wipe = loop_record(
            WIPE_STATE, stroke=stroke, hold=self.hold_offset, lift=stroke if self.lift_point is None else self.lift_point,
            low=self.hand_bounds[0], high=self.hand_bounds[1], table_z=self._table_z, half_z=self._half_z,
            depth=self.depth, force=self.force, press_force=config["press_force"],
            force_gain=config["press_force_gain"], gap_gain=config["gap_gain"], contact_slack=config["contact_slack"],
            dt=self.dt, min_depth=config["min_press_depth"], max_depth=config["max_press_depth"],
            arrival=config["setpoint_arrival"], touch_force=config["touch_force"],
            drift_bound=config["max_drift_correction"], shift_depth=-config["shift_clearance"], mode=mode,
            axis=self._stroke_axis(), stroke_max_steps=config["stroke_max_steps"],
            press_timeout=config["press_max_steps"] + self.press_grace, lift_max_steps=config["lift_max_steps"],
            force_fn=0, lifted=self.lifted)  # force_fn: set by the stepper
        ran = stepper.run_phase(state, skill._last_fingers, wipe, skill.env.sponge_press_force)
        if ran:
            self.depth, self.force = float(wipe["depth"][0]), float(wipe["force"][0])
            self.lifted = bool(wipe["lifted"][0])
        skill.count_loop_steps(ran, state)
        return ran

    def next(self, skill, info: Mapping[str, Any], phase: str) -> str | None:
        if phase == "TO_SEGMENT":  # the first PRESS descends from the travel height
            extra = float(info["eef_pos"][2]) - (float(info["table_top_z"]) + self.config["hover_height"])
            self.press_grace = int(max(extra, 0.0) // (self.config["descend_speed"] * skill.dt))
        if phase == "SHIFT":
            self.press_grace = 0
        if phase == "PRESS":
            self.stroke_index += 1  # the stroke's end
            return "WIPE"
        if phase == "WIPE":
            if not info["sponge_grasped"]:
                raise SkillFailure("sponge lost while wiping", redo=1)  # grasped again where it lies
            self.lift_point, self.lifted = self.strokes[self.stroke_index], False
            if self.stroke_index + 1 < len(self.strokes):
                self.stroke_index += 1  # the next stroke's start
                return "SHIFT"
            self.passes += 1
            # "dirt remains" is the abstraction's call (the sponge is in hand, so it is not checked)
            still_dirty = not skill.env.symbolic_state(check_sponge=False).is_clean(self.segment)
            if self.passes < self.config["max_passes"] and still_dirty:
                self.strokes = self._pattern(info, self.passes)
                self.stroke_index = 0
                return "SHIFT"
            skill.yaw = self.grasp_yaw  # back to the grasp's yaw on the way up: the sponge goes home as it came
            return "WIPE_LIFT"
        if phase == "SHIFT":
            return "PRESS"
        if phase == "WIPE_LIFT" and self._still_dirty(skill):  # wipe again, the sponge in hand
            raise SkillFailure(f"segment {self.segment + 1} still dirty after {self.passes} pass(es)", redo=0)
        return super().next(skill, info, phase)

    def _still_dirty(self, skill) -> bool:
        """Whether the abstraction reads the segment dirty (False when it reads no state: no retry then).  Asked
        once the sponge is lifted, when it wipes no more: dirty then, the clean would end a failure."""
        try:
            return not skill.env.symbolic_state(check_sponge=False).is_clean(self.segment)
        except AbstractionError:
            return False

    def ready(self, skill, info: Mapping[str, Any], phase: str) -> bool:
        if phase == "PRESS":  # a stroke starts once a contact force is measured (or on timeout)
            timeout = self.config["press_max_steps"] + self.press_grace
            return self.force >= self.config["touch_force"] or skill._phase_steps >= timeout
        if phase == "SHIFT":  # first up off the table at the stroke's end, then over to the next start
            return self.lifted
        return True


#: The phases of [`wipe_plan`][tableclean_suite.controllers.clean.wipe_plan], in order: the sponge's grasp, the
#: wipe (PRESS -> WIPE -> SHIFT repeats over the strokes and passes), the sponge's release at home.
WIPE_PHASES = (*(f"SPONGE_{p}" for p in Grasp.PHASES), *Wipe.PHASES, *(f"HOME_{p}" for p in Release.PHASES))

CleanPhase = enum.Enum("CleanPhase", [*WIPE_PHASES, "RETURN", "DONE"], module=__name__)
"""Phases of a clean, in order: `WIPE_PHASES`, then RETURN above the arm's segment centre."""


def wipe_plan(segment: int, info: Mapping[str, Any]) -> list:
    """The ``(prefix, Primitive)`` pairs that fetch the sponge, wipe ``segment`` (0-based) and put the sponge home."""
    home = np.asarray(info["sponge_home_pos"], dtype=float)
    return [("SPONGE_", Grasp(SPONGE, "sponge grasp")), ("", Wipe(segment)),
            ("HOME_", Release(SPONGE, lambda skill, info: home[:2], lambda skill, info: float(home[2])))]


class CleanSkill(PrimitiveSkill):
    """Wipe the segment the arm is above with the sponge from its home, then return it."""

    action = Action.CLEAN
    Phase = CleanPhase
    Config = CleanConfig
    DEFAULT_CONFIG = CleanConfig().as_dict()

    def build(self, info: Mapping[str, Any]):
        self.segment = self.state.arm
        return [*wipe_plan(self.segment, info), ("", Reach("RETURN", lambda skill, info: skill.hover_point(
            info, skill.segment_center(info, self.segment)[:2]), GRIPPER_OPEN))]
