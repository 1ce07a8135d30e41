"""What an object's collision geometry says: its extent, footprint, narrow side and resting height
([`ObjectGeometry`][tableclean_suite.environments.object_geometry.ObjectGeometry], of a robosuite ``MujocoObject``:
[`object_geometry`][tableclean_suite.environments.object_geometry.object_geometry]).

Everything here is read from MuJoCo's compiled model (geom types and sizes, mesh vertices, the
geoms' poses in the object's root body), never from per-type numbers or robosuite's
``bottom_site`` / ``top_site`` (which robosuite's mesh objects place up to 2 cm off their meshes).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache

import mujoco
import numpy as np
from scipy.spatial import ConvexHull, QhullError

#: Points sampled on each circle of a round geom (sphere, cylinder, capsule, ellipsoid); the
#: sampled extent falls short of the true one by at most r (1 - cos(pi / this)): 0.5 % of the radius.
CIRCLE_POINTS = 32
#: Largest vertical gap [m] between the sampled circles of a cylinder's side or a capsule's domes, so that
#: the width of any horizontal slice of a round body is known (`ObjectGeometry.slice_width`).
SLICE_SPACING = 0.002
#: Horizontal directions [rad] over a half turn at which the object's width across the fingers is
#: measured to find its narrow side (every 1 degree).
WIDTH_DIRECTIONS = 180
#: Two widths [m] closer than this count as equal: a square footprint (two narrow sides) or a round
#: one (every side narrow: any gripper yaw will do).
EQUAL_WIDTH = 1e-3


#: (8, 3) the signs of a box's corners.
_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)


def _circle(radius_x: float, radius_y: float, z: float) -> np.ndarray:
    angles = np.linspace(0.0, 2.0 * np.pi, CIRCLE_POINTS, endpoint=False)
    return np.column_stack([radius_x * np.cos(angles), radius_y * np.sin(angles), np.full(CIRCLE_POINTS, z)])


def _geom_local_points(model: mujoco.MjModel, geom: int) -> np.ndarray:
    """(K, 3) points on geom ``geom`` in its own frame [m]."""
    kind, size = int(model.geom_type[geom]), model.geom_size[geom]
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return _CORNERS * size
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = int(model.geom_dataid[geom])
        start, count = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
        return np.array(model.mesh_vert[start:start + count], dtype=float)
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        r = float(size[0])
        return np.vstack([_circle(r, r, 0.0), [[0, 0, r], [0, 0, -r]]])
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        r, h = float(size[0]), float(size[1])
        levels = np.linspace(-h, h, int(np.ceil(2 * h / SLICE_SPACING)) + 1)
        return np.vstack([_circle(r, r, h), _circle(r, r, -h)] + [_circle(r, r, z) for z in levels[1:-1]])
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        r, h = float(size[0]), float(size[1])
        rises = np.linspace(0.0, r, int(np.ceil(r / SLICE_SPACING)) + 1)[1:-1]  # (rims and poles apart)
        rings = [_circle(np.sqrt(r * r - d * d), np.sqrt(r * r - d * d), side * (h + d)) for d in rises for side in (1, -1)]
        return np.vstack([_circle(r, r, h), _circle(r, r, -h), [[0, 0, h + r], [0, 0, -h - r]]] + rings)
    if kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        a, b, c = (float(s) for s in size)
        return np.vstack([_circle(a, b, 0.0), [[0, 0, c], [0, 0, -c]]])
    # planes, height fields, SDFs: fall back on MuJoCo's own bounding box of the geom
    return model.geom_aabb[geom, :3] + _CORNERS * model.geom_aabb[geom, 3:]


def subtree_bodies(model: mujoco.MjModel, root: int) -> np.ndarray:
    """Ids of body ``root`` and every body below it."""
    ids = [root]
    for body in range(root + 1, model.nbody):
        if int(model.body_parentid[body]) in ids:
            ids.append(body)
    return np.asarray(ids, dtype=int)


def collision_geoms(model: mujoco.MjModel, root: int) -> np.ndarray:
    """Ids of the colliding geoms (``contype`` or ``conaffinity`` non-zero) of body ``root``'s subtree."""
    bodies = subtree_bodies(model, root)
    colliding = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    return np.flatnonzero(np.isin(model.geom_bodyid, bodies) & colliding)


