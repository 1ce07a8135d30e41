"""Small parameterised motion primitives that the skills are built from.

A [`Primitive`][tableclean_suite.controllers.primitives.Primitive] is a short sequence of named phases over
end-effector waypoints: [`Reach`][tableclean_suite.controllers.primitives.Reach] (one point),
[`Grasp`][tableclean_suite.controllers.primitives.Grasp] (take a body from above, confirmed by contact and slip),
[`Release`][tableclean_suite.controllers.primitives.Release] (lower the carried body until it rests, open, retreat)
and [`Wipe`][tableclean_suite.controllers.clean.Wipe] (in [`clean`][tableclean_suite.controllers.clean]: press the
held sponge and sweep a segment).  A [`PrimitiveSkill`][tableclean_suite.controllers.primitives.PrimitiveSkill]
runs a list of them one after the other; its phase names are ``prefix + local phase`` (e.g. the clean skill's
sponge grasp has ``SPONGE_HOVER``, ``SPONGE_DESCEND``, ...).

Every height, depth and yaw comes from the scene at run time: the body's collision geometry in
its own frame (``skill_info()["objects_geometry"]``, [`tableclean_suite.environments.object_geometry`][tableclean_suite.environments.object_geometry])
at its current pose, and the gripper's measures (``gripper_palm_height``).  An object type's
registered overrides (``grasp_depth``, ``yaw_rule``) win where given; no primitive branches on a
type name.  Of equivalent yaws (a narrow side's, a turn away from a neighbour) a primitive aims at
the one within a quarter turn of the config's ``nominal_yaw`` ([`line_yaw`][tableclean_suite.controllers.primitives.line_yaw]), so the wrist
never winds towards its joint limits.
"""

from __future__ import annotations

import enum
import functools
from dataclasses import dataclass
from typing import Any, Callable, ClassVar, Mapping

import numpy as np

from tableclean_suite.controllers.configs import GraspConfig, ReleaseConfig, SkillConfig
from tableclean_suite.controllers.geometry import gripper_yaw, quat_to_matrix
from tableclean_suite.controllers.osc import GRIPPER_CLOSE, GRIPPER_OPEN
from tableclean_suite.controllers.skill import Skill, SkillFailure, Waypoint, object_heights
from tableclean_suite.environments.gripper_geometry import GripperGeometry, wrist_half_width
from tableclean_suite.environments.object_geometry import (
    WIDTH_DIRECTIONS,
    ObjectGeometry,
    box_geometry,
    grasp_yaw,
    widths_of,
    world_lowest_z,
    world_z_range,
    wrap_angle,
)
from tableclean_suite.environments.placement import footprint_of, nearest_point

Info = Mapping[str, Any]

#: rad; a grasp's finger line (the grip site's x axis) closer than this to the direction of a lying
#: neighbour the hand would reach is turned away from it.
FINGER_LINE_CLEARANCE = 0.25 * np.pi

#: m a neighbour's top is counted higher when asking how wide the hand and wrist are at its height
#: ([`wrist_reach`][tableclean_suite.controllers.primitives.wrist_reach]): it may stand tilted a little, and the arm's links sag and lag a few mm.
WRIST_HEIGHT_MARGIN = 0.01
#: m by which the hand and wrist must reach wider than the hand alone (``gripper_hand_half_width``) for a
#: neighbour to count as reaching the wrist ([`wrist_reach`][tableclean_suite.controllers.primitives.wrist_reach]): below it the hand's own rules hold unchanged.
WRIST_WIDTH_TOLERANCE = 1e-4
#: m a body's outline must step in at a height (to a part above narrower everywhere) for
#: [`ledges`][tableclean_suite.controllers.primitives.ledges] to count a ledge there.
LEDGE_MARGIN = 0.002
#: m half the height of the band about the grip site that the finger pads close on ([`fitting_z`][tableclean_suite.controllers.primitives.fitting_z]).
PAD_HALF_HEIGHT = 0.004
#: m a side by which a round body's slice below the pads (the fingertips') or above them (the finger links')
#: may be wider than the slice at the pads before the grip moves ([`fitting_z`][tableclean_suite.controllers.primitives.fitting_z]).
SLICE_MARGIN = 0.001
#: m the fingertips keep above a body's bottom when a grasp is tried again (a low body, such as a thin
#: cylinder lying on its side, is held by the pads only this low).
RETRY_TIP_CLEARANCE = 0.002
#: rad: grasp yaws across the narrow side whose distances from ``nominal_yaw`` differ by less count as a tie
#: (`Grasp` then takes the one nearest the hand's yaw).
YAW_TIE = 0.2


