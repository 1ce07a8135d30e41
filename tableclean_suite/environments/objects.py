"""Graspable object types (a registry users extend) and the sponge.

A task spec names its objects' types (``TaskSpec.objects``, e.g. ``("box", "milk")``); the scene builds each
from this registry.  An object type is how to build a robosuite ``MujocoObject``; its shape (extent, footprint,
resting height, where to grip it) is read from its collision geometry
([`object_geometry`][tableclean_suite.environments.object_geometry]), so registering one is one line
([`register_object`][tableclean_suite.environments.objects.register_object]: a class, a callable or an MJCF file).
What geometry cannot tell can be given as [`ObjectType`][tableclean_suite.environments.objects.ObjectType] overrides.  The scene refuses,
when it is made, an object the gripper cannot hold or that does not fit a segment.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np
from robosuite.models.objects import (BottleObject, BoxObject, BreadObject, CanObject, CerealObject, CylinderObject,
                                      LemonObject, MilkObject, MujocoObject)
from robosuite.utils.mjcf_utils import CustomMaterial

from tableclean_suite.registry import NAME_PATTERN, Registry

OBJECT_NAME = "object"
SPONGE_NAME = "sponge"

#: Sponge colour: yellow-green foam.
SPONGE_RGBA = (0.78, 0.86, 0.22, 1.0)
#: Sponge friction (sliding, torsional, rolling): grippy foam.
SPONGE_FRICTION = (1.5, 0.01, 0.001)
#: Soft contact (MuJoCo solref: time constant [s], damping ratio) so the sponge looks and acts squishy.
SPONGE_SOLREF = (0.01, 1.0)
#: Cube/box colour when no texture is used.
OBJECT_RGBA = (0.85, 0.1, 0.1, 1.0)
#: Colour of the cylinder type.
CYLINDER_RGBA = (0.1, 0.35, 0.85, 1.0)
#: Gripper yaw rules an object type may name.
YAW_RULES = ("short_side", "any")
#: m the open fingertips stay above a lying object's top while the gripper hovers over it.
APPROACH_CLEARANCE = 0.01
#: m the object's narrowest width must stay below the open gripper's pad gap to be grasped.
GRASP_WIDTH_MARGIN = 0.01
#: Free joint of objects built from a user's MJCF file (robosuite's default for its XML objects).
XML_OBJECT_JOINTS = ({"type": "free", "damping": "0.0005"},)

Builder = Callable[[str, Mapping], MujocoObject]


@dataclass(frozen=True)
class ObjectType:
    """A graspable object type (see the module docstring); the overrides' None derives the value from the geometry.

    Attributes:
        name: registry key, lower_snake (``"box"``).
        build: ``(mujoco_name, task_config) -> MujocoObject`` with one free joint.
        footprint_radius: m (> 0), radius of a disc covering the object seen from above.
        grasp_depth: m below the object's centre at which the grip site closes.
        approach_clearance: m between the open fingertips and the object's top while hovering
            (None: `APPROACH_CLEARANCE`).
        yaw_rule: one of `YAW_RULES` (None: ``"any"`` for a round footprint, else ``"short_side"``).
        description: one line for listings.
    """

    name: str
    build: Builder
    footprint_radius: float | None = None
    grasp_depth: float | None = None
    approach_clearance: float | None = None
    yaw_rule: str | None = None
    description: str = field(default="", compare=False)

    def __post_init__(self):
        if not isinstance(self.name, str) or not NAME_PATTERN.match(self.name):
            raise ValueError(f"object type name must be lower_snake (e.g. 'flat_box'), got {self.name!r}")
        if not callable(self.build):
            raise TypeError(f"object type {self.name!r}: build must be callable (name, task_config) -> MujocoObject")
        radius = self.footprint_radius
        if radius is not None and not (isinstance(radius, (int, float)) and math.isfinite(radius) and radius > 0):
            raise ValueError(f"object type {self.name!r}: footprint_radius must be > 0 m or None, got {radius!r}")
        for key in ("grasp_depth", "approach_clearance"):
            value = getattr(self, key)
            if value is not None and (not isinstance(value, (int, float)) or not math.isfinite(value)):
                raise ValueError(f"object type {self.name!r}: {key} must be a finite number [m] or None, got {value!r}")
        if self.yaw_rule is not None and self.yaw_rule not in YAW_RULES:
            raise ValueError(f"object type {self.name!r}: unknown yaw_rule {self.yaw_rule!r}; allowed: "
                             f"{', '.join(YAW_RULES)} or None (from the geometry)")

    def clearance(self) -> float:
        """m the open fingertips stay above the object's top while hovering (override or `APPROACH_CLEARANCE`)."""
        return APPROACH_CLEARANCE if self.approach_clearance is None else float(self.approach_clearance)


