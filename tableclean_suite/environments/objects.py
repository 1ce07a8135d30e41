"""Graspable object types (a registry users extend) and the sponge.

A task spec names its objects' types (``TaskSpec.objects``, e.g. ``("box", "cylinder")``); the
scene builds each from this registry.  An :class:`ObjectType` says everything that differs
between object types, so no skill or scene code branches on a type name:

- ``build(name, config)``: a robosuite :class:`~robosuite.models.objects.MujocoObject` named
  ``name`` (``config`` is the env's task config, e.g. for ``object_half_size``);
- the grasp: ``grasp_depth`` (m below the object's centre at which the grip site closes),
  ``approach_clearance`` (m the open fingertips stay above the object's top while hovering
  over it), ``yaw_rule`` (:data:`YAW_RULES`: ``"short_side"`` closes the fingers across the
  shorter horizontal side, ``"any"`` keeps the gripper's nominal yaw, for round objects);
- the footprint: ``footprint_radius`` (m, the radius of a disc covering the object seen from
  above), used to place objects apart and to find a free spot for a place.

Adding a type from outside the package::

    from robosuite.models.objects import BoxObject
    from tableclean_suite.environments.objects import ObjectType, register_object

    register_object(ObjectType("flat_box", lambda name, config: BoxObject(name=name, size=[0.03, 0.02, 0.015]),
                               footprint_radius=0.036))
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np
from robosuite.models.objects import BoxObject, BreadObject, CanObject, CylinderObject, MujocoObject
from robosuite.utils.mjcf_utils import CustomMaterial

from tableclean_suite.registry import Registry

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

_NAME_PATTERN = re.compile(r"^[a-z][a-z0-9_]*$")

Builder = Callable[[str, Mapping], MujocoObject]


@dataclass(frozen=True)
class ObjectType:
    """A graspable object type (see the module docstring).

    Attributes:
        name: registry key, lower_snake (``"box"``).
        build: ``(mujoco_name, task_config) -> MujocoObject`` with one free joint.
        footprint_radius: m, radius of a disc covering the object seen from above (> 0).
        grasp_depth: m below the object's centre at which the grip site closes (raised by the
            skills so the fingertips stay clear of the table).
        approach_clearance: m between the open fingertips and the object's top while hovering.
        yaw_rule: one of :data:`YAW_RULES`.
        description: one line for listings.
    """

    name: str
    build: Builder
    footprint_radius: float
    grasp_depth: float = 0.0
    approach_clearance: float = 0.01
    yaw_rule: str = "short_side"
    description: str = field(default="", compare=False)

    def __post_init__(self):
        if not isinstance(self.name, str) or not _NAME_PATTERN.match(self.name):
            raise ValueError(f"object type name must be lower_snake (e.g. 'flat_box'), got {self.name!r}")
        if not callable(self.build):
            raise TypeError(f"object type {self.name!r}: build must be callable (name, task_config) -> MujocoObject")
        if not (isinstance(self.footprint_radius, (int, float)) and self.footprint_radius > 0):
            raise ValueError(f"object type {self.name!r}: footprint_radius must be > 0 m, got {self.footprint_radius!r}")
        for key in ("grasp_depth", "approach_clearance"):
            if not isinstance(getattr(self, key), (int, float)) or not math.isfinite(getattr(self, key)):
                raise ValueError(f"object type {self.name!r}: {key} must be a finite number [m], got {getattr(self, key)!r}")
        if self.yaw_rule not in YAW_RULES:
            raise ValueError(f"object type {self.name!r}: unknown yaw_rule {self.yaw_rule!r}; allowed: {', '.join(YAW_RULES)}")

    def grasp(self) -> dict:
        """The grasp parameters the skills read (``grasp_depth``, ``approach_clearance``, ``yaw_rule``)."""
        return {"grasp_depth": self.grasp_depth, "approach_clearance": self.approach_clearance,
                "yaw_rule": self.yaw_rule}


def _red_wood() -> CustomMaterial:
    return CustomMaterial(
        texture="WoodRed",
        tex_name="redwood",
        mat_name="redwood_mat",
        tex_attrib={"type": "cube"},
        mat_attrib={"texrepeat": "1 1", "specular": "0.4", "shininess": "0.1"},
    )


def _half_size(config: Mapping) -> np.ndarray:
    return np.asarray(config["object_half_size"], dtype=float)


def _box(name: str, config: Mapping) -> MujocoObject:
    return BoxObject(name=name, size=list(_half_size(config)), rgba=list(OBJECT_RGBA), material=_red_wood())


def _cube(name: str, config: Mapping) -> MujocoObject:
    side = float(np.min(_half_size(config)))  # a cube: the smallest half extent on every axis
    return BoxObject(name=name, size=[side] * 3, rgba=list(OBJECT_RGBA), material=_red_wood())


def _cylinder(name: str, config: Mapping) -> MujocoObject:
    half = _half_size(config)
    return CylinderObject(name=name, size=[float(half[0]), float(half[2])], rgba=list(CYLINDER_RGBA))


#: Disc radius covering the default 4.5 cm cube seen from above (half diagonal) [m].
_CUBE_FOOTPRINT = 0.0225 * math.sqrt(2)

BUILTIN_OBJECTS = (
    ObjectType("box", _box, _CUBE_FOOTPRINT, description="today's red wooden cube (object_half_size)"),
    ObjectType("cube", _cube, _CUBE_FOOTPRINT, description="alias of box with equal sides (the paper-era name)"),
    ObjectType("cylinder", _cylinder, 0.0225, yaw_rule="any",
               description="upright blue cylinder, radius object_half_size[0], half height object_half_size[2]"),
    # robosuite's can: 5 cm across, 12 cm tall; gripped 1 cm above its centre so the carried can clears the table
    ObjectType("can", lambda name, config: CanObject(name=name), 0.025, grasp_depth=-0.01, yaw_rule="any",
               description="robosuite's CanObject (5 cm diameter, 12 cm tall)"),
    ObjectType("bread", lambda name, config: BreadObject(name=name), 0.03 * math.sqrt(2),
               description="robosuite's BreadObject (6 x 6 x 9 cm bounding box)"),
)

_REGISTRY: Registry[ObjectType] = Registry("object type", ObjectType, BUILTIN_OBJECTS)


def register_object(object_type: ObjectType, overwrite: bool = False) -> ObjectType:
    """Add an object type so task specs can name it (``TaskSpec(objects=("my_type", ...))``)."""
    return _REGISTRY.register(object_type, overwrite)


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


class _ObjectTypes(Mapping):
    """Read-only name -> :class:`ObjectType` view of the registry (the paper-era ``OBJECT_TYPES``)."""

    def __getitem__(self, name):
        return get_object_type(name)

    def __iter__(self):
        return iter(object_type_names())

    def __len__(self):
        return len(object_type_names())


#: Object type name -> :class:`ObjectType` (a live view of the registry).
OBJECT_TYPES: Mapping[str, ObjectType] = _ObjectTypes()


def check_object_type(object_type: str) -> None:
    """Raise ``ValueError`` naming the allowed types when ``object_type`` is unknown."""
    get_object_type(object_type)


def object_names(n_objects: int) -> list[str]:
    """MuJoCo names of M objects: ``"object"`` for one (as the paper scene), ``"object1"``... for more."""
    return [OBJECT_NAME] if n_objects == 1 else [f"{OBJECT_NAME}{j + 1}" for j in range(n_objects)]


def make_object(object_type: str, config_or_half_size, name: str = OBJECT_NAME) -> MujocoObject:
    """The object of ``object_type`` named ``name``; the second argument is the task config (or a half size (3,))."""
    kind = get_object_type(object_type)
    config = config_or_half_size
    if not isinstance(config, Mapping):
        config = {"object_half_size": np.asarray(config_or_half_size, dtype=float)}
    obj = kind.build(name, config)
    if not isinstance(obj, MujocoObject):
        raise TypeError(f"object type {kind.name!r}: build returned {type(obj).__name__}, not a robosuite MujocoObject")
    return obj


def make_sponge(half_size, density: float) -> MujocoObject:
    """A light, soft, yellow-green box named ``"sponge"`` with half extents ``half_size`` (3,) [m]."""
    return BoxObject(
        name=SPONGE_NAME,
        size=[float(h) for h in half_size],
        density=density,
        friction=list(SPONGE_FRICTION),
        solref=list(SPONGE_SOLREF),
        rgba=list(SPONGE_RGBA),
    )
