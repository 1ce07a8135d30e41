"""The table-cleaning arena: robosuite's ``TableArena`` plus, on the table body, one tinted visual patch per
segment and dividers between neighbours, ``rows * cols`` visual-only dirt markers per segment, one dirt-state
body per segment ([`dirt_state`][tableclean_suite.environments.dirt_state]), the sponge's stand and a ``tableview`` camera."""

from __future__ import annotations

import numpy as np
from robosuite.models.arenas import TableArena
from robosuite.utils.mjcf_utils import new_body, new_geom, new_inertial, new_joint
from scipy.spatial.transform import Rotation

from tableclean_suite.environments.config import SceneGeometry
from tableclean_suite.environments.dirt_state import dirt_state_joint_name

#: RGBA of each segment's tint (segment 1 light blue, 2 light orange, 3 light green, 4 light violet; cycled).
SEGMENT_RGBA = ((0.62, 0.78, 0.95, 1.0), (0.98, 0.80, 0.58, 1.0), (0.70, 0.90, 0.62, 1.0), (0.84, 0.72, 0.95, 1.0))
DIVIDER_RGBA = (0.15, 0.15, 0.18, 1.0)
DIRT_RGBA = (0.36, 0.24, 0.12, 1.0)
STAND_RGBA = (0.25, 0.35, 0.55, 1.0)

#: Thickness (half height) of the visual layers on the table top [m]: tint, then dirt on top of it.
TINT_HALF_HEIGHT = 0.0003
DIRT_HALF_HEIGHT = 0.0006
#: Fraction of the segment gap covered by the divider strip.
DIVIDER_WIDTH_FRACTION = 0.5
#: Visual-only geom attributes (no collisions, rendered in robosuite's visual group 1).
_VISUAL = dict(contype=0, conaffinity=0, group=1)

#: Mass [kg] and principal inertia [kg m^2] of a dirt-state body (MuJoCo needs both > 0 on a moving body).
DIRT_STATE_MASS = 1e-3
DIRT_STATE_INERTIA = 1e-9
#: Damping of a dirt-state joint [N s/m]: any stray velocity dies within a physics step (implicit in MuJoCo).
DIRT_STATE_DAMPING = 1e6
#: Slide axis of a dirt-state joint (horizontal: gravity has no component along it).
DIRT_STATE_AXIS = "1 0 0"

#: Camera that shows the whole scene: (position, look-at point) in the table frame [m].
TABLEVIEW_CAMERA = "tableview"
TABLEVIEW_EYE = (0.62, -0.42, 0.62)
TABLEVIEW_TARGET = (-0.08, 0.06, 0.02)
TABLEVIEW_FOVY = 45


def marker_geom_name(segment: int, index: int) -> str:
    """Name of dirt marker ``index`` of ``segment`` (0-based; e.g. ``"dirt_s1_07"`` for segment 0)."""
    return f"dirt_s{segment + 1}_{index:02d}"


