"""Typed, frozen settings of the primitives and skills (a leaf module: it imports nothing of the package).

One dataclass per primitive and skill; each field states its unit and allowed range, and ``__post_init__``
refuses a value outside it with a `ValueError` naming the field, the value and the range.  A skill's config
type is the union of its primitives' (by inheritance: ``CleanConfig(WipeConfig, GraspConfig, ReleaseConfig)``),
with the skill's own defaults on top.  A skill's values (its defaults, the robot's and gripper's overrides, the
caller's; the documentation's "Objects and skills" page gives the order) are checked once, by
[`checked_skill_config`][tableclean_suite.controllers.configs.checked_skill_config]: a skill's constructor, a
robot's per-action overrides and [`compose_skill`][tableclean_suite.controllers.authoring.compose_skill] refuse
the same settings with the same [`SkillConfigError`][tableclean_suite.controllers.configs.SkillConfigError].
"""

from __future__ import annotations

import math
import numbers
import warnings
from dataclasses import dataclass, field, fields
from typing import Any, Mapping

__all__ = ["SkillConfig", "GraspConfig", "ReleaseConfig", "WipeConfig", "MoveConfig", "PickConfig",
           "PlaceConfig", "CleanConfig", "ComposedConfig", "GRASP_SLIP_TOLERANCE", "setting",
           "SkillConfigError", "checked_skill_config", "RENAMED_KEYS"]

#: A lifted body may trail the grip site's rise by at most this [m] before the grasp counts as
#: slipping (the default of [`GraspConfig.grasp_slip_tolerance`][tableclean_suite.controllers.configs.GraspConfig.grasp_slip_tolerance]).
GRASP_SLIP_TOLERANCE = 0.01

_INF = math.inf


def setting(default, unit: str, low: float = -_INF, high: float = _INF, *, integer: bool = False,
            optional: bool = False, low_open: bool = False):
    """A config field: ``default`` with its ``unit`` and allowed range ``[low, high]`` (``(low, high]`` with
    ``low_open``); ``integer``: an int (not a bool); ``optional``: ``None`` is allowed too."""
    return field(default=default, metadata={"unit": unit, "low": low, "high": high, "integer": integer,
                                            "optional": optional, "low_open": low_open})


def _allowed(meta: dict) -> str:
    """The allowed range of a field as text, e.g. ``"an int >= 1"``, ``"a number in [0, 1]"``."""
    kind = "an int" if meta["integer"] else "a number"
    low, high = meta["low"], meta["high"]
    if low > -_INF and high < _INF:
        text = f"{kind} in {'(' if meta['low_open'] else '['}{low:g}, {high:g}]"
    elif low > -_INF:
        text = f"{kind} {'>' if meta['low_open'] else '>='} {low:g}"
    elif high < _INF:
        text = f"{kind} <= {high:g}"
    else:
        text = f"a finite {kind[2:] if kind.startswith('a ') else kind[3:]}"
    return f"None or {text}" if meta["optional"] else text


def _valid(value: Any, meta: dict) -> bool:
    if value is None:
        return meta["optional"]
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return False
    if meta["integer"] and not isinstance(value, numbers.Integral):
        return False
    if not math.isfinite(value):
        return False
    above = value > meta["low"] if meta["low_open"] else value >= meta["low"]
    return above and value <= meta["high"]


