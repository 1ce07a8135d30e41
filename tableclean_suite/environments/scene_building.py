"""Building the ``TableClean`` scene and laying it out at a reset: checks that the objects fit a segment,
their measures as built, the arm's hover pose, the objects' and the sponge's start poses."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import Mapping, NamedTuple, Sequence

import numpy as np

from tableclean_suite.environments import placement
from tableclean_suite.environments.ik import site_pose, solve_site_pose
from tableclean_suite.environments.objects import footprint_radius, type_geometry
from tableclean_suite.robosuite_adapter import mj_model

#: Height above the table top at which a dropped object is placed, so it settles without penetration [m].
PLACEMENT_CLEARANCE = 0.001
#: A randomised sponge start keeps its footprint this far inside its stand's edges [m].
STAND_EDGE_MARGIN = 0.002


def object_outline(kind, shape, radius: float | None = None) -> np.ndarray:
    """(K, 2) outline [m] of an upright object of type ``kind`` seen from above in its own frame: a disc of
    ``radius`` (default its ``footprint_radius``) when the type overrides the footprint, else its collision
    geometry ``shape``'s ([outline_of][tableclean_suite.environments.placement.outline_of])."""
    if kind.footprint_radius is not None:
        return placement.disc_outline(float(kind.footprint_radius) if radius is None else radius)
    return placement.outline_of(shape.hull)


def check_objects_fit(kinds, geometry, config: Mapping, size_scale: float = 1.0) -> None:
    """``ValueError`` (naming the objects, the size they need and the segment's) unless all the objects of
    ``kinds`` fit side by side on one segment by their oriented footprints
    ([`row_layout`][tableclean_suite.environments.placement.row_layout]), each footprint times ``size_scale``."""
    half = np.asarray(geometry.segment_half_sizes[0], dtype=float)
    scaled = f" at object size scale {size_scale:g}" if size_scale != 1.0 else ""
    segment = f"{2 * half[0] * 100:.1f} x {2 * half[1] * 100:.1f} cm"

    def layout(outlines):
        return placement.row_layout(outlines, half, config["object_spacing"], config["object_clearance"], 0.0)

    outlines = []
    for kind in kinds:
        outline = object_outline(kind, type_geometry(kind, config)) * size_scale
        try:
            layout([outline])
        except placement.DoesNotFit as error:
            raise ValueError(f"object {kind.name!r} does not fit a segment{scaled}: its footprint is "
                             f"{error.size[0] * 100:.1f} x {error.size[1] * 100:.1f} cm (even turned with its narrowest "
                             f"width along x), a segment {segment}") from None
        outlines.append(outline)
    try:
        layout(outlines)
    except placement.DoesNotFit as error:
        raise ValueError(f"{len(kinds)} objects ({', '.join(k.name for k in kinds)}) do not fit side by side on one "
                         f"segment{scaled}: {error}; use fewer or smaller objects") from None


def check_randomization_fits(randomization, kinds, geometry, config: Mapping) -> None:
    """``ValueError`` when ``randomization`` (a
    [DynamicsRandomization][tableclean_suite.environments.randomization.DynamicsRandomization]) could move
    the sponge's start beyond the ``config``'s home tolerance, or draw objects of ``kinds`` too large to lie
    side by side on one segment."""
    largest = randomization.object_size_scale[1]
    if largest > 1.0:
        check_objects_fit(kinds, geometry, config, largest)
    corner = randomization.sponge_home_noise * np.sqrt(2.0)
    if corner > config["sponge_home_tolerance"]:
        raise ValueError(f"randomization sponge_home_noise {randomization.sponge_home_noise} m can put the "
                         f"sponge {corner:.4f} m from home, beyond sponge_home_tolerance "
                         f"{config['sponge_home_tolerance']} m")


class ObjectMeasures(NamedTuple):
    """The M objects' sizes as built (object 1 first), read from their collision geometry."""

    types: tuple  #: (M,) their [ObjectType][tableclean_suite.environments.objects.ObjectType]s
    geometries: tuple  #: (M,) their [ObjectGeometry][tableclean_suite.environments.object_geometry.ObjectGeometry]
    half_sizes: np.ndarray  #: (M, 3) bounding half extents [m]
    rest_z: np.ndarray  #: (M,) centre height when resting upright on the table [m]
    footprints: np.ndarray  #: (M,) footprint radii [m]
    outlines: tuple  #: (M,) outlines (K, 2) [m] seen from above in their own frames, upright

    @classmethod
    def of(cls, kinds, geometries, table_top_z: float, nominal_footprints: np.ndarray) -> "ObjectMeasures":
        """The measures of objects of ``kinds`` built with ``geometries``; ``nominal_footprints`` (M,) [m] are
        the footprints built from the unrandomised config: an overridden footprint grows with a drawn size
        as the geometry's does."""
        kinds, geometries = tuple(kinds), tuple(geometries)
        growth = np.array([g.footprint_radius for g in geometries]) / nominal_footprints
        footprints = np.array([footprint_radius(kind, g) for kind, g in zip(kinds, geometries)])
        footprints *= np.where([k.footprint_radius is None for k in kinds], 1.0, growth)
        return cls(types=kinds, geometries=geometries,
                   half_sizes=np.array([g.half_size for g in geometries], dtype=float),
                   rest_z=np.array([table_top_z - float(g.lower[2]) for g in geometries]),
                   footprints=footprints,
                   outlines=tuple(object_outline(kind, g, float(r)) for kind, g, r in zip(kinds, geometries, footprints)))


