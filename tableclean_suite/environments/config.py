"""Task parameters of the ``TableClean`` environment and the scene geometry derived from them.

All physical constants of the task live in `DEFAULT_TABLECLEAN_CONFIG` (one comment per key); users override
keys with ``robosuite.make("TableClean", ..., task_config={...})``, `make_config` merges and validates.
Metres, world frame; "table frame" offsets are from the centre of the table top.

Layout of N segments (`segment_layout`): rows of ``segment_columns`` segments along y, stacked along x
inside the band ``reach_x``, numbered along a U (first row -y to +y, the next back), so MOVE always goes
to a neighbouring segment.  One row keeps ``segment_size``; with more the side shrinks to fit the band, and
segments smaller than ``min_segment_size`` are refused: with the defaults at most `MAX_SCENE_SEGMENTS` = 4.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np

from tableclean_suite.environments.dirt_state import MAX_MARKERS_PER_SEGMENT
from tableclean_suite.task.paper import PAPER_SEGMENTS

#: Segments of the default scene (the paper's two); a task spec may ask for up to [`max_segments`][tableclean_suite.environments.config.max_segments].
SCENE_SEGMENTS = PAPER_SEGMENTS

DEFAULT_TABLECLEAN_CONFIG = {
    # --- table -------------------------------------------------------------------------------
    "table_full_size": (0.8, 0.8, 0.05),  # table extents (x, y, z) [m], as in robosuite's Lift
    "table_offset": (0.0, 0.0, 0.8),  # world position of the table-top centre [m]; z is the top height
    "table_friction": (1.0, 5e-3, 1e-4),  # MuJoCo (sliding, torsional, rolling) friction of the table
    # --- segments ----------------------------------------------------------------------------
    "segment_size": (0.24, 0.24),  # (x, y) extent of each segment's cleanable area [m]
    "segment_gap": 0.04,  # width along y of the divider strip between the two segments [m]
    "segment_x": 0.0,  # x of the segment rows' centre in the table frame [m] (one row: its x)
    "segment_columns": 2,  # segments per row (along y); further segments start a new row further along x
    # table-frame x band [m] in which the Panda presses the sponge onto the table with a downward gripper
    # (measured by IK: the grip site 2 cm above the table top is reachable for |x| <= 0.2 at |y| <= 0.2)
    "reach_x": (-0.2, 0.2),
    "min_segment_size": 0.15,  # smallest segment side [m]: two objects side by side plus a sponge lane
    # --- dirt --------------------------------------------------------------------------------
    "marker_grid": (5, 5),  # dirt markers per segment as (rows along x, columns along y); at most 52 in all
    "marker_radius": 0.011,  # radius of a (visual-only) dirt marker disc [m]
    "clean_fraction": 0.9,  # a segment counts clean once at least this fraction of its markers is wiped
    "wipe_contact_dist": 0.0,  # a sponge-table contact counts as pressing when its distance is <= this [m]
    "wipe_marker_reach": 0.005,  # a marker is under the pressing sponge when within this of the sponge box [m]
    # --- sponge ------------------------------------------------------------------------------
    "sponge_half_size": (0.04, 0.025, 0.015),  # sponge half extents (x, y, z) [m]
    "sponge_density": 200.0,  # sponge density [kg/m^3] (light, foam-like)
    "sponge_home_xy": (-0.1, 0.33),  # sponge home (centre of its stand) in the table frame [m]
    "stand_half_size": (0.06, 0.04, 0.01),  # half extents of the stand the sponge rests on at home [m]
    "sponge_home_tolerance": 0.03,  # the sponge counts as home within this distance of its home centre [m]
    # --- object ------------------------------------------------------------------------------
    # None: each object's type from the task spec (TaskSpec.objects); a registered name overrides every
    # object's type (see tableclean_suite.environments.objects.object_type_names())
    "object_type": None,
    "object_half_size": (0.0225, 0.0225, 0.0225),  # half extents of "cube"/"box" ("cylinder": r, r, h) [m]
    "placement_noise": 0.03,  # object xy placement noise, uniform in +-this around its segment centre [m]
    "placement_yaw_noise": 0.0,  # object yaw noise, uniform in +-this [rad]
    "object_spacing": 0.08,  # distance between the spots of objects sharing a segment (centre to centre) [m]
    "object_clearance": 0.01,  # least gap between two objects' footprints on a segment [m]
    # --- arm ---------------------------------------------------------------------------------
    "arm_hover_height": 0.15,  # gripper-site height above the table top at reset [m]
    "arm_segment_margin": 0.06,  # the arm is over a segment when its eef xy is within this of the segment [m]
    # --- abstraction thresholds -------------------------------------------------------------
    "lift_tolerance": 0.015,  # the object counts as lifted when its centre is this much above resting [m]
    "max_stable_speed": 20.0,  # any |qvel| above this [rad/s or m/s] counts as simulation instability
}

#: Most segments per row: a third column along y would reach the sponge stand's side of the table.
MAX_SEGMENT_COLUMNS = 2
#: Largest object yaw noise [rad]: +-pi already covers every orientation.
MAX_YAW_NOISE = float(np.pi)
#: Shape of each numeric key (that of its default): None for one number, k for a sequence of k numbers.
_SHAPES = {key: None if np.ndim(value) == 0 else len(value) for key, value in DEFAULT_TABLECLEAN_CONFIG.items()
           if key != "object_type"}
#: Keys whose values must be positive numbers or sequences of positive numbers.
_POSITIVE_KEYS = ("table_full_size", "segment_size", "marker_radius", "sponge_half_size", "sponge_density",
                  "stand_half_size", "sponge_home_tolerance", "object_half_size", "min_segment_size", "object_spacing",
                  "arm_hover_height", "lift_tolerance", "max_stable_speed")
#: Keys whose values must be non-negative.
_NON_NEGATIVE_KEYS = ("segment_gap", "wipe_marker_reach", "placement_noise", "placement_yaw_noise", "arm_segment_margin",
                      "object_clearance", "table_friction")
#: Further checks of a key's float array, with what the key allows.
_RULES = {
    "table_friction": (lambda a: a[0] > 0, "3 numbers >= 0 with the sliding friction (first) > 0"),
    "clean_fraction": (lambda a: 0.0 < a <= 1.0, "a number in (0, 1]"),
    "placement_yaw_noise": (lambda a: a <= MAX_YAW_NOISE, f"a number in [0, {MAX_YAW_NOISE:.4f}] rad"),
    "marker_grid": (lambda a: np.all(a == np.round(a)) and np.all(a >= 1), "2 integers >= 1 (rows, columns)"),
    "segment_columns": (lambda a: a == round(float(a)) and 1 <= a <= MAX_SEGMENT_COLUMNS,
                        f"an integer in 1..{MAX_SEGMENT_COLUMNS}"),
    "reach_x": (lambda a: a[0] < a[1], "2 numbers (low, high) with low < high"),
}


class TaskConfig(dict):
    """A complete, validated config (returned by [`make_config`][tableclean_suite.environments.config.make_config]); consumers skip re-validation."""


def make_config(task_config: Mapping | None = None) -> TaskConfig:
    """The default config updated with ``task_config``; raises ``ValueError`` on unknown keys or bad values.

    Every message names the key, the value given and what is allowed (e.g.
    ``task_config['marker_grid'] = 0: expected 2 integers >= 1``).
    """
    if isinstance(task_config, TaskConfig):
        return task_config
    if task_config is not None and not isinstance(task_config, Mapping):
        raise ValueError(f"task_config must be a dict of key -> value, got {type(task_config).__name__}")
    config = TaskConfig(DEFAULT_TABLECLEAN_CONFIG)
    if task_config:
        unknown = sorted(set(task_config) - set(DEFAULT_TABLECLEAN_CONFIG), key=str)
        if unknown:
            raise ValueError(f"unknown task_config key(s) {unknown}; allowed: {sorted(DEFAULT_TABLECLEAN_CONFIG)}")
        config.update(task_config)
    _validate(config)
    return config


def _refuse(key: str, value, allowed: str):
    raise ValueError(f"task_config[{key!r}] = {value!r}: expected {allowed}")


def _numbers(key: str, value, shape) -> np.ndarray:
    """``value`` as float64 of ``shape`` (None: a scalar), all finite; ``ValueError`` naming key, value and shape."""
    allowed = _RULES[key][1] if key in _RULES and key != "table_friction" else (
        "a number" if shape is None else f"{shape} numbers")
    sequence = isinstance(value, (list, tuple, np.ndarray))
    if isinstance(value, (str, bytes, Mapping)) or sequence == (shape is None) or any(
            isinstance(item, (bool, np.bool_, str, bytes)) or item is None
            for item in np.ravel(np.asarray([value] if shape is None else value, dtype=object))):
        _refuse(key, value, allowed)
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        _refuse(key, value, allowed)
    if array.shape != (() if shape is None else (shape,)):
        _refuse(key, value, allowed)
    if not np.all(np.isfinite(array)):
        _refuse(key, value, allowed + ", all finite")
    return array


def _validate(config: dict) -> None:
    arrays = {key: _numbers(key, config[key], shape) for key, shape in _SHAPES.items()}
    for key in _POSITIVE_KEYS:
        if not np.all(arrays[key] > 0):
            shape = _SHAPES[key]
            _refuse(key, config[key], "a positive number" if shape is None else f"{shape} positive numbers")
    for key in _NON_NEGATIVE_KEYS:
        if not np.all(arrays[key] >= 0):
            _refuse(key, config[key], ("a number" if _SHAPES[key] is None else f"{_SHAPES[key]} numbers") + " >= 0")
    for key, (check, allowed) in _RULES.items():
        if not check(arrays[key]):
            _refuse(key, config[key], allowed)
    rows, cols = (int(n) for n in arrays["marker_grid"])
    if rows * cols > MAX_MARKERS_PER_SEGMENT:
        raise ValueError(f"task_config['marker_grid'] = {config['marker_grid']!r}: {rows * cols} markers per segment; "
                         f"at most {MAX_MARKERS_PER_SEGMENT} fit in a segment's dirt-state joint")
    if config["object_type"] is not None:
        from tableclean_suite.environments.objects import get_object_type

        if not isinstance(config["object_type"], str):
            _refuse("object_type", config["object_type"], "None or a registered object type name")
        get_object_type(config["object_type"])
    if float(arrays["segment_gap"]) / 2 + arrays["segment_size"][1] > arrays["table_full_size"][1] / 2:
        raise ValueError(f"segments (gap {config['segment_gap']} + 2 x {config['segment_size'][1]} m along y) "
                         f"do not fit on a table {config['table_full_size'][1]} m wide")


class LayoutError(ValueError):
    """The scene cannot lay out the requested number of segments (the message names the limit)."""


def segment_layout(config: Mapping, n_segments: int) -> tuple[np.ndarray, float]:
    """Table-frame centres ``(N, 2)`` and the side [m] of N square-ish segments (see the module docstring).

    Raises [`LayoutError`][tableclean_suite.environments.config.LayoutError] naming [`max_segments`][tableclean_suite.environments.config.max_segments] when N segments do not fit.
    """
    if isinstance(n_segments, bool) or not isinstance(n_segments, (int, np.integer)) or n_segments < 2:
        raise LayoutError(f"the scene needs an integer number of segments >= 2, got {n_segments!r}")
    columns = int(config["segment_columns"])
    rows = -(-int(n_segments) // columns)
    gap = float(config["segment_gap"])
    size = np.asarray(config["segment_size"], dtype=float)
    low, high = (float(v) for v in config["reach_x"])
    fit = (high - low - (rows - 1) * gap) / rows  # the side that R rows leave inside the reach band
    side = min(float(size.min()), fit) if rows > 1 else None
    limit = max_segments(config)
    if n_segments > limit:
        raise LayoutError(
            f"the TableClean scene lays out at most {limit} segments, got {n_segments}: rows of "
            f"{columns} segments must fit in the Panda's reach band x in [{low}, {high}] m of the table centre "
            f"with sides >= min_segment_size {config['min_segment_size']} m (a row more leaves {fit:.3f} m)")
    half = size / 2 if side is None else np.array([side / 2, side / 2])
    centers = np.zeros((int(n_segments), 2))
    row_x = config["segment_x"] + (np.arange(rows) - (rows - 1) / 2) * (2 * half[0] + gap)
    col_y = (np.arange(columns) - (columns - 1) / 2) * (2 * half[1] + gap)
    for k in range(int(n_segments)):
        row, col = divmod(k, columns)
        if row % 2:  # U-shaped numbering: odd rows run back along -y
            col = columns - 1 - col
        centers[k] = (row_x[row], col_y[col])
    return centers, half


def max_segments(config: Mapping) -> int:
    """The largest N [`segment_layout`][tableclean_suite.environments.config.segment_layout] accepts with ``config`` (4 with the defaults)."""
    columns = int(config["segment_columns"])
    gap = float(config["segment_gap"])
    low, high = (float(v) for v in config["reach_x"])
    rows = int(np.floor((high - low + gap) / (float(config["min_segment_size"]) + gap) + 1e-9))
    return max(rows, 1) * columns


@dataclass(frozen=True)
class SceneGeometry:
    """World-frame geometry derived from a config (all arrays float, metres)."""

    table_top_z: float  #: height of the table top
    table_center: np.ndarray  #: (3,) centre of the table top
    table_half_size: np.ndarray  #: (2,) half extents (x, y) of the table top
    segment_centers: np.ndarray  #: (N, 3) table-top point at each segment centre (row 0 = segment 1)
    segment_half_sizes: np.ndarray  #: (N, 2) half extents (x, y) of each segment's cleanable area
    sponge_home_pos: np.ndarray  #: (3,) centre of the sponge when it rests on its stand
    stand_center: np.ndarray  #: (3,) centre of the stand box
    stand_half_size: np.ndarray  #: (3,) half extents of the stand box


def scene_geometry(config: Mapping, n_segments: int = SCENE_SEGMENTS) -> SceneGeometry:
    """The world-frame [`SceneGeometry`][tableclean_suite.environments.config.SceneGeometry] of a (merged) config with ``n_segments`` segments."""
    center = np.asarray(config["table_offset"], dtype=float)
    table_xy, half_size = segment_layout(config, n_segments)
    segment_centers = np.zeros((int(n_segments), 3))
    segment_centers[:, :2] = center[:2] + table_xy
    segment_centers[:, 2] = center[2]
    stand_half = np.asarray(config["stand_half_size"], dtype=float)
    home_xy = center[:2] + np.asarray(config["sponge_home_xy"], dtype=float)
    stand_center = np.array([home_xy[0], home_xy[1], center[2] + stand_half[2]])
    sponge_home = stand_center + np.array([0.0, 0.0, stand_half[2] + config["sponge_half_size"][2]])
    return SceneGeometry(table_top_z=float(center[2]), table_center=center,
                         table_half_size=np.asarray(config["table_full_size"][:2], dtype=float) / 2,
                         segment_centers=segment_centers, segment_half_sizes=np.tile(half_size, (int(n_segments), 1)),
                         sponge_home_pos=sponge_home, stand_center=stand_center, stand_half_size=stand_half)


def marker_positions(config: Mapping, n_segments: int = SCENE_SEGMENTS) -> np.ndarray:
    """World xy of every dirt marker, shape ``(N, rows * cols, 2)``: segment, marker, (x, y).

    Markers sit at the centres of a regular ``marker_grid`` of cells covering each segment.
    """
    geometry = scene_geometry(config, n_segments)
    rows, cols = (int(n) for n in config["marker_grid"])
    size = 2 * geometry.segment_half_sizes[0]
    fx = (np.arange(rows) + 0.5) / rows - 0.5
    fy = (np.arange(cols) + 0.5) / cols - 0.5
    gx, gy = np.meshgrid(fx * size[0], fy * size[1], indexing="ij")
    offsets = np.stack([gx.ravel(), gy.ravel()], axis=-1)
    return np.stack([geometry.segment_centers[s, :2] + offsets for s in range(n_segments)])


#: The largest number of segments the default config lays out (see the module docstring).
MAX_SCENE_SEGMENTS = max_segments(DEFAULT_TABLECLEAN_CONFIG)


def jsonable(value):
    """``value`` with tuples, NumPy arrays and scalars and paths turned into JSON types (lists, Python scalars,
    strings), recursively through dicts (keys as strings) and sequences."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return value