def gripper_of(env) -> GripperGeometry | None:
    """The env's measured [`GripperGeometry`][tableclean_suite.environments.gripper_geometry.GripperGeometry] (through
    wrappers), or None for an env that has none (then no neighbour counts as reaching the wrist)."""
    geometry = getattr(env, "gripper_geometry", None)
    return geometry if isinstance(geometry, GripperGeometry) else None


def wrist_reach(info: Mapping[str, Any], gripper: GripperGeometry | None, top_z: float, grip_z: float) -> float | None:
    """How far [m] across the fingers' closing axis the hand and the links rigidly fixed to it (the wrist)
    reach at or below a neighbour's top ``top_z`` [m, world] when the grip site is at ``grip_z`` [m, world]
    (`WRIST_HEIGHT_MARGIN` higher), when that is more than the hand's own half width
    (``gripper_hand_half_width``): the neighbour then reaches the wrist.  None otherwise (or without ``gripper``):
    the hand's rules stand as they were."""
    if gripper is None:
        return None
    width = wrist_half_width(gripper, float(top_z) - float(grip_z) + WRIST_HEIGHT_MARGIN)
    return width if width > float(info["gripper_hand_half_width"]) + WRIST_WIDTH_TOLERANCE else None


@dataclass(frozen=True)
class Body:
    """How a primitive reads a graspable body from ``skill_info()``.

    Attributes:
        pos: ``info -> (3,)`` world centre [m].
        quat: ``info -> (4,)`` xyzw orientation.
        half_size: ``info -> (3,)`` bounding half extents [m].
        grasped: ``info -> bool`` both finger pads touch it.
        grasp_depth: m below the centre at which the grip site closes (raised so the fingertips
            keep ``tip_clearance`` above the body's bottom); None: the holding depth from
            ``geometry`` ([`holding_z`][tableclean_suite.controllers.primitives.holding_z]), or the skill's ``grasp_depth`` without one.
        yaw_rule: ``"short_side"`` (fingers across the narrowest side) or ``"any"`` (keep the
            gripper's current yaw); None: ``"any"`` for a round ``geometry``, else ``"short_side"``.
        geometry: ``info -> ObjectGeometry`` of the body in its own frame; None: a box of ``half_size``.
        index: the body's 0-based index among ``skill_info()``'s objects (None: not a task object, e.g. the sponge).
    """

    pos: Callable[[Info], np.ndarray]
    quat: Callable[[Info], np.ndarray]
    half_size: Callable[[Info], np.ndarray]
    grasped: Callable[[Info], bool]
    grasp_depth: float | None = None
    yaw_rule: str | None = "short_side"
    geometry: Callable[[Info], ObjectGeometry] | None = None
    index: int | None = None

    def shape(self, info: Info) -> ObjectGeometry:
        """The body's collision geometry in its own frame (a box of ``half_size`` without ``geometry``)."""
        return box_geometry(self.half_size(info)) if self.geometry is None else self.geometry(info)


def object_body(obj: int, info: Info | None = None) -> Body:
    """The task object ``obj`` (0-based): its pose and geometry (``objects_geometry``) read at use; with
    ``info``, its registered type's overrides (``info["object_types"]``: ``grasp_depth``, ``yaw_rule``; None:
    derived from the geometry).  The keys are [`skill_info`][tableclean_suite.environments.table_clean.TableClean.skill_info]'s
    (a missing one raises ``KeyError`` naming it)."""
    kind = None if info is None else info["object_types"][obj]
    return Body(
        pos=lambda info: np.asarray(info["objects_pos"][obj], dtype=float),
        quat=lambda info: np.asarray(info["objects_quat"][obj], dtype=float),
        half_size=lambda info: np.asarray(info["objects_half_size"][obj], dtype=float),
        grasped=lambda info: bool(info["objects_grasped"][obj]),
        grasp_depth=None if kind is None else kind.grasp_depth,
        yaw_rule=None if kind is None else kind.yaw_rule,
        geometry=lambda info: info["objects_geometry"][obj],
        index=obj,
    )


