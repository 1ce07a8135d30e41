"""Where objects go on a segment: spots for a reset, and a free spot for a place (pure NumPy, world xy, metres).

The rule (used by the env's reset and by the place skill, so both agree):

- The ``c`` objects starting on one segment take the spots of :func:`slot_offsets`: a grid of
  ``ceil(sqrt(c))`` columns along x (one spot, the centre, for ``c = 1``), its pitch the larger
  of ``object_spacing`` and the two largest footprint diameters plus ``object_clearance``.
  Each object is then shifted by uniform noise of at most ``placement_noise`` per axis, capped
  so that two footprints stay ``object_clearance`` apart and every footprint stays inside the
  segment (:func:`noise_bound`).  No rejection sampling: a layout is never retried.
- A place puts the held object on the *free spot* of the arm's segment
  (:func:`free_spot`): the centre if its footprint keeps ``object_clearance`` from every object
  lying there; else, of the spots of a :data:`LATTICE_STEP` lattice over the segment whose
  footprint keeps that clearance and stays inside the segment, the one farthest from the other
  segments (``away_from``; ties: nearest the centre); if none fits, the spot farthest from the
  objects.  Away from the other segments, because the hand wiping a neighbouring segment reaches
  ~10 cm beyond the sponge along its long axis: an object standing near the shared edge would
  shrink that segment's wipe area (:mod:`tableclean_suite.controllers.wipe_pattern`) until its
  edge row of dirt stays.
- The grid of the reset lays its spots along x first (:func:`slot_offsets`), across the wiping
  hand's long axis at the skills' nominal yaw (world y), for the same reason.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

#: Spacing [m] of the lattice of spots :func:`free_spot` tries when the centre is taken.
LATTICE_STEP = 0.01
#: Distances [m] to the other segments closer than this count as equal in :func:`free_spot` (then: nearest the centre).
DISTANCE_RESOLUTION = 1e-6


def slot_offsets(count: int, pitch: float) -> np.ndarray:
    """(count, 2) offsets from the segment centre of a centred grid with ``ceil(sqrt(count))`` columns along x."""
    if count < 1:
        return np.zeros((0, 2))
    columns = math.ceil(math.sqrt(count))
    rows = math.ceil(count / columns)
    offsets = []
    for k in range(count):
        row, col = divmod(k, columns)
        offsets.append(((col - (columns - 1) / 2) * pitch, (row - (rows - 1) / 2) * pitch))
    return np.asarray(offsets, dtype=float)


def slot_pitch(radii: Sequence[float], spacing: float, clearance: float) -> float:
    """Grid pitch [m] for objects of footprint ``radii``: ``spacing``, or more so that two never touch."""
    largest = sorted(radii, reverse=True)[:2]
    return max(float(spacing), sum(largest) + float(clearance) if len(largest) == 2 else 0.0)


def noise_bound(offsets: np.ndarray, radii: Sequence[float], half_size, noise: float, pitch: float,
                clearance: float) -> np.ndarray:
    """Per-object bound (count,) [m] of the xy noise: ``noise`` capped by the room around each spot."""
    half = np.asarray(half_size, dtype=float)
    bounds = []
    largest = max(radii) if len(radii) else 0.0
    for offset, radius in zip(offsets, radii):
        room_edge = float(np.min(half - np.abs(offset) - radius))
        room_pair = (pitch - radius - largest - clearance) / 2 if len(radii) > 1 else math.inf
        bounds.append(max(0.0, min(float(noise), room_edge, room_pair)))
    return np.asarray(bounds)


def other_segments(centers, half_sizes, segment: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """``(center (2,), half_size (2,))`` [m] of every segment but ``segment`` (0-based), for :func:`free_spot`."""
    return [(np.asarray(centers[k], dtype=float)[:2], np.asarray(half_sizes[k], dtype=float))
            for k in range(len(centers)) if k != int(segment)]


def _distance_to_rectangles(points: np.ndarray, rectangles) -> np.ndarray:
    """(K,) distance [m] of each of ``points`` (K, 2) to the nearest of ``rectangles`` (inf without any)."""
    nearest = np.full(len(points), np.inf)
    for center, half in rectangles:
        outside = np.maximum(np.abs(points - np.asarray(center, dtype=float)[:2]) - np.asarray(half, dtype=float), 0.0)
        nearest = np.minimum(nearest, np.linalg.norm(outside, axis=1))
    return nearest


def free_spot(center, half_size, radius: float, others: Sequence[tuple[np.ndarray, float]], clearance: float,
              away_from: Sequence[tuple[np.ndarray, np.ndarray]] = ()) -> np.ndarray:
    """(2,) world xy where an object of footprint ``radius`` fits on a segment (see the module docstring).

    Args:
        center: segment centre (first two entries used).
        half_size: (2,) segment half extents.
        radius: footprint radius of the object to place.
        others: ``(xy, radius)`` of the objects lying on the segment.
        clearance: the config's ``object_clearance`` [m] kept between two footprints.
        away_from: ``(center, half_size)`` of the other segments (:func:`other_segments`); the spot
            keeps as far from them as it can when the centre is taken.
    """
    center = np.asarray(center, dtype=float)[:2]
    half = np.asarray(half_size, dtype=float)

    def gaps(offsets: np.ndarray) -> np.ndarray:
        xy = center + offsets
        gap = np.full(len(offsets), np.inf)
        for p, r in others:
            gap = np.minimum(gap, np.linalg.norm(xy - np.asarray(p, dtype=float)[:2], axis=1) - radius - r)
        return gap

    if gaps(np.zeros((1, 2)))[0] >= clearance:
        return center.copy()
    reach = np.maximum(half - radius, 0.0)
    gx = np.arange(-reach[0], reach[0] + 1e-9, LATTICE_STEP)
    gy = np.arange(-reach[1], reach[1] + 1e-9, LATTICE_STEP)
    lattice = np.stack(np.meshgrid(gx, gy, indexing="ij"), axis=-1).reshape(-1, 2)
    lattice = lattice[np.all(np.abs(lattice) + radius <= half + 1e-9, axis=1)]
    if len(lattice) == 0:
        return center.copy()
    gap = gaps(lattice)
    fits = gap >= clearance
    if not fits.any():
        return center + lattice[int(np.argmax(gap))]
    spots = lattice[fits]
    far = np.round(_distance_to_rectangles(center + spots, away_from) / DISTANCE_RESOLUTION)
    order = np.lexsort((np.linalg.norm(spots, axis=1), -far))
    return center + spots[order[0]]