def _red_wood() -> CustomMaterial:
    return CustomMaterial(texture="WoodRed", tex_name="redwood", mat_name="redwood_mat", tex_attrib={"type": "cube"},
                          mat_attrib={"texrepeat": "1 1", "specular": "0.4", "shininess": "0.1"})


def _half_size(config: Mapping) -> np.ndarray:
    return np.asarray(config["object_half_size"], dtype=float)


def _box(name: str, config: Mapping) -> MujocoObject:
    return _fixed_box(_half_size(config))(name, config)


def _cube(name: str, config: Mapping) -> MujocoObject:
    return _fixed_box([float(np.min(_half_size(config)))] * 3)(name, config)  # the smallest half extent


def _cylinder(name: str, config: Mapping) -> MujocoObject:
    half = _half_size(config)
    return CylinderObject(name=name, size=[float(half[0]), float(half[2])], rgba=list(CYLINDER_RGBA))


def _fixed_box(half_size) -> Builder:
    return lambda name, config: BoxObject(name=name, size=list(half_size), rgba=list(OBJECT_RGBA), material=_red_wood())


def _fixed_cylinder(radius: float, half_height: float) -> Builder:
    return lambda name, config: CylinderObject(name=name, size=[radius, half_height], rgba=list(CYLINDER_RGBA))


def _robosuite(cls) -> Builder:
    return lambda name, config: cls(name=name)


BUILTIN_OBJECTS = (
    ObjectType("box", _box, description="red wooden box, half extents object_half_size (a cube by default)"),
    ObjectType("cube", _cube, description="red wooden cube, half side the smallest of object_half_size"),
    ObjectType("cylinder", _cylinder,
               description="upright blue cylinder, radius object_half_size[0], half height object_half_size[2]"),
    ObjectType("can", _robosuite(CanObject), description="robosuite's CanObject (5 cm diameter, 8 cm tall)"),
    ObjectType("bread", _robosuite(BreadObject), description="robosuite's BreadObject (5 x 4 x 5 cm)"),
    ObjectType("bottle", _robosuite(BottleObject), description="robosuite's BottleObject (5.5 x 5.9 x 16 cm)"),
    ObjectType("lemon", _robosuite(LemonObject), description="robosuite's LemonObject (6.8 x 4 x 4 cm)"),
    ObjectType("milk", _robosuite(MilkObject), description="robosuite's MilkObject (4 x 4 x 14.4 cm)"),
    ObjectType("cereal", _robosuite(CerealObject), description="robosuite's CerealObject (10 x 3 x 15 cm)"),
    ObjectType("tall_box", _fixed_box((0.02, 0.02, 0.05)), description="a 4 x 4 x 10 cm box"),
    ObjectType("tower_box", _fixed_box((0.02, 0.02, 0.075)), description="a 4 x 4 x 15 cm box"),
    ObjectType("tall_cylinder", _fixed_cylinder(0.02, 0.075), description="a cylinder 4 cm across, 15 cm tall"),
)

_REGISTRY: Registry[ObjectType] = Registry("object type", ObjectType, BUILTIN_OBJECTS)


def _builder_of(name: str, builder) -> Builder:
    """``(mujoco_name, task_config) -> MujocoObject`` from a MujocoObject class or a ``name -> MujocoObject`` callable."""
    if isinstance(builder, type):
        if not issubclass(builder, MujocoObject):
            raise TypeError(f"object {name!r}: builder class {builder.__name__} is not a robosuite MujocoObject")
        return lambda mujoco_name, config: builder(name=mujoco_name)
    if not callable(builder):
        raise TypeError(f"object {name!r}: builder must be a MujocoObject class or a callable name -> MujocoObject, "
                        f"got {builder!r}")
    return lambda mujoco_name, config: builder(mujoco_name)


def xml_object_builder(path) -> Builder:
    """A builder of robosuite ``MujocoXMLObject``s from the MJCF file ``path`` in robosuite's object layout
    (an ``object`` body and ``bottom_site``, ``top_site``, ``horizontal_radius_site``); checked by
    building it once (``ValueError`` naming the file and what is wrong)."""
    from robosuite.models.objects import MujocoXMLObject

    fname = os.path.abspath(os.fspath(path))
    if not os.path.isfile(fname):
        raise ValueError(f"object xml {fname!r} does not exist")

    def build(name: str, config: Mapping) -> MujocoObject:
        return MujocoXMLObject(fname, name=name, joints=[dict(j) for j in XML_OBJECT_JOINTS], obj_type="all",
                               duplicate_collision_geoms=True)

    try:
        build("check", {})
    except Exception as error:  # robosuite asserts / KeyErrors on a file outside its layout
        raise ValueError(f"object xml {fname!r} is not in robosuite's object layout (an 'object' body, bottom_site, "
                         f"top_site, horizontal_radius_site): {type(error).__name__}: {error}") from None
    return build


