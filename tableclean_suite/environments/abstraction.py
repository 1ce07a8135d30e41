"""Physical-to-symbolic abstraction: an observation mapping -> the task model's [`TaskState`][tableclean_suite.task.state.TaskState].

The only place the task's physical thresholds are applied; pure functions of an observation mapping
(``env.skill_info()`` is one) and a config (`DEFAULT_TABLECLEAN_CONFIG` when ``None``).

Observation keys (world frame, metres):

Required
    - ``"dirt_fraction"`` (N,): fraction of dirt markers still present per segment (1.0 = all dirty).
    - ``"object_pos"`` (3,) and ``"object_grasped"`` bool (both finger pads touch it); or, for M
      objects, ``"objects_pos"`` (M, 3) and ``"objects_grasped"`` (M,) (optional ``"objects_rest_z"`` (M,)).
    - ``"eef_pos"`` (3,): gripper site position.
    - ``"sponge_pos"`` (3,): sponge centre (only when ``check_sponge``).
Optional (defaults from the config's scene geometry)
    - ``"sponge_home_pos"`` (3,), ``"sponge_grasped"`` bool (default False).
    - ``"table_top_z"`` float, ``"table_center"`` (3,), ``"table_half_size"`` (2,).
    - ``"segment_centers"`` (N, 3), ``"segment_half_sizes"`` (N, 2) (N = 2 by default).
    - ``"object_rest_z"`` float (default ``table_top_z + object_half_size[2]``), ``"object_half_size"`` (3,).
    - ``"qvel"`` (n,): simulation velocities, checked against ``max_stable_speed``.

Situations the task model has no state for raise [`AbstractionError`][tableclean_suite.environments.abstraction.AbstractionError] (``.fault`` a
[`Fault`][tableclean_suite.environments.abstraction.Fault]); nothing is mapped silently.
"""

from __future__ import annotations

import enum
import math
from typing import Mapping

import numpy as np

from tableclean_suite.environments.config import make_config, scene_geometry
from tableclean_suite.task import HELD, TaskState

#: Observation keys read from the physics and checked for NaN/inf by [`check_stability`][tableclean_suite.environments.abstraction.check_stability].
PHYSICAL_KEYS = ("object_pos", "eef_pos", "sponge_pos", "dirt_fraction", "qvel")
#: Slack on the clean test so that e.g. 0.9 wiped of 10 markers (float 0.09999...) counts as clean.
_FRACTION_EPS = 1e-9


class Fault(str, enum.Enum):
    """A physical situation the symbolic task model has no state for."""

    UNSTABLE = "unstable"  # non-finite values or speeds above max_stable_speed
    OBJECT_OFF_TABLE = "object_off_table"  # object outside the table top or below it
    OBJECT_BETWEEN_SEGMENTS = "object_between_segments"  # on the table but on neither segment
    OBJECT_LIFTED_NOT_GRASPED = "object_lifted_not_grasped"  # above its resting height, not held
    ARM_NOT_OVER_SEGMENT = "arm_not_over_segment"  # gripper not above any segment
    OBJECTS_HELD = "objects_held"  # more than one object grasped and lifted at once
    SPONGE_AWAY_FROM_HOME = "sponge_away_from_home"  # sponge not at its home while no skill runs


class AbstractionError(RuntimeError):
    """Raised when the physical state maps to no task state; ``fault`` says which [`Fault`][tableclean_suite.environments.abstraction.Fault]."""

    def __init__(self, fault: Fault, message: str):
        super().__init__(f"{fault.value}: {message}")
        self.fault = Fault(fault)


_DEFAULT_CONFIG = make_config()


def resolve_config(config: Mapping | None) -> Mapping:
    """The full validated config: the default for ``None``, else ``config`` merged into the default."""
    return _DEFAULT_CONFIG if config is None else make_config(config)


def _require(obs: Mapping, *keys: str) -> None:
    missing = [k for k in keys if k not in obs]
    if missing:
        raise KeyError(f"observation lacks key(s) {missing} needed by the abstraction; has {sorted(obs)}")


def _geometry_value(obs: Mapping, key: str, config: Mapping) -> np.ndarray:
    """``obs[key]`` as float array, else the same attribute of the config's (two-segment) scene geometry."""
    if key in obs:
        return np.asarray(obs[key], dtype=float)
    return np.asarray(getattr(scene_geometry(config), key), dtype=float)