@dataclass(frozen=True)
class SkillConfig:
    """Settings every skill understands (the shared base of every skill's config)."""

    max_steps: int = setting(400, "control steps", 1, integer=True)
    """Control steps (int >= 1) before the skill gives up."""
    speed: float = setting(0.4, "m/s", 0.0, low_open=True)
    """m/s (> 0), maximum speed of the rate-limited setpoint."""
    descend_speed: float = setting(0.25, "m/s", 0.0, low_open=True)
    """m/s (> 0), speed of the slower final approaches: a grasp's and a release's descent, a wipe's press."""
    reach_tolerance: float = setting(0.008, "m", 0.0, low_open=True)
    """m (> 0), achieved-to-waypoint distance that counts as reached."""
    gripper_still: float = setting(2e-4, "finger joint units per control step", 0.0)
    """Finger joint motion per control step (>= 0; m for the Panda's slide fingers, rad for hinged ones)
    below which the gripper has settled; see ``Skill.gripper_settled`` for the other two rules."""
    gripper_window: int | None = setting(None, "control steps", 1, integer=True, optional=True)
    """Control steps (None or int >= 1) of each of the two windows whose mean finger positions are
    compared; None: rule off (grippers whose fingers jitter without stopping, e.g. the Robotiq 85's linkage)."""
    gripper_drift: float = setting(0.0, "finger joint units per control step", 0.0)
    """Finger joint units per control step (>= 0): the windowed mean drifting slower than this has settled."""
    gripper_timeout: int | None = setting(None, "control steps", 1, integer=True, optional=True)
    """Control steps (None or int >= 1) in a phase after which the gripper counts as settled; None: never."""
    hover_height: float = setting(0.08, "m", 0.0)
    """m (>= 0) above the table top at which the gripper travels and hovers (clears a carried 4.5 cm cube)."""
    yaw_rate: float = setting(1.5, "rad/s", 0.0, low_open=True)
    """rad/s (> 0), maximum turning speed of the gripper-yaw setpoint (faster turns hit wrist limits)."""
    yaw_tolerance: float = setting(0.1, "rad", 0.0, math.pi, low_open=True)
    """rad (in (0, pi]), achieved-to-target gripper yaw error that counts as reached."""
    nominal_yaw: float = setting(0.5 * math.pi, "rad", -math.pi, math.pi)
    """rad (in [-pi, pi]), preferred gripper yaw when a grasp allows several: the Panda's grip site has
    yaw pi/2 at robosuite's home pose (fingers closing along world y); yaws near 0 or pi hit wrist limits."""
    fingertip_depth: float = setting(0.0135, "m", 0.0)
    """m (>= 0), lowest point of the gripper's finger collision meshes below its grip site (the Panda's)."""
    carry_clearance: float = setting(0.01, "m", 0.0)
    """m (>= 0) a carried body's bottom stays above the tallest lying object's top."""
    retries: int = setting(2, "retries", 0, integer=True)
    """Retries (int >= 0) per execution: a grasp, place or wipe that missed its phase goal re-measures the
    scene and starts that part again ([`Skill.restart`][tableclean_suite.controllers.skill.Skill.restart]) at most this
    often in all before the skill fails; 0: open loop."""
    carry_lift: float = setting(0.03, "m", 0.0)
    """m (>= 0) a carried body's bottom stays above the table top: clears the 2 cm sponge stand and lifts
    an object beyond the abstraction's 1.5 cm lift tolerance."""

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if not _valid(value, f.metadata):
                raise ValueError(f"{f.name} must be {_allowed(f.metadata)} ({f.metadata['unit']}), got {value!r} "
                                 f"({type(self).__name__})")
        self.check()

    def check(self) -> None:
        """Hook: checks across fields (raise `ValueError` naming them)."""

    def as_dict(self) -> dict[str, Any]:
        """``{field name: value}`` (the dict form skills index as ``skill.config[name]``)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def keys(cls) -> list[str]:
        """The field names, in declaration order."""
        return [f.name for f in fields(cls)]


@dataclass(frozen=True)
class GraspConfig(SkillConfig):
    """Settings of the Grasp primitive (grasp a body from above)."""

    grasp_depth: float = setting(0.0, "m")
    """m (finite; negative: above) below the body's centre at which the grip site closes when the body has
    no geometry to hold it by (the sponge); raised so that the fingertips keep ``tip_clearance``."""
    tip_clearance: float = setting(0.010, "m", 0.0)
    """m (>= 0) the fingertips stay above the body's bottom (and so above the table)."""
    palm_clearance: float = setting(0.005, "m", 0.0)
    """m (>= 0) a grasped object's top stays below the hand (the gripper's measured palm height)."""
    close_min_steps: int = setting(4, "control steps", 0, integer=True)
    """Control steps (int >= 0) to keep closing before checking the fingers settled."""
    hover_still_speed: float | None = setting(None, "m/s", 0.0, low_open=True, optional=True)
    """m/s (None or > 0): the hand's horizontal speed at the hover point at most which the descent may start
    (an arm whose hand swings on past the hover point while descending); None: descend on arrival."""
    grasp_slip_tolerance: float = setting(GRASP_SLIP_TOLERANCE, "m", 0.0, low_open=True)
    """m (> 0) a lifted body may trail the grip site's rise before the grasp counts as slipping."""