def look_at_quat(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """MuJoCo camera quaternion (w, x, y, z) looking from ``eye`` at ``target`` (camera looks along -z)."""
    eye, target, up = (np.asarray(v, dtype=float) for v in (eye, target, up))
    back = eye - target
    back /= np.linalg.norm(back)
    right = np.cross(up, back)
    right /= np.linalg.norm(right)
    cam_up = np.cross(back, right)
    rot = np.stack([right, cam_up, back], axis=1)  # columns: camera x, y, z in world
    x, y, z, w = Rotation.from_matrix(rot).as_quat()
    return np.array([w, x, y, z])


class TableCleanArena(TableArena):
    """A `TableArena` whose top is split into N dirty segments, with a sponge stand beside them.

    Args:
        geometry: world-frame scene geometry ([`scene_geometry`][tableclean_suite.environments.config.scene_geometry]).
        marker_xy: world xy of the dirt markers, shape ``(N, markers_per_segment, 2)``.
        marker_radius: radius of a dirt marker disc [m].
        table_full_size, table_friction, table_offset: as for `TableArena`.
    """

    def __init__(self, geometry: SceneGeometry, marker_xy: np.ndarray, marker_radius: float,
                 table_full_size, table_friction, table_offset):
        # configure_location() runs inside TableArena.__init__ and reads these
        self.geometry = geometry
        self.marker_xy = np.asarray(marker_xy, dtype=float)
        self.marker_radius = float(marker_radius)
        super().__init__(table_full_size=table_full_size, table_friction=table_friction, table_offset=table_offset)
        table = np.asarray(table_offset, dtype=float)
        self.set_camera(TABLEVIEW_CAMERA, pos=table + np.asarray(TABLEVIEW_EYE),
                        quat=look_at_quat(TABLEVIEW_EYE, TABLEVIEW_TARGET),
                        camera_attribs={"fovy": str(TABLEVIEW_FOVY)})

    @property
    def marker_names(self) -> list[str]:
        """Dirt marker geom names, segment 1 first, in the order of ``marker_xy``."""
        return [marker_geom_name(s, i) for s in range(self.marker_xy.shape[0]) for i in range(self.marker_xy.shape[1])]

    @property
    def dirt_state_joint_names(self) -> list[str]:
        """The dirt-state slide joints, one per segment, segment 1 first (see [`dirt_state`][tableclean_suite.environments.dirt_state])."""
        return [dirt_state_joint_name(s) for s in range(self.marker_xy.shape[0])]

    def configure_location(self):
        """Places the table (superclass), then adds segments, divider, dirt and the sponge stand."""
        super().configure_location()
        top = self.table_half_size[2]  # table-top height in the table body's frame
        body_xy = np.asarray(self.table_offset[:2], dtype=float)  # table body xy in the world
        g = self.geometry
        for segment in range(len(g.segment_centers)):
            center = g.segment_centers[segment, :2] - body_xy
            self.table_body.append(new_geom(
                f"segment{segment + 1}_visual", "box", size=(*g.segment_half_sizes[segment], TINT_HALF_HEIGHT),
                pos=(*center, top + TINT_HALF_HEIGHT), rgba=SEGMENT_RGBA[segment % len(SEGMENT_RGBA)], **_VISUAL))
        for index, (a, b) in enumerate(_neighbours(g)):
            ca, cb = g.segment_centers[a, :2], g.segment_centers[b, :2]
            axis = int(np.argmax(np.abs(cb - ca)))  # the strip lies across this axis
            gap = abs(cb[axis] - ca[axis]) - 2 * g.segment_half_sizes[a, axis]
            half = np.array(g.segment_half_sizes[a], dtype=float)
            half[axis] = max(gap * DIVIDER_WIDTH_FRACTION / 2, TINT_HALF_HEIGHT)
            name = "segment_divider_visual" if index == 0 else f"segment_divider{index + 1}_visual"
            self.table_body.append(new_geom(name, "box", size=(*half, TINT_HALF_HEIGHT),
                                            pos=(*((ca + cb) / 2 - body_xy), top + TINT_HALF_HEIGHT), rgba=DIVIDER_RGBA,
                                            **_VISUAL))
        marker_z = top + 2 * TINT_HALF_HEIGHT + DIRT_HALF_HEIGHT
        for name, xy in zip(self.marker_names, self.marker_xy.reshape(-1, 2)):
            self.table_body.append(new_geom(name, "cylinder", size=(self.marker_radius, DIRT_HALF_HEIGHT),
                                            pos=(*(xy - body_xy), marker_z), rgba=DIRT_RGBA, **_VISUAL))
        for joint in self.dirt_state_joint_names:
            body = new_body(joint.replace("_joint", "_body"), pos=(0.0, 0.0, 0.0))
            body.append(new_inertial(mass=DIRT_STATE_MASS, diaginertia=(DIRT_STATE_INERTIA,) * 3))
            body.append(new_joint(joint, type="slide", axis=DIRT_STATE_AXIS, limited="false", damping=DIRT_STATE_DAMPING))
            self.table_body.append(body)
        stand_local = g.stand_center - np.array([*body_xy, g.table_top_z - top])
        self.table_body.append(new_geom("sponge_stand", "box", size=g.stand_half_size, pos=stand_local, rgba=STAND_RGBA,
                                        group=0, friction=self.table_friction))
        self.table_body.append(new_geom("sponge_stand_visual", "box", size=g.stand_half_size, pos=stand_local,
                                        rgba=STAND_RGBA, **_VISUAL))


def _neighbours(geometry: SceneGeometry) -> list[tuple[int, int]]:
    """Pairs ``(a, b)`` of segments side by side (centres one segment side plus a gap apart along x or y)."""
    centers, half = geometry.segment_centers[:, :2], geometry.segment_half_sizes
    pairs = []
    for a in range(len(centers)):
        for b in range(a + 1, len(centers)):
            delta = np.abs(centers[b] - centers[a])
            axis = int(np.argmax(delta))
            aligned = delta[1 - axis] < half[a, 1 - axis]
            if aligned and delta[axis] < 2 * (half[a, axis] + half[b, axis]):
                pairs.append((a, b))
    return pairs
