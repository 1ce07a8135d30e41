"""Boustrophedon wipe patterns that cover a rectangular table segment with a sponge."""

from __future__ import annotations

import math

import numpy as np


def boustrophedon(
    center: np.ndarray,
    half_size: np.ndarray,
    footprint: np.ndarray,
    overlap: float,
    along_x: bool,
    lane_shift: float = 0.0,
    edge_inset: float = 1.0,
) -> np.ndarray:
    """Sponge-centre waypoints (n, 2) in world xy that sweep a rectangle lane by lane.

    The sponge centre stays ``edge_inset * footprint`` inside the rectangle's
    edges (1: the sponge's edge just reaches the rectangle's; less: it overhangs,
    which makes up for tracking lag); neighbouring lanes overlap by the fraction
    ``overlap`` of the sponge's width across the strokes.

    Args:
        center: (2,) or (3,) centre of the rectangle (only x, y are used), m.
        half_size: (2,) half extents (x, y) of the rectangle, m.
        footprint: (2,) half extents (x, y) of the sponge's contact patch in world axes, m (> 0).
        overlap: fraction in [0, 1) of the sponge width shared by neighbouring lanes.
        along_x: strokes run along world x (lanes stacked in y) if True, else along y.
        lane_shift: lanes shifted by this fraction of the lane spacing (kept inside the
            rectangle), so a repeated pass sweeps between the previous lanes.
        edge_inset: fraction in [0, 1] of the footprint the sponge centre keeps inside the edges.
    """
    footprint = np.asarray(footprint, dtype=float)
    if footprint.shape != (2,) or np.any(footprint <= 0):
        raise ValueError(f"footprint must be two positive half extents, got {footprint}")
    if not 0.0 <= overlap < 1.0:
        raise ValueError(f"overlap must be in [0, 1), got {overlap}")
    stroke_axis, lane_axis = (0, 1) if along_x else (1, 0)
    if not 0.0 <= edge_inset <= 1.0:
        raise ValueError(f"edge_inset must be in [0, 1], got {edge_inset}")
    reach = np.maximum(np.asarray(half_size, dtype=float) - edge_inset * footprint, 0.0)
    spacing = 2.0 * footprint[lane_axis] * (1.0 - overlap)
    n_lanes = max(1, math.ceil(2.0 * reach[lane_axis] / spacing) + 1) if reach[lane_axis] > 0 else 1
    lanes = np.linspace(-reach[lane_axis], reach[lane_axis], n_lanes)
    if n_lanes > 1:
        lanes = np.clip(lanes + lane_shift * (lanes[1] - lanes[0]), -reach[lane_axis], reach[lane_axis])
    points = []
    for k, lane in enumerate(lanes):
        ends = (-reach[stroke_axis], reach[stroke_axis]) if k % 2 == 0 else (reach[stroke_axis], -reach[stroke_axis])
        for end in ends:
            point = np.zeros(2)
            point[stroke_axis] = end
            point[lane_axis] = lane
            points.append(point)
    return np.asarray(center, dtype=float)[:2] + np.array(points)