@dataclass(frozen=True)
class ReleaseConfig(SkillConfig):
    """Settings of the Release primitive (set the held body down and let go)."""

    place_clearance: float = setting(0.006, "m", 0.0)
    """m (>= 0) between the held body's bottom and the surface it is put on at release."""
    release_min_steps: int = setting(3, "control steps", 0, integer=True)
    """Control steps (int >= 0) to keep opening before checking the fingers settled."""


@dataclass(frozen=True)
class WipeConfig(SkillConfig):
    """Settings of the Wipe primitive (strokes of the held sponge over a segment, pressed by a force loop)."""

    press_force: float = setting(8.0, "N", 0.0, low_open=True)
    """N (> 0), the pressing force the depth loop holds while wiping."""
    touch_force: float = setting(1.0, "N", 0.0)
    """N (>= 0); a stroke starts once at least this contact force is measured."""
    press_force_gain: float = setting(0.0005, "m/(N s)", 0.0)
    """m/(N s) (>= 0), integral gain from the force error to the commanded depth."""
    gap_gain: float = setting(5.0, "1/s", 0.0)
    """1/s (>= 0), extra descent rate per m the sponge's lowest corner is above the table."""
    contact_slack: float = setting(0.0005, "m", 0.0)
    """m (>= 0) of that gap that count as touching."""
    press_start_depth: float = setting(0.002, "m")
    """m (finite) below the table top the first press aims at before any force is measured."""
    min_press_depth: float = setting(-0.01, "m")
    """m (finite, <= ``max_press_depth``), the depth loop's lower bound (negative: above the table top,
    for a sponge slid up in the hand)."""
    max_press_depth: float = setting(0.02, "m")
    """m (finite, >= ``min_press_depth``), the depth loop's bound below the table top."""
    setpoint_arrival: float = setting(1e-4, "m", 0.0, low_open=True)
    """m (> 0); the press integrates once the rate-limited setpoint is this close to its height."""
    wipe_speed: float = setting(0.25, "m/s", 0.0, low_open=True)
    """m/s (> 0) along the strokes."""
    wipe_tolerance: float = setting(0.02, "m", 0.0, low_open=True)
    """m (> 0, horizontal); table friction keeps the pressed sponge a little behind its setpoint."""
    edge_inset: float = setting(1.0, "fraction of the sponge's half extent", 0.0)
    """Fraction (>= 0) of the sponge's half extent its centre keeps inside the segment's edges; 1 with no
    overlap makes the lanes tile the segment exactly (3 lanes on the default 0.24 m segment)."""
    repeat_lane_shift: float = setting(0.5, "fraction of the lane spacing", 0.0, 1.0)
    """Fraction (in [0, 1]) of the lane spacing repeated passes shift the lanes by."""
    wipe_overlap: float = setting(0.0, "fraction of the sponge width", 0.0, 1.0)
    """Fraction (in [0, 1]) of the sponge width shared by neighbouring lanes (the wipe reach covers the seams)."""
    shift_clearance: float = setting(0.005, "m", 0.0)
    """m (>= 0) the sponge's bottom is lifted while it shifts to the next stroke (dragged, it tips in the hand)."""
    press_max_steps: int = setting(12, "control steps", 0, integer=True)
    """Control steps (int >= 0) after which a stroke starts even if no force was measured; the force
    loop then deepens the contact."""
    lift_max_steps: int = setting(10, "control steps", 0, integer=True)
    """Control steps (int >= 0) a SHIFT lifts at most before moving on."""
    stroke_max_steps: int = setting(40, "control steps", 1, integer=True)
    """Control steps (int >= 1) after which a stroke ends wherever the sponge got (~20 at ``wipe_speed``)."""
    max_drift_correction: float = setting(0.02, "m", 0.0)
    """m (>= 0), bound of the wipe target's lead over the sponge's drift."""
    max_passes: int = setting(3, "passes", 1, integer=True)
    """Wipe passes (int >= 1) at most; a pass is repeated only while the segment is dirty."""

    def check(self) -> None:
        if self.min_press_depth > self.max_press_depth:
            raise ValueError(f"min_press_depth ({self.min_press_depth!r} m) must be <= max_press_depth "
                             f"({self.max_press_depth!r} m) ({type(self).__name__})")