@functools.lru_cache(maxsize=512)
def ledges(geometry: ObjectGeometry, under: bool = False) -> tuple[tuple[float, float, tuple], ...]:
    """``(height, next height, directions)`` [m, ascending, the body's own frame]: heights at which the upright
    body steps in to a part above that is narrower by more than `LEDGE_MARGIN` a side (a can's shoulder under its
    narrower cap), with collision points of both there; the next height with collision points above; and the
    `WIDTH_DIRECTIONS` directions (bools, angle ``k pi / WIDTH_DIRECTIONS`` in its frame) along which it is
    narrower (fingers closing along the others meet no ledge: a carton's gable along its ridge, a handle).
    ``under``: the heights below which the body is narrower (a lip's underside; points of the narrower part
    there not needed: a lip may overlap the body)."""
    z = -geometry.points[:, 2] if under else geometry.points[:, 2]
    radius = np.hypot(geometry.points[:, 0], geometry.points[:, 1])
    levels, found = np.unique(np.round(geometry.points[:, 2], 4)), []
    for level in levels:
        here, beyond = np.abs(z - (-level if under else level)) <= 1e-4, z > (-level if under else level) + 1e-4
        stepped = under or radius[here].min() < radius[here].max() - LEDGE_MARGIN  # (not a sphere's equator)
        narrower = (widths_of(geometry.points[beyond, :2]) < widths_of(geometry.points[here, :2]) - 2 * LEDGE_MARGIN
                    if beyond.any() else np.zeros(WIDTH_DIRECTIONS, bool))
        if stepped and narrower.any():
            following = float(levels[min(np.searchsorted(levels, level) + 1, len(levels) - 1)])
            found.append((float(level), following, tuple(narrower.tolist())))
    return tuple(found)


def holding_z(pos, rot, geometry: ObjectGeometry, config: Mapping[str, Any], palm_height: float,
              closing: float | None = None) -> float:
    """World z [m] of the grip site that holds an upright body at ``pos`` (3,) with rotation ``rot`` (3, 3), the
    fingers closing along ``closing`` [rad, the body's frame; None: a lip counts only if it is one along every
    direction; a ledge always must be].

    The body's mid-height, raised so that its top stays ``palm_clearance`` below the hand
    (``palm_height`` m above the grip site) and so that the fingertips stay ``tip_clearance``
    above its bottom; then where the fingers would first meet a wider part than the one between the pads
    ([`ledges`][tableclean_suite.controllers.primitives.ledges]): a ledge just below the fingertips raises them
    ``tip_clearance`` above it (while the pads still reach ``tip_clearance`` of the part above), a lip's
    underside above the grip site raises the grip site to the lip's middle.
    """
    low, top = world_z_range(geometry, pos, rot)
    depth, tip = config["fingertip_depth"], config["tip_clearance"]
    z = max(0.5 * (low + top), top - (palm_height - config["palm_clearance"]), low + depth + tip)
    base = float(pos[2])
    k = None if closing is None else int(round(closing / (np.pi / WIDTH_DIRECTIONS))) % WIDTH_DIRECTIONS
    for ledge, _, along in ledges(geometry):
        raised = base + ledge + depth + tip
        if all(along) and z - depth - tip <= ledge + base < z and raised - depth <= top - tip:  # (a gable: no)
            z = raised
    for lip, lip_top, along in ledges(geometry, under=True):
        if (all(along) if k is None else along[k]) and z < base + lip < z + palm_height:
            z = base + 0.5 * (lip + lip_top)
    if z <= 0.5 * (low + top):  # held at mid-height or lower, the palm keeps clear of a top fingers could miss
        return z
    k = int(np.argmin(geometry.widths())) if k is None else k
    return base + fitting_z(geometry, z - base, top - base, depth, k)


def fitting_z(geometry: ObjectGeometry, z: float, top: float, depth: float, direction: int) -> float:
    """Height [m, the upright body's own frame] of the grip site at or above ``z`` where the fingers, closing along
    ``direction`` (index of ``WIDTH_DIRECTIONS``), meet the body with their pads: the slice at the pads
    (`PAD_HALF_HEIGHT` about the grip site, [`slice_width`][tableclean_suite.environments.object_geometry.ObjectGeometry.slice_width])
    at least as wide (`SLICE_MARGIN` a side) as the slice the fingertips reach below it (``depth`` m) and everything
    above it up to the body's ``top`` [m, own frame].  ``z`` itself when it fits (or no points lie at the pads:
    a box's sides are not sampled); else, of the higher grip sites up to ``top`` less `PAD_HALF_HEIGHT` that fit,
    the middle one of those whose pads meet the widest slice; ``z`` when none fits."""
    return z if _fit(geometry, z, top, depth, direction)[1] else _higher_fit(geometry, round(z, 4), round(top, 4), depth,
                                                                         direction)


def _fit(geometry: ObjectGeometry, at: float, top: float, depth: float, direction: int) -> tuple[float, bool]:
    """(slice width at pads at ``at`` [m], whether nothing the fingers reach first is wider): see `fitting_z`."""
    pads = geometry.slice_width(at - PAD_HALF_HEIGHT, at + PAD_HALF_HEIGHT, direction)
    wider = max(geometry.slice_width(at - depth, at - PAD_HALF_HEIGHT, direction),
                geometry.slice_width(at + PAD_HALF_HEIGHT, top, direction))
    return pads, pads == 0.0 or wider <= pads + 2 * SLICE_MARGIN