def exclude_parent_contacts(robot_model) -> int:
    """Add ``<exclude>`` contact pairs for every parent-child body pair of ``robot_model`` (robosuite MJCF model),
    before it is merged into the task model: MuJoCo skips parent-child contacts only below a world-welded parent,
    so a fixed-base arm's first link collides with its base (Sawyer's stalls the OSC).  Returns the pairs added."""
    added = 0
    for parent in robot_model.worldbody.iter("body"):
        for child in parent.findall("body"):
            first, second = parent.get("name"), child.get("name")
            if first and second:
                robot_model.contact.append(ET.Element("exclude", attrib={"body1": first, "body2": second}))
                added += 1
    return added


def hover_qpos(sim, robot, target) -> np.ndarray:
    """Arm joint positions putting ``robot``'s grip site at world ``target`` (3,) [m] with the orientation of
    its default pose (a deterministic IK solve on robosuite's simulation ``sim``)."""
    model = sim.model
    qpos_addrs = [model.get_joint_qpos_addr(j) for j in robot.robot_model.joints]
    dof_addrs = [model.get_joint_qvel_addr(j) for j in robot.robot_model.joints]
    site_id = model.site_name2id(robot.gripper[robot.arms[0]].important_sites["grip_site"])
    q_default = np.array(robot.robot_model.init_qpos, dtype=float)
    _, default_mat = site_pose(mj_model(sim), qpos_addrs, site_id, q_default)
    return solve_site_pose(mj_model(sim), qpos_addrs, dof_addrs, site_id, target, default_mat, q_default)


def resting_qpos(xy, yaw: float, rest_z: float) -> np.ndarray:
    """(7,) free-joint qpos of an object at rest at world ``xy`` [m] turned ``yaw`` [rad] about z, its centre
    ``PLACEMENT_CLEARANCE`` above its resting height ``rest_z`` [m] so it settles without penetration."""
    quat_wxyz = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
    return np.concatenate([np.asarray(xy, dtype=float)[:2], [rest_z + PLACEMENT_CLEARANCE], quat_wxyz])


def sponge_start_qpos(geometry, config: Mapping, sample=None) -> np.ndarray:
    """(7,) free-joint qpos of the sponge at rest on its home, offset and turned by ``sample`` (a
    [DynamicsSample][tableclean_suite.environments.randomization.DynamicsSample], None: exactly home)."""
    pos = geometry.sponge_home_pos
    if sample is None:
        return np.concatenate([pos, [1.0, 0.0, 0.0, 0.0]])
    # clipped so the turned sponge rests wholly on its stand, STAND_EDGE_MARGIN inside its edges, and settling from
    # just above as the objects do (MuJoCo's box-box test reports a bogus deep contact when edges or faces coincide)
    yaw, half = sample.sponge_yaw, np.asarray(config["sponge_half_size"], dtype=float)
    footprint = np.abs(np.cos(yaw)) * half[:2] + np.abs(np.sin(yaw)) * half[1::-1]
    room = np.maximum(geometry.stand_half_size[:2] - footprint - STAND_EDGE_MARGIN, 0.0)
    return resting_qpos(pos[:2] + np.clip(sample.sponge_home_offset, -room, room), yaw, pos[2])


class ResetLayouts:
    """Where a reset puts the objects: on each segment a grid of their oriented outlines
    ([row_layout][tableclean_suite.environments.placement.row_layout]) plus capped xy and yaw noise.

    Args:
        outlines: (M,) the objects' outlines (K, 2) [m] ([ObjectMeasures][tableclean_suite.environments.scene_building.ObjectMeasures]).
    """

    def __init__(self, outlines: Sequence[np.ndarray]):
        self.outlines = tuple(outlines)
        self._cache: dict = {}  # row layouts per (objects, segment size, config values)

    def row(self, here: tuple[int, ...], segment: int, half_size, config: Mapping) -> placement.RowLayout:
        """The row layout of objects ``here`` (0-based) on ``segment`` (0-based, half extents ``half_size``
        (2,) [m]); ``ValueError`` naming the objects when they do not fit."""
        key = (here, tuple(half_size), float(config["object_spacing"]), float(config["object_clearance"]),
               float(config["placement_noise"]), float(config["placement_yaw_noise"]))
        if key not in self._cache:
            try:
                self._cache[key] = placement.row_layout(
                    [self.outlines[j] for j in here], half_size, key[2], key[3], key[4], key[5])
            except placement.DoesNotFit as error:
                raise ValueError(f"objects {[j + 1 for j in here]} do not fit side by side on segment {segment + 1}: "
                                 f"{error}") from None
        return self._cache[key]

    def draw(self, rng: np.random.Generator, segments: Sequence[int], geometry,
             config: Mapping) -> list[tuple[int, np.ndarray, float]]:
        """``(object, xy [m], yaw [rad])`` of each object, object j on ``segments[j]`` (0-based), the noise
        drawn from ``rng`` (per segment in order, per object: xy noise, then yaw noise)."""
        poses = []
        yaw_noise = float(config["placement_yaw_noise"])
        for segment in sorted(set(segments)):
            here = tuple(j for j, k in enumerate(segments) if k == segment)
            layout = self.row(here, segment, geometry.segment_half_sizes[segment], config)
            for j, offset, bound, base_yaw in zip(here, layout.offsets, layout.xy_noise, layout.yaws):
                noise = rng.uniform(-config["placement_noise"], config["placement_noise"], size=2)
                noise = np.clip(noise, -bound, bound)
                yaw = rng.uniform(-yaw_noise, yaw_noise)
                if layout.yaw_noise < yaw_noise:
                    yaw = float(np.clip(yaw, -layout.yaw_noise, layout.yaw_noise))
                if base_yaw != 0.0:
                    yaw = float(base_yaw) + yaw
                poses.append((j, geometry.segment_centers[segment, :2] + offset + noise, yaw))
        return poses
