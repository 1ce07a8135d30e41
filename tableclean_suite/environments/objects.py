"""The graspable task object (by type name) and the sponge."""

from __future__ import annotations

from typing import Callable

import numpy as np
from robosuite.models.objects import BoxObject, CanObject, CylinderObject, MilkObject, MujocoObject
from robosuite.utils.mjcf_utils import CustomMaterial

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


def _red_wood() -> CustomMaterial:
    return CustomMaterial(
        texture="WoodRed",
        tex_name="redwood",
        mat_name="redwood_mat",
        tex_attrib={"type": "cube"},
        mat_attrib={"texrepeat": "1 1", "specular": "0.4", "shininess": "0.1"},
    )


def _box(half_size) -> MujocoObject:
    return BoxObject(name=OBJECT_NAME, size=list(half_size), rgba=list(OBJECT_RGBA), material=_red_wood())


def _cube(half_size) -> MujocoObject:
    side = float(np.min(half_size))  # a cube: the smallest half extent on every axis
    return _box((side, side, side))


def _cylinder(half_size) -> MujocoObject:
    return CylinderObject(name=OBJECT_NAME, size=[float(half_size[0]), float(half_size[2])], rgba=list(OBJECT_RGBA))


#: Object type name -> factory taking the configured half size (3,) [m] (mesh objects ignore it).
OBJECT_TYPES: dict[str, Callable[[np.ndarray], MujocoObject]] = {
    "cube": _cube,
    "box": _box,
    "cylinder": _cylinder,
    "can": lambda half_size: CanObject(name=OBJECT_NAME),
    "milk": lambda half_size: MilkObject(name=OBJECT_NAME),
}


def check_object_type(object_type: str) -> None:
    """Raise ``ValueError`` naming the allowed types when ``object_type`` is unknown."""
    if object_type not in OBJECT_TYPES:
        raise ValueError(f"unknown object_type {object_type!r}; allowed: {sorted(OBJECT_TYPES)}")


def make_object(object_type: str, half_size) -> MujocoObject:
    """The task object of ``object_type`` (see :data:`OBJECT_TYPES`) named ``"object"``."""
    check_object_type(object_type)
    return OBJECT_TYPES[object_type](np.asarray(half_size, dtype=float))


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