def check_stability(obs: Mapping, config: Mapping | None = None) -> None:
    """Raise ``UNSTABLE`` when a physical reading (`PHYSICAL_KEYS`) is non-finite or ``|qvel|`` is too high."""
    config = resolve_config(config)
    for key in PHYSICAL_KEYS:
        if key in obs and not math.isfinite(float(np.sum(obs[key]))):  # NaN/inf propagate through the sum
            raise AbstractionError(Fault.UNSTABLE, f"observation {key!r} is not finite: {obs[key]!r}")
    if "qvel" in obs and len(obs["qvel"]):
        speed = float(np.max(np.abs(obs["qvel"])))
        if speed > config["max_stable_speed"]:
            raise AbstractionError(Fault.UNSTABLE, f"simulation speed {speed:.1f} exceeds max_stable_speed "
                                                   f"{config['max_stable_speed']}")


def segments_clean(dirt_fraction, config: Mapping | None = None) -> np.ndarray:
    """Bool (N,): a segment is clean when its remaining dirt fraction is <= ``1 - clean_fraction``."""
    config = resolve_config(config)
    dirt = np.asarray(dirt_fraction, dtype=float)
    if dirt.ndim != 1 or dirt.size < 1:
        raise ValueError(f"dirt_fraction must have shape (N,) with N >= 1 segments, got {dirt.shape}")
    return dirt <= 1.0 - config["clean_fraction"] + _FRACTION_EPS


def segment_of_xy(xy, segment_centers, segment_half_sizes, margin: float = 0.0) -> int | None:
    """The segment whose area, grown by ``margin`` [m], contains ``xy``; the nearest if several; else ``None``.

    Plain float arithmetic over the N segments (faster than NumPy on arrays this small).
    """
    x, y = float(xy[0]), float(xy[1])
    best, best_distance = None, math.inf
    for segment in range(len(segment_centers)):
        cx, cy = float(segment_centers[segment][0]), float(segment_centers[segment][1])
        hx, hy = float(segment_half_sizes[segment][0]), float(segment_half_sizes[segment][1])
        if abs(x - cx) <= hx + margin and abs(y - cy) <= hy + margin:
            distance = math.hypot(x - cx, y - cy)
            if distance < best_distance:
                best, best_distance = segment, distance
    return best


def object_locations(obs: Mapping, config: Mapping | None = None) -> tuple[int, ...]:
    """Where each object is (HELD or a 0-based segment), from ``objects_*`` keys or the single ``object_*`` ones.

    Raises [`AbstractionError`][tableclean_suite.environments.abstraction.AbstractionError] on the first object the model has no location for.
    """
    config = resolve_config(config)
    if "objects_pos" in obs:
        _require(obs, "objects_pos", "objects_grasped")
        positions = np.asarray(obs["objects_pos"], dtype=float).reshape(-1, 3)
        grasped = [bool(g) for g in np.asarray(obs["objects_grasped"]).reshape(-1)]
        rest = obs.get("objects_rest_z")
        rest = [None] * len(positions) if rest is None else [float(z) for z in np.asarray(rest).reshape(-1)]
        labels = [f"object {j + 1}" for j in range(len(positions))]
    else:
        _require(obs, "object_pos", "object_grasped")
        positions = [np.asarray(obs["object_pos"], dtype=float)]
        grasped = [bool(obs["object_grasped"])]
        rest = [float(obs["object_rest_z"]) if "object_rest_z" in obs else None]
        labels = ["object"]
    return tuple(_one_location(p, g, z, label, obs, config) for p, g, z, label in zip(positions, grasped, rest, labels))


