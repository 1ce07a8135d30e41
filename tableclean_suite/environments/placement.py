"""Where objects go on a segment: spots for a reset, and a free spot for a place (pure NumPy, world xy, metres).

Objects are placed by their *oriented footprints*: the outline of their collision geometry seen
from above, in their own frame ([`outline_of`][tableclean_suite.environments.placement.outline_of]; a disc for a ``footprint_radius`` override),
turned by their yaw.  Nothing here knows an object type.

- The ``c`` objects starting on one segment form a grid ([`row_layout`][tableclean_suite.environments.placement.row_layout]): ``ceil(sqrt(c))``
  columns along x (one spot, the centre, for ``c = 1``), rows along y.  Neighbouring columns
  (rows) lie ``object_spacing`` apart centre to centre, or farther, so that their footprints keep
  ``object_clearance``; the grid's footprints are centred on the segment.  Each object keeps its
  own yaw (0) unless the grid is then wider than the segment: then objects are turned, the one
  that gains most first, until their narrowest width lies along the row (x) and the grid fits.
  The yaw noise (``placement_yaw_noise``) enters every extent (the footprint over every yaw the
  noise can draw) and is capped (the largest that still fits, found by bisection) when the full
  noise does not fit; the xy noise is capped per object so that footprints stay
  ``object_clearance`` apart and inside the segment (`RowLayout.xy_noise`).  No rejection
  sampling: a layout is never retried.  What does not fit even turned and without yaw noise is
  refused ([`DoesNotFit`][tableclean_suite.environments.placement.DoesNotFit], naming the grid's size and the segment's).
- A place puts the held object on the *free spot* of the arm's segment ([`free_spot`][tableclean_suite.environments.placement.free_spot]):
  the centre if its footprint keeps ``object_clearance`` from every object lying there; else, of
  the spots of a `LATTICE_STEP` lattice over the segment whose footprint keeps that
  clearance and stays inside the segment, the one farthest from the other segments
  (``away_from``; ties: nearest the centre); if none fits, the spot farthest from the objects (of the
  lattice and the spots at the segment's extremes).

Both keep objects out of the wiping hand's way on the neighbouring segments: the free spot away from them, the
reset's grid laid along x first (why: the objects-and-skills docs page).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from tableclean_suite.environments.object_geometry import WIDTH_DIRECTIONS, hull_corners, widths_of

#: Spacing [m] of the lattice of spots [`free_spot`][tableclean_suite.environments.placement.free_spot] tries when the centre is taken.
LATTICE_STEP = 0.01
#: Distances [m] to the other segments closer than this count as equal in [`free_spot`][tableclean_suite.environments.placement.free_spot] (then: nearest the centre).
DISTANCE_RESOLUTION = 1e-6
#: Directions over a full turn along which [`free_spot`][tableclean_suite.environments.placement.free_spot] measures the gap between two footprints (the
#: largest separation along any of them); it falls short of the true gap by at most a footprint's size
#: times sin(pi / this): ~1 mm for a 10 cm footprint, on the safe side.
GAP_DIRECTIONS = 360
#: Points of the polygon standing for a disc footprint (circumscribed: it covers the disc).
DISC_POINTS = 32
#: Bisection steps finding the largest yaw noise that still fits ([`row_layout`][tableclean_suite.environments.placement.row_layout]): the cap is
#: within ``placement_yaw_noise / 2**this`` of the largest that fits.
YAW_CAP_STEPS = 12
#: Slack [m] in the fit tests (floating-point sums of extents).
FIT_TOLERANCE = 1e-9


class DoesNotFit(ValueError):
    """Objects whose footprints do not fit side by side on a segment, even turned and without yaw noise.

    Attributes:
        size: (2,) x, y extent [m] their grid needs (turned where that helps).
    """

    def __init__(self, message: str, size):
        super().__init__(message)
        self.size = np.asarray(size, dtype=float)


def disc_outline(radius: float) -> np.ndarray:
    """(DISC_POINTS, 2) polygon [m] covering the disc of ``radius`` about the origin."""
    angles = np.linspace(0.0, 2.0 * np.pi, DISC_POINTS, endpoint=False)
    r = float(radius) / math.cos(math.pi / DISC_POINTS)
    return np.column_stack([r * np.cos(angles), r * np.sin(angles)])


def outline_of(points) -> np.ndarray:
    """(K, 2) corners [m] of the convex outline of ``points`` (N, 2 or 3; x, y used), seen from above."""
    return hull_corners(np.asarray(points, dtype=float)[:, :2])


def turned(outline, yaw: float) -> np.ndarray:
    """(K, 2) ``outline`` (K, 2) turned by ``yaw`` [rad] about the origin."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.asarray(outline, dtype=float) @ np.array([[c, s], [-s, c]])


