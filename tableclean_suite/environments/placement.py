"""Where objects go on a segment: spots for a reset, and a free spot for a place (pure NumPy, world xy, metres).

The rule (used by the env's reset and by the place skill, so both agree):

- The ``c`` objects starting on one segment take the spots of :func:`slot_offsets`: a grid of
  ``ceil(sqrt(c))`` columns along y (one spot, the centre, for ``c = 1``), its pitch the larger
  of ``object_spacing`` and the two largest footprint diameters plus ``object_clearance``.
  Each object is then shifted by uniform noise of at most ``placement_noise`` per axis, capped
  so that two footprints stay ``object_clearance`` apart and every footprint stays inside the
  segment (:func:`noise_bound`).  No rejection sampling: a layout is never retried.
- A place puts the held object on the *free spot* of the arm's segment
  (:func:`free_spot`): among the candidate spots (the centre first, then the grid spots of up
  to :data:`MAX_SPOTS` objects, then a :data:`LATTICE_STEP` lattice over the segment, nearest
  the centre first) the first whose footprint keeps ``object_clearance`` from every object
  lying there and stays inside the segment; if none does, the spot farthest from them.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

#: Largest number of objects whose grid spots are tried by :func:`free_spot`.
MAX_SPOTS = 4
#: Spacing [m] of the fallback lattice of spots :func:`free_spot` tries after the grid spots.
LATTICE_STEP = 0.01


def slot_offsets(count: int, pitch: float) -> np.ndarray:
    """(count, 2) offsets from the segment centre of a centred grid with ``ceil(sqrt(count))`` columns along y."""
    if count < 1:
        return np.zeros((0, 2))
    columns = math.ceil(math.sqrt(count))
    rows = math.ceil(count / columns)
    offsets = []
    for k in range(count):
        row, col = divmod(k, columns)
        offsets.append(((row - (rows - 1) / 2) * pitch, (col - (columns - 1) / 2) * pitch))
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


def free_spot(center, half_size, radius: float, others: Sequence[tuple[np.ndarray, float]], spacing: float,
              clearance: float) -> np.ndarray:
    """(2,) world xy where an object of footprint ``radius`` fits on a segment (see the module docstring).

    Args:
        center: segment centre (first two entries used).
        half_size: (2,) segment half extents.
        radius: footprint radius of the object to place.
        others: ``(xy, radius)`` of the objects lying on the segment.
        spacing, clearance: the config's ``object_spacing`` and ``object_clearance``.
    """
    center = np.asarray(center, dtype=float)[:2]
    half = np.asarray(half_size, dtype=float)
    radii = [radius] + [r for _, r in others]
    pitch = slot_pitch(radii, spacing, clearance)
    candidates = [np.zeros(2)]
    for count in range(2, MAX_SPOTS + 1):
        candidates.extend(slot_offsets(count, pitch))
    reach = np.maximum(half - radius, 0.0)
    gx = np.arange(-reach[0], reach[0] + 1e-9, LATTICE_STEP)
    gy = np.arange(-reach[1], reach[1] + 1e-9, LATTICE_STEP)
    lattice = np.stack(np.meshgrid(gx, gy, indexing="ij"), axis=-1).reshape(-1, 2)
    candidates.extend(lattice[np.argsort(np.linalg.norm(lattice, axis=1), kind="stable")])
    best, best_gap = center, -math.inf
    for offset in candidates:
        xy = center + offset
        if np.any(np.abs(offset) + radius > half + 1e-9):
            continue
        gap = min((float(np.linalg.norm(xy - np.asarray(p, dtype=float)[:2])) - radius - r for p, r in others),
                  default=math.inf)
        if gap >= clearance:
            return xy
        if gap > best_gap:
            best, best_gap = xy, gap
    return best