def register_object(object_type, builder=None, *, xml=None, overwrite: bool = False, **overrides) -> ObjectType:
    """Add an object type so task specs can name it (``TaskSpec(objects=("my_type", ...))``).

    ``register_object("name", builder)`` (a robosuite ``MujocoObject`` class, made with ``name=``, or a callable
    ``mujoco_name -> MujocoObject``), ``register_object("name", xml="my_object.xml")`` (an MJCF file in
    robosuite's object layout) or ``register_object(ObjectType(...))``.  ``overrides``: other
    [`ObjectType`][tableclean_suite.environments.objects.ObjectType] fields.  Returns the registered type; ``ValueError`` when the name is taken
    and ``overwrite`` is False.
    """
    if isinstance(object_type, ObjectType):
        if builder is not None or xml is not None or overrides:
            raise TypeError("register_object(ObjectType(...)) takes no builder, xml or overrides; set them on the ObjectType")
        return _REGISTRY.register(object_type, overwrite)
    if not isinstance(object_type, str):
        raise TypeError(f"register_object needs an ObjectType or a name, got {object_type!r}")
    if (builder is None) == (xml is None):
        raise TypeError(f"register_object({object_type!r}, ...): give exactly one of a builder and xml=")
    build = xml_object_builder(xml) if xml is not None else _builder_of(object_type, builder)
    return _REGISTRY.register(ObjectType(object_type, build, **overrides), overwrite)


def object_type_names() -> list[str]:
    """Registered object type names, in registration order."""
    return _REGISTRY.names()


def get_object_type(name: str | ObjectType) -> ObjectType:
    """An object type by name; ``ValueError`` naming the registered types when unknown."""
    if isinstance(name, ObjectType):
        return name
    if not isinstance(name, str) or name not in _REGISTRY.names():
        raise ValueError(f"unknown object_type {name!r}; allowed: {', '.join(sorted(object_type_names()))}")
    return _REGISTRY.get(name)


#: Object type name -> [`ObjectType`][tableclean_suite.environments.objects.ObjectType] (a live view of the registry).
OBJECT_TYPES: Mapping[str, ObjectType] = _REGISTRY.view()


def object_names(n_objects: int) -> list[str]:
    """MuJoCo names of M objects: ``"object"`` for one (as the paper scene), ``"object1"``... for more."""
    return [OBJECT_NAME] if n_objects == 1 else [f"{OBJECT_NAME}{j + 1}" for j in range(n_objects)]


def make_object(object_type: str, config: Mapping, name: str = OBJECT_NAME) -> MujocoObject:
    """The object of ``object_type`` named ``name`` built from the task ``config``."""
    kind = get_object_type(object_type)
    obj = kind.build(name, config)
    if not isinstance(obj, MujocoObject):
        raise TypeError(f"object type {kind.name!r}: build returned {type(obj).__name__}, not a robosuite MujocoObject")
    return obj


def make_sponge(half_size, density: float) -> MujocoObject:
    """A light, soft, yellow-green box named ``"sponge"`` with half extents ``half_size`` (3,) [m]."""
    return BoxObject(name=SPONGE_NAME, size=[float(h) for h in half_size], density=density,
                     friction=list(SPONGE_FRICTION), solref=list(SPONGE_SOLREF), rgba=list(SPONGE_RGBA))


def type_geometry(object_type, config):
    """The collision geometry ([`ObjectGeometry`][tableclean_suite.environments.object_geometry.ObjectGeometry]) of ``object_type`` built from task ``config``."""
    from tableclean_suite.environments.object_geometry import object_geometry

    return object_geometry(make_object(object_type, config, "probe"))


def footprint_radius(object_type, geometry) -> float:
    """m, the type's ``footprint_radius`` override, else the footprint of its collision ``geometry``."""
    kind = get_object_type(object_type)
    return geometry.footprint_radius if kind.footprint_radius is None else float(kind.footprint_radius)


def check_holdable(object_type, geometry, open_width: float, gripper: str = "gripper") -> None:
    """``ValueError`` naming the object, its narrowest width and the limit when the open ``gripper`` cannot take it.

    The limit is ``open_width`` (m, the open finger pads' gap) less `GRASP_WIDTH_MARGIN`.
    """
    kind = get_object_type(object_type)
    limit = open_width - GRASP_WIDTH_MARGIN
    if geometry.narrow_width > limit:
        raise ValueError(f"object {kind.name!r} cannot be grasped: its narrowest horizontal width is "
                         f"{geometry.narrow_width * 100:.1f} cm, the open {gripper}'s pad gap {open_width * 100:.1f} cm "
                         f"less a {GRASP_WIDTH_MARGIN * 100:.0f} cm margin allows at most {limit * 100:.1f} cm")
