"""Task parameters of the ``TableClean`` environment and the scene geometry derived from them.

All physical constants of the task live in :data:`DEFAULT_TABLECLEAN_CONFIG` (robosuite Wipe's
``DEFAULT_WIPE_CONFIG`` pattern, one comment per key).  Users override keys with
``robosuite.make("TableClean", ..., task_config={...})``; :func:`make_config` merges and validates.

Frames and units: metres, world frame.  "Table frame" offsets are relative to the centre of the
table top.  Segment 1 lies at negative y (left in the ``frontview`` camera), segment 2 at positive y.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from tableclean_suite.environments.dirt_state import MAX_MARKERS_PER_SEGMENT
from tableclean_suite.task.paper import PAPER_SEGMENTS

#: Segments the scene lays out (the paper's two; the task spec may not ask for more yet).
SCENE_SEGMENTS = PAPER_SEGMENTS

DEFAULT_TABLECLEAN_CONFIG = {
    # --- table -------------------------------------------------------------------------------
    "table_full_size": (0.8, 0.8, 0.05),  # table extents (x, y, z) [m], as in robosuite's Lift
    "table_offset": (0.0, 0.0, 0.8),  # world position of the table-top centre [m]; z is the top height
    "table_friction": (1.0, 5e-3, 1e-4),  # MuJoCo (sliding, torsional, rolling) friction of the table
    # --- segments ----------------------------------------------------------------------------
    "segment_size": (0.24, 0.24),  # (x, y) extent of each segment's cleanable area [m]
    "segment_gap": 0.04,  # width along y of the divider strip between the two segments [m]
    "segment_x": 0.0,  # x of both segment centres in the table frame [m]
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
    "object_type": "cube",  # graspable object: one of tableclean_suite.environments.objects.OBJECT_TYPES
    "object_half_size": (0.0225, 0.0225, 0.0225),  # half extents of "cube"/"box" ("cylinder": r, r, h) [m]
    "placement_noise": 0.03,  # object xy placement noise, uniform in +-this around its segment centre [m]
    "placement_yaw_noise": 0.0,  # object yaw noise, uniform in +-this [rad]
    # --- arm ---------------------------------------------------------------------------------
    "arm_hover_height": 0.15,  # gripper-site height above the table top at reset [m]
    "arm_segment_margin": 0.06,  # the arm is over a segment when its eef xy is within this of the segment [m]
    # --- abstraction thresholds -------------------------------------------------------------
    "lift_tolerance": 0.015,  # the object counts as lifted when its centre is this much above resting [m]
    "max_stable_speed": 20.0,  # any |qvel| above this [rad/s or m/s] counts as simulation instability
}

#: Keys whose values must be positive numbers or sequences of positive numbers.
_POSITIVE_KEYS = (
    "table_full_size",
    "segment_size",
    "marker_radius",
    "sponge_half_size",
    "sponge_density",
    "stand_half_size",
    "sponge_home_tolerance",
    "object_half_size",
    "arm_hover_height",
    "lift_tolerance",
    "max_stable_speed",
)
#: Keys whose values must be non-negative.
_NON_NEGATIVE_KEYS = ("segment_gap", "wipe_marker_reach", "placement_noise", "placement_yaw_noise", "arm_segment_margin")


class TaskConfig(dict):
    """A complete, validated config (returned by :func:`make_config`); consumers skip re-validation."""


def make_config(task_config: Mapping | None = None) -> TaskConfig:
    """The default config updated with ``task_config``; raises ``ValueError`` on unknown keys or bad values."""
    if isinstance(task_config, TaskConfig):
        return task_config
    config = TaskConfig(DEFAULT_TABLECLEAN_CONFIG)
    if task_config:
        unknown = sorted(set(task_config) - set(DEFAULT_TABLECLEAN_CONFIG))
        if unknown:
            raise ValueError(
                f"unknown task_config key(s) {unknown}; allowed: {sorted(DEFAULT_TABLECLEAN_CONFIG)}"
            )
        config.update(task_config)
    _validate(config)
    return config


def _validate(config: dict) -> None:
    for key in _POSITIVE_KEYS:
        values = np.atleast_1d(np.asarray(config[key], dtype=float))
        if not np.all(values > 0):
            raise ValueError(f"task_config[{key!r}] must be positive, got {config[key]!r}")
    for key in _NON_NEGATIVE_KEYS:
        if not float(config[key]) >= 0:
            raise ValueError(f"task_config[{key!r}] must be >= 0, got {config[key]!r}")
    if not 0.0 < float(config["clean_fraction"]) <= 1.0:
        raise ValueError(f"task_config['clean_fraction'] must be in (0, 1], got {config['clean_fraction']!r}")
    grid = config["marker_grid"]
    if len(grid) != 2 or any(isinstance(n, bool) or int(n) != n or n < 1 for n in grid):
        raise ValueError(f"task_config['marker_grid'] must be two integers >= 1, got {grid!r}")
    if int(grid[0]) * int(grid[1]) > MAX_MARKERS_PER_SEGMENT:
        raise ValueError(f"task_config['marker_grid'] {grid!r} has {int(grid[0]) * int(grid[1])} markers per segment; "
                         f"at most {MAX_MARKERS_PER_SEGMENT} fit in a segment's dirt-state joint")
    half_y = config["table_full_size"][1] / 2
    reach_y = config["segment_gap"] / 2 + config["segment_size"][1]
    if reach_y > half_y:
        raise ValueError(
            f"segments (gap {config['segment_gap']} + 2 x {config['segment_size'][1]} m along y) "
            f"do not fit on a table {config['table_full_size'][1]} m wide"
        )


@dataclass(frozen=True)
class SceneGeometry:
    """World-frame geometry derived from a config (all arrays float, metres).

    Attributes:
        table_top_z: height of the table top.
        table_center: (3,) centre of the table top.
        table_half_size: (2,) half extents (x, y) of the table top.
        segment_centers: (2, 3) table-top point at each segment centre (row 0 = segment 1).
        segment_half_sizes: (2, 2) half extents (x, y) of each segment's cleanable area.
        sponge_home_pos: (3,) centre of the sponge when it rests on its stand.
        stand_center: (3,) centre of the stand box.
        stand_half_size: (3,) half extents of the stand box.
    """

    table_top_z: float
    table_center: np.ndarray
    table_half_size: np.ndarray
    segment_centers: np.ndarray
    segment_half_sizes: np.ndarray
    sponge_home_pos: np.ndarray
    stand_center: np.ndarray
    stand_half_size: np.ndarray


def scene_geometry(config: Mapping) -> SceneGeometry:
    """The world-frame :class:`SceneGeometry` of a (merged) config."""
    center = np.asarray(config["table_offset"], dtype=float)
    half_size = np.asarray(config["segment_size"], dtype=float) / 2
    offset_y = config["segment_gap"] / 2 + half_size[1]
    side = np.array([-1.0, 1.0])  # segment 1 at -y, segment 2 at +y
    segment_centers = np.zeros((SCENE_SEGMENTS, 3))
    segment_centers[:, 0] = center[0] + config["segment_x"]
    segment_centers[:, 1] = center[1] + side * offset_y
    segment_centers[:, 2] = center[2]
    stand_half = np.asarray(config["stand_half_size"], dtype=float)
    home_xy = center[:2] + np.asarray(config["sponge_home_xy"], dtype=float)
    stand_center = np.array([home_xy[0], home_xy[1], center[2] + stand_half[2]])
    sponge_home = stand_center + np.array([0.0, 0.0, stand_half[2] + config["sponge_half_size"][2]])
    return SceneGeometry(
        table_top_z=float(center[2]),
        table_center=center,
        table_half_size=np.asarray(config["table_full_size"][:2], dtype=float) / 2,
        segment_centers=segment_centers,
        segment_half_sizes=np.tile(half_size, (SCENE_SEGMENTS, 1)),
        sponge_home_pos=sponge_home,
        stand_center=stand_center,
        stand_half_size=stand_half,
    )


def marker_positions(config: Mapping) -> np.ndarray:
    """World xy of every dirt marker, shape ``(2, rows * cols, 2)``: segment, marker, (x, y).

    Markers sit at the centres of a regular ``marker_grid`` of cells covering each segment.
    """
    geometry = scene_geometry(config)
    rows, cols = (int(n) for n in config["marker_grid"])
    size = np.asarray(config["segment_size"], dtype=float)
    fx = (np.arange(rows) + 0.5) / rows - 0.5
    fy = (np.arange(cols) + 0.5) / cols - 0.5
    gx, gy = np.meshgrid(fx * size[0], fy * size[1], indexing="ij")
    offsets = np.stack([gx.ravel(), gy.ravel()], axis=-1)
    return np.stack([geometry.segment_centers[s, :2] + offsets for s in range(SCENE_SEGMENTS)])