@dataclass(frozen=True)
class MoveConfig(SkillConfig):
    """Settings of [`MoveSkill`][tableclean_suite.controllers.move.MoveSkill]."""

    max_steps: int = setting(200, "control steps", 1, integer=True)
    """Control steps (int >= 1) before the move gives up."""
    lift_tolerance: float = setting(0.03, "m", 0.0, low_open=True)
    """m (> 0); the lift only needs to clear the table, not be exact."""


@dataclass(frozen=True)
class PickConfig(GraspConfig):
    """Settings of [`PickSkill`][tableclean_suite.controllers.pick.PickSkill] (the Grasp primitive's)."""

    max_steps: int = setting(250, "control steps", 1, integer=True)
    """Control steps (int >= 1) before the pick gives up."""


@dataclass(frozen=True)
class PlaceConfig(GraspConfig, ReleaseConfig):
    """Settings of [`PlaceSkill`][tableclean_suite.controllers.place.PlaceSkill]: the Release primitive's, and the
    Grasp's for a retry that grasps a misplaced object again."""

    max_steps: int = setting(250, "control steps", 1, integer=True)
    """Control steps (int >= 1) before the place gives up."""


@dataclass(frozen=True)
class ComposedConfig(GraspConfig, ReleaseConfig):
    """Settings of a skill made by ``compose_skill`` without a wipe: the Grasp and Release primitives'."""

    max_steps: int = setting(250, "control steps", 1, integer=True)
    """Control steps (int >= 1) before the skill gives up (``compose_skill``'s ``max_steps`` sets it)."""


@dataclass(frozen=True)
class CleanConfig(WipeConfig, GraspConfig, ReleaseConfig):
    """Settings of [`CleanSkill`][tableclean_suite.controllers.clean.CleanSkill] (and of composed skills that wipe)."""

    max_steps: int = setting(900, "control steps", 1, integer=True)
    """Control steps (int >= 1) before the clean gives up."""
    tip_clearance: float = setting(0.004, "m", 0.0)
    """m (>= 0) the fingertips stay above the sponge's bottom (0.010 for objects: gripped low, it drags less)."""
    place_clearance: float = setting(0.004, "m", 0.0)
    """m (>= 0) above its home at which the sponge is released."""


#: Old config keys still accepted, with the key that replaced them (a ``DeprecationWarning`` says so).
RENAMED_KEYS = {"grasp_retries": "retries"}


class SkillConfigError(KeyError, ValueError):
    """Settings a skill refuses (a ``KeyError`` and a ``ValueError``): a key it does not know, or a value outside
    its ``Config``'s range; the message is one line naming the skill, the key and the allowed keys or range."""

    def __str__(self) -> str:  # a KeyError would quote the message
        return str(self.args[0]) if self.args else ""


def checked_skill_config(owner: str, config_type, defaults: Mapping[str, Any],
                         overrides: Mapping[str, Any] | None = None):
    """``({**defaults, **overrides}, the config_type instance of them)``, both checked.

    Args:
        owner: the skill as the message names it (e.g. ``"PickSkill"``, ``"skill 'transfer'"``).
        config_type: the skill's [`SkillConfig`][tableclean_suite.controllers.configs.SkillConfig] subclass (its ``keys()`` and ranges).
        defaults: the skill's settings before ``overrides`` (its ``DEFAULT_CONFIG``); their keys
            are the keys allowed (keys ``config_type`` lacks pass through unchecked).
        overrides: the values to put on top.

    Raises:
        SkillConfigError: a key of ``overrides`` not in ``defaults`` (naming the keys and the allowed
            ones), or a merged value outside ``config_type``'s range (naming the field, the value
            and the range).
    """
    overrides = dict(overrides or {})
    for old, new in RENAMED_KEYS.items():
        if old in overrides and new in defaults:
            warnings.warn(f"{owner}: config key {old!r} is now {new!r}", DeprecationWarning, stacklevel=3)
            overrides.setdefault(new, overrides.pop(old))
    unknown = sorted(set(overrides) - set(defaults))
    if unknown:
        raise SkillConfigError(f"unknown config keys for {owner}: {unknown} (allowed: {sorted(defaults)})")
    merged = {**defaults, **overrides}
    try:
        settings = config_type(**{key: merged[key] for key in config_type.keys() if key in merged})
    except ValueError as error:
        raise SkillConfigError(f"{owner}: {error}") from None
    return merged, settings