def _max_cos(start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Largest cos over each angle interval ``[start, end]`` [rad] (elementwise, ``end >= start``)."""
    peak = np.ceil(start / (2 * np.pi)) * (2 * np.pi) <= end
    return np.where(peak, 1.0, np.maximum(np.cos(start), np.cos(end)))


def extent(outline, yaw: float = 0.0, yaw_noise: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """``(lower (2,), upper (2,))`` [m]: the smallest and largest world x, y of ``outline`` (K, 2, own frame)
    about the object's origin when it is turned by any yaw in ``[yaw - yaw_noise, yaw + yaw_noise]`` (exact)."""
    pts = np.asarray(outline, dtype=float)
    if yaw_noise == 0.0:  # the turned points themselves (exact at yaw 0: a symmetric outline stays centred)
        pts = turned(pts, yaw)
        return pts.min(axis=0), pts.max(axis=0)
    rho = np.hypot(pts[:, 0], pts[:, 1])
    phi = np.arctan2(pts[:, 1], pts[:, 0]) + float(yaw)
    noise = abs(float(yaw_noise))
    bounds = []
    for axis in (0.0, 0.5 * np.pi, np.pi, 1.5 * np.pi):  # +x, +y, -x, -y
        bounds.append(float(np.max(rho * _max_cos(phi - axis - noise, phi - axis + noise))))
    return np.array([-bounds[2], -bounds[3]]), np.array([bounds[0], bounds[1]])


def narrow_yaw(outline) -> float:
    """Yaw [rad] (in ``(-pi/2, pi/2]``) that lays ``outline``'s narrowest width along world x."""
    direction = int(np.argmin(widths_of(outline))) * (np.pi / WIDTH_DIRECTIONS)
    return -direction if direction <= 0.5 * np.pi else np.pi - direction


@dataclass(frozen=True)
class RowLayout:
    """Where the objects starting on one segment go ([`row_layout`][tableclean_suite.environments.placement.row_layout]).

    Attributes:
        yaws: (c,) each object's yaw [rad] before the noise.
        offsets: (c, 2) each object's spot (its origin) from the segment centre [m].
        xy_noise: (c,) each object's cap [m] of the xy noise, per axis.
        yaw_noise: the cap [rad] of the yaw noise, every object.
        size: (2,) x, y extent [m] of the grid's footprints at the capped yaw noise.
    """

    yaws: np.ndarray
    offsets: np.ndarray
    xy_noise: np.ndarray
    yaw_noise: float
    size: np.ndarray


def _axis_positions(cells, lowers, uppers, spacing: float, clearance: float):
    """Centres of the cells along one axis (cell k's objects: ``lowers``/``uppers`` of that axis) and the
    span (lowest, highest) of their footprints, the first cell's centre at 0."""
    n = max(cells) + 1
    low = [min(lowers[i] for i in range(len(cells)) if cells[i] == k) for k in range(n)]
    high = [max(uppers[i] for i in range(len(cells)) if cells[i] == k) for k in range(n)]
    centres = [0.0]
    for k in range(1, n):
        centres.append(centres[-1] + max(float(spacing), high[k - 1] + float(clearance) - low[k]))
    return np.asarray(centres), np.asarray(low), np.asarray(high)


def _grid(outlines, yaws, yaw_noise, spacing, clearance, noise, half):
    """The grid of [`row_layout`][tableclean_suite.environments.placement.row_layout] for given yaws: (offsets (c, 2), xy noise caps (c,), size (2,))."""
    count = len(outlines)
    columns = math.ceil(math.sqrt(count))
    cells = [divmod(k, columns) for k in range(count)]  # (row, column)
    extents = [extent(o, y, yaw_noise) for o, y in zip(outlines, yaws)]
    offsets = np.zeros((count, 2))
    size = np.zeros(2)
    room = np.full(count, float(noise))
    for axis, index in ((0, 1), (1, 0)):  # x: columns, y: rows
        cell = [c[index] for c in cells]
        lowers = [e[0][axis] for e in extents]
        uppers = [e[1][axis] for e in extents]
        centres, low, high = _axis_positions(cell, lowers, uppers, spacing, clearance)
        span = (centres + low).min(), (centres + high).max()
        size[axis] = span[1] - span[0]
        centres = centres - 0.5 * (span[0] + span[1])
        # room to the neighbouring cells (each side moves at most half the gap beyond the clearance)
        gaps = (centres[1:] + low[1:]) - (centres[:-1] + high[:-1]) - float(clearance)
        for k in range(count):
            c = cell[k]
            offsets[k, axis] = centres[c]
            edge = min(half[axis] - (centres[c] + uppers[k]), half[axis] + (centres[c] + lowers[k]))
            beside = [gaps[c - 1]] if c > 0 else []
            beside += [gaps[c]] if c < len(gaps) else []
            pair = min(beside, default=math.inf) / 2
            room[k] = min(room[k], edge, pair)
    return offsets, np.maximum(room, 0.0), size


def _fits(size, half) -> bool:
    return bool(np.all(size <= 2 * np.asarray(half, dtype=float) + FIT_TOLERANCE))


def _oriented_grid(outlines, yaw_noise, spacing, clearance, noise, half):
    """(yaws, grid) of [`row_layout`][tableclean_suite.environments.placement.row_layout] at yaw noise ``yaw_noise``: every object at yaw 0, then turned
    narrow side along x one at a time (most gain first) until the grid fits; the last grid if none does."""
    yaws = np.zeros(len(outlines))
    grid = _grid(outlines, yaws, yaw_noise, spacing, clearance, noise, half)
    narrow = [narrow_yaw(o) for o in outlines]
    width = [float(np.ptp(turned(o, 0.0)[:, 0])) - float(np.ptp(turned(o, y)[:, 0])) for o, y in zip(outlines, narrow)]
    for k in sorted(range(len(outlines)), key=lambda k: -width[k]):
        if _fits(grid[2], half) or width[k] <= FIT_TOLERANCE:
            break
        yaws[k] = narrow[k]
        grid = _grid(outlines, yaws, yaw_noise, spacing, clearance, noise, half)
    return yaws, grid


def row_layout(outlines: Sequence[np.ndarray], half_size, spacing: float, clearance: float, noise: float,
               yaw_noise: float = 0.0) -> RowLayout:
    """The spots, yaws and noise caps of the objects of ``outlines`` (each (K, 2), own frame) sharing one segment.

    See the module docstring for the rule.  ``half_size`` (2,): the segment's half extents [m];
    ``spacing``: least distance [m] between neighbouring spots (``object_spacing``); ``clearance``:
    least gap [m] between two footprints (``object_clearance``); ``noise``: xy noise half-width [m]
    (``placement_noise``); ``yaw_noise``: yaw noise half-width [rad] (``placement_yaw_noise``).
    Raises [`DoesNotFit`][tableclean_suite.environments.placement.DoesNotFit] when the grid does not fit even turned and without yaw noise.
    """
    half = np.asarray(half_size, dtype=float)[:2]
    if len(outlines) == 0:
        return RowLayout(np.zeros(0), np.zeros((0, 2)), np.zeros(0), float(yaw_noise), np.zeros(2))

    def attempt(psi):
        yaws, grid = _oriented_grid(outlines, psi, spacing, clearance, noise, half)
        return (yaws, grid) if _fits(grid[2], half) else None

    found, cap = attempt(float(yaw_noise)), float(yaw_noise)
    if found is None:
        found, cap = attempt(0.0), 0.0
        if found is None:
            size = _oriented_grid(outlines, 0.0, spacing, clearance, noise, half)[1][2]
            raise DoesNotFit(f"their grid needs {size[0] * 100:.1f} x {size[1] * 100:.1f} cm (each turned so its "
                             f"narrowest width lies along the row if that helps, {clearance * 100:.1f} cm apart), "
                             f"a segment is {2 * half[0] * 100:.1f} x {2 * half[1] * 100:.1f} cm", size)
        low, high = 0.0, float(yaw_noise)
        for _ in range(YAW_CAP_STEPS):
            mid = 0.5 * (low + high)
            tried = attempt(mid)
            if tried is None:
                high = mid
            else:
                low, found = mid, tried
        cap = low
    yaws, (offsets, room, size) = found
    return RowLayout(yaws, offsets, room, cap, size)


def other_segments(centers, half_sizes, segment: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """``(center (2,), half_size (2,))`` [m] of every segment but ``segment`` (0-based), for [`free_spot`][tableclean_suite.environments.placement.free_spot]."""
    return [(np.asarray(centers[k], dtype=float)[:2], np.asarray(half_sizes[k], dtype=float))
            for k in range(len(centers)) if k != int(segment)]


def _distance_to_rectangles(points: np.ndarray, rectangles) -> np.ndarray:
    """(K,) distance [m] of each of ``points`` (K, 2) to the nearest of ``rectangles`` (inf without any)."""
    nearest = np.full(len(points), np.inf)
    for center, half in rectangles:
        outside = np.maximum(np.abs(points - np.asarray(center, dtype=float)[:2]) - np.asarray(half, dtype=float), 0.0)
        nearest = np.minimum(nearest, np.linalg.norm(outside, axis=1))
    return nearest


def _support(footprint, directions: np.ndarray) -> np.ndarray:
    """(D,) how far [m] a footprint reaches from its object's origin along each of ``directions`` (2, D): a
    radius [m] (a disc: the same every way) or an outline (K, 2) [m]."""
    if np.ndim(footprint) == 0:
        return np.full(directions.shape[1], float(footprint))
    return (np.asarray(footprint, dtype=float) @ directions).max(axis=0)


def _directions() -> tuple[np.ndarray, np.ndarray]:
    """(2, GAP_DIRECTIONS) unit directions over a full turn, and each one's opposite's index."""
    angles = np.arange(GAP_DIRECTIONS) * (2 * np.pi / GAP_DIRECTIONS)
    return np.stack([np.cos(angles), np.sin(angles)]), np.roll(np.arange(GAP_DIRECTIONS), GAP_DIRECTIONS // 2)


def quat_matrix(quat_xyzw) -> np.ndarray:
    """(3, 3) rotation matrix of the unit quaternion ``quat_xyzw`` (4,) (robosuite's order)."""
    x, y, z, w = (float(q) for q in quat_xyzw)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def grown(footprint, margin: float):
    """``footprint`` (a radius [m] or an outline (K, 2) [m], as in [`free_spot`][tableclean_suite.environments.placement.free_spot]) grown by ``margin`` [m] every
    way: the radius plus ``margin``, or the outline's convex hull with a [`disc_outline`][tableclean_suite.environments.placement.disc_outline] of ``margin`` about each
    corner (it covers every point within ``margin`` of the outline).  ``margin <= 0``: ``footprint`` itself."""
    if margin <= 0.0:
        return footprint
    if np.ndim(footprint) == 0:
        return float(footprint) + float(margin)
    corners = np.asarray(footprint, dtype=float)[:, None, :] + disc_outline(margin)[None, :, :]
    return outline_of(corners.reshape(-1, 2))


def nearest_point(xy, footprint, point) -> np.ndarray:
    """(2,) the point [m, world xy] of the footprint (a radius or an outline (K, 2) about the object's origin at
    world ``xy``; first two entries used) nearest to ``point`` (2,) [m] outside it (the outline's edges, in the
    order [`outline_of`][tableclean_suite.environments.placement.outline_of] gives them; a point inside gets the nearest edge point too)."""
    origin = np.asarray(xy, dtype=float)[:2]
    p = np.asarray(point, dtype=float)[:2]
    if np.ndim(footprint) == 0:
        away = p - origin
        norm = float(np.hypot(away[0], away[1]))
        return origin.copy() if norm == 0.0 else origin + float(footprint) * away / norm
    corners = origin + np.asarray(footprint, dtype=float)
    if len(corners) == 1:
        return corners[0].copy()
    starts, ends = corners, np.roll(corners, -1, axis=0)
    edges = ends - starts
    lengths = np.maximum(np.einsum("ij,ij->i", edges, edges), FIT_TOLERANCE ** 2)
    t = np.clip(np.einsum("ij,ij->i", p - starts, edges) / lengths, 0.0, 1.0)
    closest = starts + t[:, None] * edges
    return closest[int(np.argmin(np.linalg.norm(closest - p, axis=1)))]


def footprint_of(info, obj: int):
    """Object ``obj``'s footprint as it stands now, from the env's ``skill_info`` ``info``: its radius [m] (a disc,
    any yaw) when its type overrides ``footprint_radius``, else its outline (K, 2) in world axes about its
    origin (the [`outline_of`][tableclean_suite.environments.placement.outline_of] of its collision geometry turned
    as it stands, tilted too)."""
    if info["object_types"][obj].footprint_radius is not None:
        return float(info["objects_footprint"][obj])
    return outline_of(info["objects_geometry"][obj].hull @ quat_matrix(info["objects_quat"][obj]).T)


def free_spot(center, half_size, footprint, others: Sequence[tuple[np.ndarray, object]], clearance: float,
              away_from: Sequence[tuple[np.ndarray, np.ndarray]] = (), hand=None,
              under_hand: Sequence[tuple[np.ndarray, object]] = ()) -> np.ndarray:
    """(2,) world xy for the origin of an object of ``footprint`` on a segment (see the module docstring).

    A footprint is a radius [m] (a disc: the object at any yaw) or an outline (K, 2) [m] in world axes about
    the object's origin, turned as the object stands
    ([`footprint_of`][tableclean_suite.environments.placement.footprint_of]).

    Args:
        center: segment centre (first two entries used).
        half_size: (2,) segment half extents.
        footprint: of the object to place, as it will stand.
        others: ``(xy, footprint)`` of the objects lying on the segment (xy: first two entries used).
        clearance: the config's ``object_clearance`` [m] kept between two footprints.
        away_from: ``(center, half_size)`` of the other segments ([`other_segments`][tableclean_suite.environments.placement.other_segments]); the spot
            keeps as far from them as it can when the centre is taken.
        hand: the footprint, about the spot, of the hand lowering the object (e.g. the disc of its
            half width across the fingers, the side it turns toward a tall neighbour); with
            ``under_hand``.
        under_hand: ``(xy, footprint)`` of the lying objects whose top reaches the hand's underside
            at release: the hand's footprint keeps ``clearance`` from them too.
    """
    if len(under_hand) and hand is None:
        raise ValueError(f"free_spot: under_hand names {len(under_hand)} object(s) the hand must clear, but hand "
                         "(the hand's footprint about the spot: a radius [m] or an outline (K, 2)) is None")
    center = np.asarray(center, dtype=float)[:2]
    half = np.asarray(half_size, dtype=float)[:2]
    directions, opposite = _directions()  # (2, D)
    reach_mine = _support(footprint, directions)  # (D,) of the object to place
    # per other object: the nearest its footprint comes along each direction, less my reach there
    fronts = [np.asarray(p, dtype=float)[:2] @ directions - _support(f, directions)[opposite] - reach_mine
              for p, f in others]
    if under_hand:
        reach_hand = _support(hand, directions)
        fronts += [np.asarray(p, dtype=float)[:2] @ directions - _support(f, directions)[opposite] - reach_hand
                   for p, f in under_hand]

    def gaps(offsets: np.ndarray) -> np.ndarray:
        along = (center + offsets) @ directions  # (K, D)
        gap = np.full(len(offsets), np.inf)
        for front in fronts:
            gap = np.minimum(gap, np.max(front - along, axis=1))
        return gap

    if gaps(np.zeros((1, 2)))[0] >= clearance:
        return center.copy()
    axes_reach = _support(footprint, np.array([[1.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, -1.0]]))  # +x, +y, -x, -y
    low = -half + axes_reach[2:]
    high = half - axes_reach[:2]
    axes = [LATTICE_STEP * np.arange(math.ceil(lo / LATTICE_STEP - FIT_TOLERANCE),
                                     math.floor(hi / LATTICE_STEP + FIT_TOLERANCE) + 1) for lo, hi in zip(low, high)]
    lattice = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 2)
    if len(lattice) == 0:
        return center.copy()
    gap = gaps(lattice)
    fits = gap >= clearance
    if not fits.any():
        # none keeps the clearance: the farthest of the lattice and the segment's extreme spots (its sides lie
        # up to a lattice step beyond the lattice, and a corner is often the farthest from a centred neighbour)
        axes = [np.unique(np.concatenate([a, [lo, hi]])) if lo <= hi else a for a, lo, hi in zip(axes, low, high)]
        lattice = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 2)
        return center + lattice[int(np.argmax(gaps(lattice)))]
    spots = lattice[fits]
    far = np.round(_distance_to_rectangles(center + spots, away_from) / DISTANCE_RESOLUTION)
    order = np.lexsort((np.linalg.norm(spots, axis=1), -far))
    return center + spots[order[0]]