def _one_location(pos: np.ndarray, grasped: bool, rest_z: float | None, label: str, obs: Mapping,
                  config: Mapping) -> int:
    top_z = float(_geometry_value(obs, "table_top_z", config))
    if rest_z is None:
        half = obs.get("object_half_size", config["object_half_size"])
        rest_z = top_z + float(np.asarray(half, dtype=float)[2])
    if pos[2] < top_z:
        raise AbstractionError(Fault.OBJECT_OFF_TABLE,
                               f"{label} centre at z={pos[2]:.3f} m is below the table top z={top_z:.3f} m")
    lifted = pos[2] > rest_z + config["lift_tolerance"]
    if lifted and grasped:
        return HELD
    if lifted:
        raise AbstractionError(Fault.OBJECT_LIFTED_NOT_GRASPED,
                               f"{label} centre is {pos[2] - rest_z:.3f} m above its resting height but not grasped")
    centers = _geometry_value(obs, "segment_centers", config)
    segment = segment_of_xy(pos, centers, _geometry_value(obs, "segment_half_sizes", config))
    if segment is not None:
        return segment
    table_center = _geometry_value(obs, "table_center", config)
    table_half = _geometry_value(obs, "table_half_size", config)
    if np.all(np.abs(pos[:2] - table_center[:2]) <= table_half):
        raise AbstractionError(Fault.OBJECT_BETWEEN_SEGMENTS, f"{label} at xy=({pos[0]:.3f}, {pos[1]:.3f}) lies on "
                               f"{'neither' if len(centers) == 2 else 'no'} segment")
    raise AbstractionError(Fault.OBJECT_OFF_TABLE, f"{label} at xy=({pos[0]:.3f}, {pos[1]:.3f}) is off the table")


def arm_segment(obs: Mapping, config: Mapping | None = None) -> int:
    """The 0-based segment the gripper is above (within ``arm_segment_margin``); raises ``ARM_NOT_OVER_SEGMENT``."""
    config = resolve_config(config)
    _require(obs, "eef_pos")
    eef = np.asarray(obs["eef_pos"], dtype=float)
    centers = _geometry_value(obs, "segment_centers", config)
    segment = segment_of_xy(eef, centers, _geometry_value(obs, "segment_half_sizes", config),
                            margin=config["arm_segment_margin"])
    if segment is None:
        raise AbstractionError(Fault.ARM_NOT_OVER_SEGMENT, f"gripper at xy=({eef[0]:.3f}, {eef[1]:.3f}) is above "
                               f"{'neither' if len(centers) == 2 else 'no'} segment")
    return segment


def sponge_at_home(obs: Mapping, config: Mapping | None = None) -> bool:
    """Whether the sponge is released and within ``sponge_home_tolerance`` of its home centre."""
    config = resolve_config(config)
    _require(obs, "sponge_pos")
    home = _geometry_value(obs, "sponge_home_pos", config)
    distance = float(np.linalg.norm(np.asarray(obs["sponge_pos"], dtype=float) - home))
    return distance <= config["sponge_home_tolerance"] and not bool(obs.get("sponge_grasped", False))


def abstract_state(obs: Mapping, config: Mapping | None = None, *, check_sponge: bool = True) -> TaskState:
    """The symbolic [`TaskState`][tableclean_suite.task.state.TaskState] of a physical observation (keys in the module docstring).

    Args:
        obs: observation mapping, e.g. ``env.skill_info()``.
        config: task config (full or partial overrides); ``None`` for the default.
        check_sponge: also require the sponge at home (``SPONGE_AWAY_FROM_HOME`` otherwise).  Pass
            ``False`` while a skill that carries the sponge (clean) is running.

    Raises:
        AbstractionError: for situations the task model has no state for (see [`Fault`][tableclean_suite.environments.abstraction.Fault]).
        KeyError: when a required observation key is missing.
    """
    config = resolve_config(config)
    _require(obs, "dirt_fraction")
    check_stability(obs, config)
    clean = segments_clean(obs["dirt_fraction"], config)
    locations = object_locations(obs, config)
    held = [j + 1 for j, where in enumerate(locations) if where == HELD]
    if len(held) > 1:
        raise AbstractionError(Fault.OBJECTS_HELD, f"objects {held} are grasped and lifted at once")
    segment = arm_segment(obs, config)
    if check_sponge and not sponge_at_home(obs, config):
        where = np.round(np.asarray(obs["sponge_pos"], dtype=float), 3).tolist()
        raise AbstractionError(Fault.SPONGE_AWAY_FROM_HOME, f"sponge at {where} is not at its home"
                               + (" (grasped)" if obs.get("sponge_grasped", False) else ""))
    return TaskState(tuple(bool(c) for c in clean), locations, segment)
