"""Boustrophedon wipe patterns that cover a rectangular table segment with a sponge, clear of obstacles.

[`boustrophedon`][tableclean_suite.controllers.wipe_pattern.boustrophedon] sweeps a rectangle lane by lane; [`clear_area`][tableclean_suite.controllers.wipe_pattern.clear_area] first shrinks that
rectangle so that the hand, wherever the sponge is inside it, keeps a margin from every obstacle
(the objects standing on the neighbouring segments whose tops reach the hand).  The shrunk area is
one rectangle, so every stroke, every shift between strokes and every move between two passes
(straight lines between its points) stays clear as well.
"""

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
    direction: int = 0,
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
        direction: 0: strokes alternate (lane by lane, back and forth); +1 or -1: every stroke runs toward
            the + or - end of the stroke axis (each lane starts at the same end).
    """
    footprint = np.asarray(footprint, dtype=float)
    if footprint.shape != (2,) or np.any(footprint <= 0):
        raise ValueError(f"footprint must be two positive half extents, got {footprint}")
    if not 0.0 <= overlap < 1.0:
        raise ValueError(f"overlap must be in [0, 1), got {overlap}")
    stroke_axis, lane_axis = (0, 1) if along_x else (1, 0)
    if not 0.0 <= edge_inset <= 1.0:
        raise ValueError(f"edge_inset must be in [0, 1], got {edge_inset}")
    if direction not in (-1, 0, 1):
        raise ValueError(f"direction must be -1, 0 or 1, got {direction!r}")
    reach = np.maximum(np.asarray(half_size, dtype=float) - edge_inset * footprint, 0.0)
    spacing = 2.0 * footprint[lane_axis] * (1.0 - overlap)
    n_lanes = max(1, math.ceil(2.0 * reach[lane_axis] / spacing) + 1) if reach[lane_axis] > 0 else 1
    lanes = np.linspace(-reach[lane_axis], reach[lane_axis], n_lanes)
    if n_lanes > 1:
        lanes = np.clip(lanes + lane_shift * (lanes[1] - lanes[0]), -reach[lane_axis], reach[lane_axis])
    points = []
    for k, lane in enumerate(lanes):
        forward = k % 2 == 0 if direction == 0 else direction > 0
        ends = (-reach[stroke_axis], reach[stroke_axis]) if forward else (reach[stroke_axis], -reach[stroke_axis])
        for end in ends:
            point = np.zeros(2)
            point[stroke_axis] = end
            point[lane_axis] = lane
            points.append(point)
    return np.asarray(center, dtype=float)[:2] + np.array(points)


def clear_area(
    center: np.ndarray,
    half_size: np.ndarray,
    hand_offset: np.ndarray,
    hand_half: np.ndarray,
    obstacles: np.ndarray,
    margin: float,
) -> tuple[np.ndarray, np.ndarray]:
    """``(center, half_size)`` (2,), (2,) [m] of the largest-kept part of a rectangle clear of ``obstacles``.

    The hand is the box of half extents ``hand_half`` about the sponge centre plus ``hand_offset``;
    with the sponge centre anywhere in the returned rectangle, that box stays ``margin`` away from
    every obstacle box.  Each obstacle that the hand could reach is cut off by moving one side of the
    rectangle: of the four sides, the one that keeps the most area.  Obstacles the hand cannot reach
    from anywhere in the rectangle leave it as it is.  An obstacle inside the rectangle (no side
    clears it) collapses the rectangle to zero size on the cheapest side.

    Args:
        center: (2,) or (3,) centre of the rectangle of sponge-centre positions (x, y used), m.
        half_size: (2,) its half extents, m (>= 0).
        hand_offset: (2,) world xy of the hand box's centre minus the sponge centre, m.
        hand_half: (2,) half extents (x, y) of the hand box in world axes, m (>= 0).
        obstacles: (K, 4) world boxes ``[x_min, y_min, x_max, y_max]``, m (K may be 0).
        margin: m (>= 0) kept between the hand box and every obstacle box.
    """
    center = np.asarray(center, dtype=float)[:2]
    half = np.asarray(half_size, dtype=float)
    offset = np.asarray(hand_offset, dtype=float)
    hand = np.asarray(hand_half, dtype=float)
    boxes = np.asarray(obstacles, dtype=float).reshape(-1, 4)
    if half.shape != (2,) or np.any(half < 0) or hand.shape != (2,) or np.any(hand < 0):
        raise ValueError(f"half_size and hand_half must be two half extents >= 0, got {half} and {hand}")
    if margin < 0:
        raise ValueError(f"margin must be >= 0 m, got {margin}")
    low, high = center - half, center + half
    for box in boxes:
        # the obstacle grown by the hand box and the margin, in sponge-centre coordinates
        grown_low = box[:2] - hand - margin - offset
        grown_high = box[2:] + hand + margin - offset
        if np.any(grown_low >= high) or np.any(grown_high <= low):
            continue  # out of the hand's reach from anywhere in the rectangle
        best = None
        for axis in (0, 1):
            other = 1 - axis
            span = high[other] - low[other]
            for new_low, new_high in ((low[axis], min(high[axis], grown_low[axis])),
                                      (max(low[axis], grown_high[axis]), high[axis])):
                kept = max(new_high - new_low, 0.0) * span
                if best is None or kept > best[0]:
                    best = (kept, axis, new_low, new_high)
        _, axis, new_low, new_high = best
        if new_high < new_low:  # the obstacle inside: nothing clear on this axis
            new_low = new_high = float(np.clip(0.5 * (new_low + new_high), low[axis], high[axis]))
        low[axis], high[axis] = new_low, new_high
    return 0.5 * (low + high), 0.5 * (high - low)