@functools.lru_cache(maxsize=512)
def _higher_fit(geometry: ObjectGeometry, z: float, top: float, depth: float, direction: int) -> float:
    fits = [(pads, at) for at in np.arange(z, top - PAD_HALF_HEIGHT, 0.001)
            for pads, ok in [_fit(geometry, at, top, depth, direction)] if ok and pads > 0.0]
    if not fits:
        return z
    widest = max(pads for pads, _ in fits)
    best = [at for pads, at in fits if pads >= widest - 2 * SLICE_MARGIN]
    return float(best[len(best) // 2])


def line_angle(a: float, b: float) -> float:
    """Angle [rad, in [0, pi/2]] between the horizontal lines of directions ``a`` and ``b`` [rad]."""
    turn = abs(wrap_angle(a - b))
    return min(turn, np.pi - turn)


def line_yaw(direction: float, preferred: float) -> float:
    """Of the two yaws [rad] along the line of ``direction`` (pi apart), the one nearest ``preferred``.

    The skills aim every yaw within a quarter turn of the config's ``nominal_yaw`` this way, so
    that successive turns never wind the wrist towards its joint limit.
    """
    turns = np.round(wrap_angle(preferred - direction) / np.pi)
    return wrap_angle(direction + turns * np.pi)


def nearest_neighbour(info: Info, xy, above_z: float, exclude: int | None = None) -> int | None:
    """The nearest lying object (not ``exclude``) whose top is above ``above_z`` [m] and that the hand would reach
    over ``xy`` (2,) [m]: its footprint within ``gripper_hand_reach`` of ``xy``; None when there is none."""
    tops, _ = object_heights(info)
    positions = np.asarray(info["objects_pos"], dtype=float)
    lying = ~np.asarray(info["objects_grasped"], dtype=bool)
    if exclude is not None:
        lying[exclude] = False
    gaps = np.linalg.norm(positions[:, :2] - np.asarray(xy, dtype=float)[:2], axis=1)
    near = np.flatnonzero(lying & (tops > above_z) & (gaps < float(info["gripper_hand_reach"])
                                                     + np.asarray(info["objects_footprint"], dtype=float)))
    return None if near.size == 0 else int(near[np.argmin(gaps[near])])


SPONGE = Body(
    pos=lambda info: np.asarray(info["sponge_pos"], dtype=float),
    quat=lambda info: np.asarray(info["sponge_quat"], dtype=float),
    half_size=lambda info: np.asarray(info["sponge_half_size"], dtype=float),
    grasped=lambda info: bool(info["sponge_grasped"]),
)


def grasp_point(box_pos: np.ndarray, box_half_size: np.ndarray, config: Mapping[str, Any],
                depth: float | None = None) -> np.ndarray:
    """(3,) grip-site target to grasp an upright body resting at ``box_pos`` (its centre, m).

    ``depth`` (default ``config["grasp_depth"]``) below the centre, raised if needed so that the
    fingertips stay ``tip_clearance`` above the body's bottom: a flat box (the sponge) is
    gripped high, so the fingers never drag on the surface it rests on.
    """
    depth = config["grasp_depth"] if depth is None else depth
    bottom = float(box_pos[2]) - float(box_half_size[2])
    floor = bottom + config["fingertip_depth"] + config["tip_clearance"]
    z = max(float(box_pos[2]) - depth, floor)
    return np.array([box_pos[0], box_pos[1], z])


class Primitive:
    """A named sequence of phases; subclasses set ``PHASES`` and implement `waypoint`.

    Hooks receive the running [`PrimitiveSkill`][tableclean_suite.controllers.primitives.PrimitiveSkill] (its config, setpoint and helpers) and
    the current ``skill_info()``.
    """

    PHASES: ClassVar[tuple[str, ...]] = ()
    #: Phases in which running out of step budget is retried: the primitive starts again from the measured scene.
    STALLS: ClassVar[tuple[str, ...]] = ()
    #: The settings the primitive reads from its skill's config (a skill running it must have them all).
    Config: ClassVar[type[SkillConfig]] = SkillConfig
    def start(self, skill: "PrimitiveSkill", info: Info) -> None:
        """Per-execution set-up when the primitive begins."""

    def restart(self, skill: "PrimitiveSkill", info: Info) -> None:
        """Set-up when the primitive begins again after a retryable failure (default: as `start`, from ``info``)."""
        self.start(skill, info)

    def waypoint(self, skill: "PrimitiveSkill", info: Info, phase: str) -> Waypoint:
        raise NotImplementedError

    def next(self, skill: "PrimitiveSkill", info: Info, phase: str) -> str | None:
        """The phase after ``phase`` (default: the next in ``PHASES``; None ends the primitive)."""
        index = self.PHASES.index(phase) + 1
        return self.PHASES[index] if index < len(self.PHASES) else None

    def ready(self, skill: "PrimitiveSkill", info: Info, phase: str) -> bool:
        """An extra condition for leaving ``phase`` (default True)."""
        return True

    def update(self, skill: "PrimitiveSkill", info: Info, phase: str) -> None:
        """Per-step bookkeeping before the phase is evaluated."""

    def run_loop(self, skill: "PrimitiveSkill", stepper, phase: str) -> int:
        """Run ``phase``'s next control steps in a compiled loop (after a step whose waypoint was a ``loop``
        one); returns how many ran (default: none)."""
        return 0


class Reach(Primitive):
    """One phase: go to ``target(skill, info)`` with ``gripper``; reached within ``tolerance`` (default the skill's)."""

    def __init__(self, name: str, target: Callable[["PrimitiveSkill", Info], np.ndarray], gripper: float,
                 tolerance: float | None = None):
        self.PHASES = (name,)
        self.target, self.gripper, self.tolerance = target, gripper, tolerance

    def waypoint(self, skill, info, phase):
        tol = skill.config["reach_tolerance"] if self.tolerance is None else self.tolerance
        return Waypoint(np.asarray(self.target(skill, info), dtype=float), self.gripper, tol)


class Grasp(Primitive):
    """Hover over ``body`` (gripper open), descend to its grasp point, close, confirm the grasp, lift, confirm again.

    The grasp is confirmed by what is measured, twice: after closing, both finger pads touch the
    body (contact); after lifting, they still do and the body rose with the grip site, trailing
    it by at most ``grasp_slip_tolerance`` m (slip).  Either failure, and a descent or a lift that runs
    out of steps, is retryable: the skill re-approaches the body from its measured pose (opening the
    hand where it is before it rises), within its ``retries``.  Sets the skill's target yaw from
    ``body.yaw_rule`` when it starts, with the finger line turned off a lying neighbour the hand would
    reach (`FINGER_LINE_CLEARANCE`).
    """

    PHASES = ("HOVER", "DESCEND", "CLOSE", "LIFT")
    #: a descent held up by what it met; a lift held up by a body that snagged or slipped in the hand
    STALLS = ("DESCEND", "LIFT")
    Config = GraspConfig

    def __init__(self, body: Body, what: str = "grasp"):
        self.body, self.what = body, what

    def start(self, skill, info):
        self.opening = None  # on a restart: the fingers' last (2,) positions while the hand opens in place
        self.rise_xy = None  # on a restart: (2,) m, where the open hand rises straight up before it approaches
        self.closed_at = None  # (grip-site z, body z) [m] when the closed grasp was confirmed by contact
        self._hover_seen = None  # (skill step, (2,) grip-site xy [m]) at the last hover check
        self.config = skill.config  # the settings of the grasp height (a retry lowers the fingertips)
        self._aim(skill, info)

    def restart(self, skill, info):
        """Again from the measured pose: the hand opens where it is, rises straight up to the travel height at
        its yaw, then turns and approaches as at the start."""
        self.start(skill, info)
        self.config = {**skill.config, "tip_clearance": min(skill.config["tip_clearance"], RETRY_TIP_CLEARANCE)}
        self.aim_yaw, skill.yaw = skill.yaw, skill._yaw_setpoint
        self.opening = np.full(np.shape(info["gripper_qpos"]), np.inf)
        self.rise_xy = skill.setpoint[:2]

    def update(self, skill, info, phase):
        if self.opening is not None:  # open until the fingers settle, at least close_min_steps
            fingers = np.asarray(info["gripper_qpos"], dtype=float)
            moved = float(np.max(np.abs(fingers - self.opening)))
            opened = skill._phase_steps >= skill.config["close_min_steps"] and skill.gripper_settled(moved)
            self.opening = None if opened else fingers
        elif self.rise_xy is not None and float(info["eef_pos"][2]) >= skill.hover_z(info) - skill.config["reach_tolerance"]:
            self.rise_xy, skill.yaw = None, self.aim_yaw

    def _aim(self, skill, info) -> None:
        """The target yaw for (re-)approaching the body as it lies now: across its narrow side, or
        the current one for a round body (or its type's ``yaw_rule``); turned when the open fingers
        would come down on a lying neighbour (`_clear_of_neighbour`)."""
        shape = self.body.shape(info)
        rule = self.body.yaw_rule
        if rule is None:
            rule = "any" if shape.is_round else "short_side"
        nominal = skill.config["nominal_yaw"]
        if rule == "short_side":
            object_yaw = gripper_yaw(self.body.quat(info))
            skill.yaw = grasp_yaw(shape, object_yaw, nominal)
            direction, period = shape.narrow_side()
            # of the narrow side's yaws about as near nominal (a tie, within YAW_TIE), the one nearest the hand's
            options = [skill.yaw, wrap_angle(skill.yaw - period), wrap_angle(skill.yaw + period)]
            limit = abs(wrap_angle(skill.yaw - nominal)) + YAW_TIE
            current = gripper_yaw(info["eef_quat"])
            skill.yaw = min((y for y in options if abs(wrap_angle(y - nominal)) <= limit),
                            key=lambda y: abs(wrap_angle(y - current)))
            lines = [object_yaw + direction + k * period for k in range(int(round(np.pi / period)))]
        else:
            skill.yaw = gripper_yaw(info["eef_quat"])
            lines = None  # any yaw grasps it
        self._clear_of_neighbour(skill, info, lines)

    def _clear_of_neighbour(self, skill, info, lines: list[float] | None) -> None:
        """Turn the finger line (the grip site's x axis) away from the nearest lying neighbour the hand would
        reach at the grasp, when it points within `FINGER_LINE_CLEARANCE` of it: to the allowed finger
        line of ``lines`` (rad) most across the neighbour, or (``lines`` None: any yaw grasps the body) to the
        line just `FINGER_LINE_CLEARANCE` from it nearer the current aim; at the yaw nearest ``nominal_yaw``.
        No neighbour or a body that is no task object (the sponge): the yaw stays."""
        if self.body.geometry is None or self.body.index is None:
            return
        pos = self.body.pos(info)
        fingertips = float(self.grasp_target(skill, info)[2]) - skill.config["fingertip_depth"]
        j = nearest_neighbour(info, pos[:2], fingertips, exclude=self.body.index)
        if j is None:
            return
        toward_vec = np.asarray(info["objects_pos"][j], dtype=float)[:2] - pos[:2]
        toward = float(np.arctan2(toward_vec[1], toward_vec[0]))
        if line_angle(skill.yaw, toward) >= FINGER_LINE_CLEARANCE:
            return
        nominal = skill.config["nominal_yaw"]
        if lines is None:  # just far enough, on the side nearer the current aim: the smaller turn
            options = [line_yaw(toward + side * FINGER_LINE_CLEARANCE, nominal) for side in (-1.0, 1.0)]
            skill.yaw = min(options, key=lambda yaw: abs(wrap_angle(yaw - skill.yaw)))
        else:
            skill.yaw = line_yaw(max(lines, key=lambda line: line_angle(line, toward)), nominal)

    def grasp_target(self, skill, info) -> np.ndarray:
        """(3,) grip-site target: the type's ``grasp_depth`` below the centre, else the holding height."""
        pos = self.body.pos(info)
        if self.body.grasp_depth is not None or self.body.geometry is None:
            return grasp_point(pos, self.body.half_size(info), skill.config, self.body.grasp_depth)
        quat = self.body.quat(info)
        z = holding_z(pos, quat_to_matrix(quat), self.body.shape(info), self.config,
                      float(info["gripper_palm_height"]), skill.yaw - gripper_yaw(quat))
        return np.array([pos[0], pos[1], z])

    def waypoint(self, skill, info, phase):
        pos = self.body.pos(info)
        tol = skill.config["reach_tolerance"]
        if phase == "HOVER":
            if self.opening is not None:  # never reached (tolerance -1): the hand holds still while it opens
                return Waypoint(skill.setpoint, GRIPPER_OPEN, -1.0)
            if self.rise_xy is not None:
                return Waypoint(np.array([*self.rise_xy, skill.hover_z(info)]), GRIPPER_OPEN, -1.0)
            return Waypoint(skill.hover_point(info, pos[:2]), GRIPPER_OPEN, tol)
        if phase == "DESCEND":
            grasp = self.grasp_target(skill, info)
            return Waypoint(grasp, GRIPPER_OPEN, tol, speed=skill.config["descend_speed"])
        if phase == "CLOSE":
            return Waypoint(skill.setpoint, GRIPPER_CLOSE, np.inf, min_steps=skill.config["close_min_steps"], fixed=True)
        # straight up from where the grasp closed (a carried body hanging off-centre would otherwise move the
        # target with every step), to the travel height of the last step the pads held the body
        if self.lift_z is None or self.body.grasped(info):
            self.lift_z = skill.hover_z(info)
        return Waypoint(np.array([*self.lift_xy, self.lift_z]), GRIPPER_CLOSE, tol)

    def ready(self, skill, info, phase):
        if phase == "HOVER":
            return self._hover_settled(skill, info)
        return True

    def _hover_settled(self, skill, info) -> bool:
        """Whether the hand, at its hover point, is nearly still: its horizontal speed over the last control
        step is at most the config's ``hover_still_speed`` (m/s; None: always, no wait).  The wait counts
        against the skill's step budget."""
        still = skill.config.get("hover_still_speed")
        if still is None:
            return True
        xy = np.asarray(info["eef_pos"], dtype=float)[:2].copy()
        seen, self._hover_seen = self._hover_seen, (skill.steps, xy)
        if seen is None or seen[0] != skill.steps - 1:  # no speed over the last step yet: one more step
            return False
        return float(np.linalg.norm(xy - seen[1])) <= still * skill.dt

    def slipped(self, skill, info) -> float:
        """How far [m] the body trailed the grip site's rise since the grasp closed (0 when it kept up)."""
        eef_z0, body_z0 = self.closed_at
        rise = float(np.asarray(info["eef_pos"], dtype=float)[2]) - eef_z0
        carried = float(self.body.pos(info)[2]) - body_z0
        return max(rise - carried, 0.0)

    def next(self, skill, info, phase):
        if phase == "CLOSE":
            if not self.body.grasped(info):
                raise SkillFailure(f"{self.what} not confirmed", redo=0)
            self.closed_at = (float(np.asarray(info["eef_pos"], dtype=float)[2]), float(self.body.pos(info)[2]))
            self.lift_xy = np.asarray(info["eef_pos"], dtype=float)[:2].copy()  # (2,) m, where LIFT rises
            self.lift_z = None  # m, LIFT's target height (see waypoint)
        if phase == "LIFT":
            tolerance = skill.config["grasp_slip_tolerance"]
            if not self.body.grasped(info):
                raise SkillFailure(f"{self.what} lost while lifting", redo=0)
            slip = self.slipped(skill, info)
            if slip > tolerance:
                raise SkillFailure(f"{self.what} slipped {slip * 1000:.0f} mm while lifting", redo=0)
        return super().next(skill, info, phase)


class Release(Primitive):
    """Hover over ``spot(skill, info)`` (2,), lower the carried ``body`` until it rests, open, retreat.

    ``rest_z(skill, info)``: the height [m] of the body's centre when it rests at the spot.  The
    grip-site-to-body offset is measured when the primitive starts (the grasp may have slipped):
    the grip site aims so that the body's centre (not the hand) comes over the spot, and lowers it
    to ``rest_z`` + ``place_clearance``.  A body with a geometry also counts as lowered once its
    lowest point, at its current pose, is within ``place_clearance`` of the surface it rests on
    (a body hanging tilted in the hand touches down before the grip site reaches its target).
    """

    PHASES = ("ALIGN", "DESCEND", "RELEASE", "RETREAT")
    STALLS = ("DESCEND",)
    Config = ReleaseConfig

    def __init__(self, body: Body, spot: Callable[["PrimitiveSkill", Info], np.ndarray],
                 rest_z: Callable[["PrimitiveSkill", Info], float]):
        self.body, self.spot, self.rest_z = body, spot, rest_z

    def start(self, skill, info):
        offset = np.asarray(info["eef_pos"], dtype=float) - self.body.pos(info)
        self.hold_offset_z = float(offset[2])
        # the body's centre over the spot (for the sponge, the grip site, as it was tuned)
        shift = offset[:2] if self.body.geometry is not None else np.zeros(2)
        self.xy = np.asarray(self.spot(skill, info), dtype=float)[:2] + shift
        self._turn_hand_away(skill, info)

    def _turn_hand_away(self, skill, info) -> None:
        """Turn the hand's long (finger) axis across the direction of the nearest lying object whose top the
        hand would reach at release (within ``gripper_hand_reach`` of the spot): the hand's narrow side then
        faces it.  No such object (the paper's scenes): the yaw stays.

        The direction is to the object's centre; to the nearest point of its footprint
        ([`nearest_point`][tableclean_suite.environments.placement.nearest_point]) when its top reaches the links above
        the hand ([`wrist_reach`][tableclean_suite.controllers.primitives.wrist_reach], the env's [`gripper_of`][tableclean_suite.controllers.primitives.gripper_of]): then the whole (convex) footprint lies
        beyond the hand's and wrist's half width, as [`place_spot`][tableclean_suite.controllers.place.place_spot] counted it."""
        if self.body.geometry is None:
            return
        grip_z = float(self.rest_z(skill, info)) + skill.config["place_clearance"] + self.hold_offset_z
        hand_bottom = grip_z + float(info["gripper_palm_height"])
        j = nearest_neighbour(info, self.xy, hand_bottom)
        if j is None:
            return
        toward = np.asarray(info["objects_pos"][j], dtype=float)[:2] - self.xy
        tops, _ = object_heights(info)
        if wrist_reach(info, gripper_of(getattr(skill, "env", None)), tops[j], grip_z) is not None:
            near = nearest_point(info["objects_pos"][j], footprint_of(info, j), self.xy) - self.xy
            if float(np.hypot(near[0], near[1])) > 0.0:
                toward = near
        across = float(np.arctan2(toward[1], toward[0])) + 0.5 * np.pi
        skill.yaw = line_yaw(across, skill.config["nominal_yaw"])  # not the current one's: no wind-up

    def rests(self, skill, info) -> bool:
        """Whether the body's lowest point is within ``place_clearance`` of the surface it rests on at ``rest_z``."""
        if self.body.geometry is None:
            return False
        shape = self.body.shape(info)
        surface = float(self.rest_z(skill, info)) + float(shape.lower[2])
        lowest = world_lowest_z(shape, self.body.pos(info), quat_to_matrix(self.body.quat(info)))
        return lowest <= surface + skill.config["place_clearance"]

    def waypoint(self, skill, info, phase):
        tol = skill.config["reach_tolerance"]
        if phase == "ALIGN":
            return Waypoint(skill.hover_point(info, self.xy), GRIPPER_CLOSE, tol)
        if phase == "DESCEND":
            if self.rests(skill, info):  # touched down: no lower
                return Waypoint(skill.setpoint, GRIPPER_CLOSE, np.inf)
            z = float(self.rest_z(skill, info)) + skill.config["place_clearance"] + self.hold_offset_z
            return Waypoint(np.array([*self.xy, z]), GRIPPER_CLOSE, tol, speed=skill.config["descend_speed"])
        if phase == "RELEASE":
            return Waypoint(skill.setpoint, GRIPPER_OPEN, np.inf, min_steps=skill.config["release_min_steps"], fixed=True)
        return Waypoint(skill.hover_point(info, self.xy), GRIPPER_OPEN, tol)

    def ready(self, skill, info, phase):
        return phase != "RELEASE" or not self.body.grasped(info)


class PrimitiveSkill(Skill):
    """A skill that runs a list of ``(prefix, Primitive)`` built by [`build`][tableclean_suite.controllers.primitives.PrimitiveSkill.build] at each execution.

    The class's ``Phase`` enum must have one member per ``prefix + phase`` of its primitives
    (in order) and a final member (e.g. ``DONE``); [`build`][tableclean_suite.controllers.primitives.PrimitiveSkill.build] is checked against it.
    """

    def build(self, info: Info) -> list[tuple[str, Primitive]]:
        """The primitives of this execution (``self.state`` is the symbolic state before it)."""
        raise NotImplementedError

    @property
    def setpoint(self) -> np.ndarray:
        """(3,) a copy of the current rate-limited position setpoint [m] (hold still there)."""
        return self._setpoint.copy()

    def on_reset(self, info: Info) -> None:
        self.plan = self.build(info)
        names = {m.name for m in self.Phase}
        for prefix, primitive in self.plan:
            missing = [prefix + p for p in primitive.PHASES if prefix + p not in names]
            if missing:
                raise TypeError(f"{type(self).__name__}.Phase lacks the phases {missing} of {type(primitive).__name__}")
            lacking = [key for key in primitive.Config.keys() if key not in self.config]
            if lacking:
                raise TypeError(f"{type(self).__name__}'s config lacks the settings {lacking} of "
                                f"{type(primitive).__name__} (its Config: {primitive.Config.__name__})")
        self.stage = 0
        self._enter(0, info)

    def restart(self, info: Info, redo: int) -> bool:
        """Start the current primitive again (``redo`` 0), or the one ``redo`` places before it, from ``info``."""
        self._enter(max(self.stage - redo, 0), info, again=True)
        return True

    def _enter(self, index: int, info: Info, again: bool = False) -> enum.Enum:
        self.stage = index
        if index >= len(self.plan):
            self.phase = self.final_phase
            return self.phase
        prefix, primitive = self.plan[index]
        (primitive.restart if again else primitive.start)(self, info)
        self.phase = self.Phase[prefix + primitive.PHASES[0]]
        return self.phase

    def _current(self) -> tuple[Primitive, str]:
        prefix, primitive = self.plan[self.stage]
        return primitive, self.phase.name[len(prefix):]

    def waypoint(self, info: Info) -> Waypoint:
        primitive, local = self._current()
        return primitive.waypoint(self, info, local)

    def next_phase(self, info: Info) -> enum.Enum:
        primitive, local = self._current()
        following = primitive.next(self, info, local)
        if following is None:
            return self._enter(self.stage + 1, info)
        return self.Phase[self.plan[self.stage][0] + following]

    def phase_ready(self, info: Info) -> bool:
        primitive, local = self._current()
        return primitive.ready(self, info, local)

    def stall_redo(self) -> int | None:
        primitive, local = self._current()
        return 0 if local in primitive.STALLS else None

    def run_loop_phase(self, stepper) -> int:
        primitive, local = self._current()
        return primitive.run_loop(self, stepper, local)

    def update(self, info: Info) -> None:
        primitive, local = self._current()
        primitive.update(self, info, local)