def collision_points(model: mujoco.MjModel, data: mujoco.MjData, root: int, geoms=None) -> np.ndarray:
    """(K, 3) points [m] on the collision geoms of body ``root``'s subtree (or on ``geoms``), in ``root``'s frame.

    ``data`` must hold the kinematics (``mj_kinematics`` or a step) of any pose: the object is rigid.
    """
    geoms = collision_geoms(model, root) if geoms is None else np.asarray(geoms, dtype=int)
    body_pos, body_rot = data.xpos[root], data.xmat[root].reshape(3, 3)
    parts = []
    for geom in geoms:
        local = _geom_local_points(model, int(geom))
        world = data.geom_xpos[geom] + local @ data.geom_xmat[geom].reshape(3, 3).T
        parts.append((world - body_pos) @ body_rot)
    if not parts:
        raise ValueError(f"body {model.body(root).name!r} has no colliding geom")
    return np.vstack(parts)


@dataclass(frozen=True, eq=False)
class ObjectGeometry:
    """An object's collision geometry in its own (root body) frame.

    The measures derived from ``points`` (extents, widths) are computed once, on first use, and
    kept (read-only arrays): skills read them every control step.

    Attributes:
        points: (K, 3) points on its collision geoms [m], root-body frame (never changed after construction).
    """

    points: np.ndarray

    @cached_property
    def lower(self) -> np.ndarray:
        """(3,) smallest x, y, z of the collision geometry in the object's frame [m]."""
        return frozen(self.points.min(axis=0))

    @cached_property
    def upper(self) -> np.ndarray:
        """(3,) largest x, y, z of the collision geometry in the object's frame [m]."""
        return frozen(self.points.max(axis=0))

    @cached_property
    def half_size(self) -> np.ndarray:
        """(3,) half extents [m] of the smallest origin-centred box holding the geometry."""
        return frozen(np.maximum(np.abs(self.lower), np.abs(self.upper)))

    @cached_property
    def hull(self) -> np.ndarray:
        """(H, 3) the corners of the convex hull of ``points`` [m] (all of them when they span no volume):
        what a footprint at any pose needs (read-only)."""
        return frozen(hull_corners(self.points))

    @property
    def height(self) -> float:
        """Vertical extent [m] of the upright object."""
        return float(self.upper[2] - self.lower[2])

    @cached_property
    def footprint_radius(self) -> float:
        """Radius [m] of the disc about the object's origin covering it seen from above (any yaw)."""
        return float(np.max(np.linalg.norm(self.points[:, :2], axis=1)))

    def widths(self) -> np.ndarray:
        """(WIDTH_DIRECTIONS,) widths [m] of the upright object along the directions ``k pi / WIDTH_DIRECTIONS``
        of its own frame (what closing fingers along that direction span; read-only)."""
        return self._widths

    @cached_property
    def _widths(self) -> np.ndarray:
        return frozen(widths_of(self.points[:, :2]))

    def slice_width(self, low: float, high: float, direction: int) -> float:
        """Width [m] along direction ``direction`` (angle ``direction pi / WIDTH_DIRECTIONS``, own frame) of the
        collision points whose height [m, own frame] is in ``[low, high]`` (0 when there are none): a round
        body's horizontal slice there (its sides are sampled every `SLICE_SPACING`; a box's only at its corners)."""
        inside = (self.points[:, 2] >= low) & (self.points[:, 2] <= high)
        if not inside.any():
            return 0.0
        angle = direction * np.pi / WIDTH_DIRECTIONS
        along = self.points[inside, :2] @ np.array([np.cos(angle), np.sin(angle)])
        return float(along.max() - along.min())

    @cached_property
    def narrow_width(self) -> float:
        """Smallest horizontal width [m] of the upright object: what the fingers close across."""
        return float(self.widths().min())

    @cached_property
    def is_round(self) -> bool:
        """Whether every horizontal width is the same within `EQUAL_WIDTH` (any gripper yaw grasps it)."""
        widths = self.widths()
        return float(widths.max() - widths.min()) <= EQUAL_WIDTH

    def narrow_side(self) -> tuple[float, float]:
        """``(direction, period)`` [rad]: a direction in the object's frame along which the fingers close
        across its narrowest width, and the turn after which another equally narrow one follows
        (``pi / 2`` for a square footprint, else ``pi``)."""
        widths = self.widths()
        k = int(np.argmin(widths))
        quarter = (k + WIDTH_DIRECTIONS // 2) % WIDTH_DIRECTIONS
        direction = (k / (WIDTH_DIRECTIONS // 2)) * (0.5 * np.pi)  # a quarter turn exactly at k = W / 2
        period = 0.5 * np.pi if abs(widths[quarter] - widths[k]) <= EQUAL_WIDTH else np.pi
        return direction, period


def box_geometry(half_size) -> ObjectGeometry:
    """The geometry of an origin-centred box of half extents ``half_size`` (3,) [m] (its 8 corners)."""
    return ObjectGeometry(_CORNERS * np.asarray(half_size, dtype=float))


def hull_corners(points) -> np.ndarray:
    """The corners of the convex hull of ``points`` (K, D) (a copy of all of them when they span no D-volume)."""
    try:
        return points[ConvexHull(points).vertices]
    except (QhullError, ValueError):  # fewer than D + 1 points, or all in a plane (a line)
        return np.array(points)


def widths_of(xy) -> np.ndarray:
    """(WIDTH_DIRECTIONS,) widths [m] of the points ``xy`` (K, 2) along the directions ``k pi / WIDTH_DIRECTIONS``."""
    angles = np.arange(WIDTH_DIRECTIONS) * (np.pi / WIDTH_DIRECTIONS)
    projections = np.asarray(xy, dtype=float) @ np.stack([np.cos(angles), np.sin(angles)])
    return projections.max(axis=0) - projections.min(axis=0)


def frozen(values) -> np.ndarray:
    """A read-only float copy of ``values``."""
    array = np.array(values, dtype=float)
    array.setflags(write=False)
    return array


def wrap_angle(angle: float) -> float:
    """``angle`` (rad) wrapped to [-pi, pi)."""
    return float((angle + np.pi) % (2 * np.pi) - np.pi)


def grasp_yaw(geometry: ObjectGeometry, object_yaw: float, preferred_yaw: float) -> float:
    """Gripper yaw [rad] (fingers closing along the grip site's x axis) across the object's narrow side.

    Of the equally narrow yaws the one nearest ``preferred_yaw`` is returned, so the wrist never
    winds up.  ``object_yaw``: the upright object's heading [rad].
    """
    direction, period = geometry.narrow_side()
    base = object_yaw + direction
    turns = np.round(wrap_angle(preferred_yaw - base) / period)
    return wrap_angle(base + turns * period)


@lru_cache(maxsize=256)
def _compiled_points(world_xml: str, root_name: str) -> np.ndarray:
    model = mujoco.MjModel.from_xml_string(world_xml)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    return frozen(collision_points(model, data, model.body(root_name).id))


def object_geometry(obj) -> ObjectGeometry:
    """The collision geometry of robosuite ``MujocoObject`` ``obj``, compiled on its own (cached per model text)."""
    from robosuite.models.world import MujocoWorldBase

    world = MujocoWorldBase()
    world.merge_assets(obj)
    world.worldbody.append(obj.get_obj())
    return ObjectGeometry(_compiled_points(world.get_xml(), obj.root_body))


def world_lowest_z(geometry: ObjectGeometry, pos, rot) -> float:
    """World z [m] of the lowest collision point of the object at ``pos`` (3,) with rotation matrix ``rot`` (3, 3)."""
    return world_z_range(geometry, pos, rot)[0]


def world_z_range(geometry: ObjectGeometry, pos, rot) -> tuple[float, float]:
    """``(lowest, highest)`` world z [m] of the object's collision points at ``pos`` (3,) with rotation matrix
    ``rot`` (3, 3), from one projection."""
    heights = geometry.points @ np.asarray(rot)[2]
    return float(pos[2] + float(np.min(heights))), float(pos[2] + float(np.max(heights)))


__all__ = ["ObjectGeometry", "object_geometry", "box_geometry", "collision_points", "collision_geoms", "grasp_yaw",
           "world_lowest_z", "world_z_range", "wrap_angle", "CIRCLE_POINTS", "EQUAL_WIDTH", "SLICE_SPACING",
           "WIDTH_DIRECTIONS"]
