"""What ``TableClean.skill_info()`` returns: a [`SkillInfo`][tableclean_suite.environments.skill_info.SkillInfo], a ``dict`` whose costlier per-step values
(``LAZY_SKILL_INFO``: the grip site's quaternion, the grasp flags, the dirt, ...) are computed on first read.

Whole-dict operations (``in``, ``len``, iteration, ``keys()``, ``==``, ``copy()``, ``repr``, pickling) see
every key, so it behaves as a plain dict.  A lazy key read after the simulation advanced raises
[`StaleSkillInfoError`][tableclean_suite.environments.skill_info.StaleSkillInfoError] (call ``skill_info()`` again) rather than mixing two states.
"""

from __future__ import annotations

from typing import Any, Callable, Mapping, NamedTuple

import numpy as np
from robosuite.utils.transform_utils import mat2quat

from tableclean_suite.environments.object_geometry import frozen

#: A lazy key's function: ``fill(owner, info)`` stores that key (and any others it computes alike) in ``info``.
Filler = Callable[[Any, "SkillInfo"], None]


class SceneNotResetError(RuntimeError):
    """``skill_info()`` before the first ``reset()``: the simulation's positions are not computed yet."""


class StaleSkillInfoError(RuntimeError):
    """A lazy key of a [`SkillInfo`][tableclean_suite.environments.skill_info.SkillInfo] was read after the simulation it describes advanced."""


class SkillInfo(dict):
    """``skill_info()``'s dict: present keys as a dict, the keys of ``lazy`` computed on first read (build with
    [`create`][tableclean_suite.environments.skill_info.SkillInfo.create])."""

    __slots__ = ("_owner", "_lazy", "_clock", "_stamp")

    @classmethod
    def create(cls, values: Mapping[str, Any], owner: Any, lazy: Mapping[str, Filler],
               clock: Callable[[], Any], stamp: Any = None) -> "SkillInfo":
        """A mapping of ``values`` (copied shallowly) plus ``lazy``'s keys (each filled by ``lazy[key](owner, info)``),
        valid while ``clock()`` (a comparable stamp of the simulation state) returns ``stamp`` (None: now)."""
        info = cls(values)
        info._owner, info._lazy, info._clock, info._stamp = owner, lazy, clock, clock() if stamp is None else stamp
        return info

    def __missing__(self, key):
        fill = self._lazy.get(key)
        if fill is None:
            raise KeyError(key)
        now = self._clock()
        if now != self._stamp:
            raise StaleSkillInfoError(f"skill_info key {key!r} read at simulation state {now} from a skill_info() "
                                      f"of state {self._stamp}; call skill_info() again")
        fill(self._owner, self)
        return dict.__getitem__(self, key)

    def materialize(self) -> "SkillInfo":
        """Compute every lazy key not computed yet (a plain dict's contents from then on); returns ``self``."""
        for key in list(self._lazy):
            if not dict.__contains__(self, key):  # (a filler may have stored it with an earlier one)
                self[key]
        self._lazy = {}
        return self

    def __contains__(self, key) -> bool:
        return dict.__contains__(self, key) or key in self._lazy

    def get(self, key, default=None):
        return self[key] if key in self else default

    def setdefault(self, key, default=None):
        if key in self:
            return self[key]
        self[key] = default
        return default

    def copy(self) -> dict:
        """A plain ``dict`` of every key."""
        return dict(dict.items(self.materialize()))

    def __eq__(self, other) -> bool:
        if isinstance(other, SkillInfo):
            other.materialize()
        return dict.__eq__(self.materialize(), other)

    def __ne__(self, other) -> bool:
        equal = self.__eq__(other)
        return equal if equal is NotImplemented else not equal

    __hash__ = None

    def __reduce__(self):
        return dict, (self.copy(),)


def _after_materialize(name: str):
    """``dict``'s method ``name`` run once every lazy key is computed: whole-dict operations and removals see
    every key (``dict(info)``, ``info | other`` and ``{**info}`` go through ``keys()``)."""
    method = getattr(dict, name)

    def whole(self, *args):
        return method(self.materialize(), *args)

    whole.__name__ = whole.__qualname__ = name
    return whole


for _name in ("__iter__", "__reversed__", "__len__", "keys", "items", "values", "__repr__", "__delitem__", "pop",
              "popitem", "clear"):
    setattr(SkillInfo, _name, _after_materialize(_name))


# -- what TableClean.skill_info() reads --------------------------------------------------------
#: Indexes of a MuJoCo wxyz quaternion's entries in robosuite's xyzw order.
XYZW_FROM_WXYZ = np.array([1, 2, 3, 0], dtype=np.intp)


class DataViews(NamedTuple):
    """Views into one MuJoCo data (kept: each mjData attribute access builds a new view) and the precomputed
    gathers of the rows ``skill_info()`` reports (quaternions in xyzw order)."""

    eef_pos: np.ndarray  #: (3,) grip-site position [m]
    eef_xmat: np.ndarray  #: (9,) grip-site rotation matrix, row-major
    qpos: np.ndarray  #: (nq,)
    qvel: np.ndarray  #: (nv,)
    fingers: np.ndarray  #: finger joints' qpos indexes
    xpos: np.ndarray  #: (nbody * 3,) body positions [m]
    xquat: np.ndarray  #: (nbody * 4,) body quaternions, wxyz
    objects_pos: np.ndarray  #: (M, 3) indexes into xpos
    objects_quat: np.ndarray  #: (M, 4) indexes into xquat, xyzw order
    sponge_pos: np.ndarray  #: (3,) indexes into xpos
    sponge_quat: np.ndarray  #: (4,) indexes into xquat, xyzw order

    @classmethod
    def of(cls, data, eef_site: int, fingers, object_bodies, sponge_body: int) -> "DataViews":
        """The views of the raw ``mujoco.MjData`` ``data``: the grip site ``eef_site``, the finger joints'
        qpos indexes ``fingers``, the (M,) objects' bodies and the sponge's."""
        objects = np.asarray(object_bodies, dtype=np.intp)[:, None]
        sponge = np.intp(sponge_body)
        return cls(eef_pos=data.site_xpos[eef_site], eef_xmat=data.site_xmat[eef_site], qpos=data.qpos,
                   qvel=data.qvel, fingers=np.asarray(fingers, dtype=int), xpos=data.xpos.reshape(-1),
                   xquat=data.xquat.reshape(-1), objects_pos=objects * 3 + np.arange(3),
                   objects_quat=objects * 4 + XYZW_FROM_WXYZ, sponge_pos=sponge * 3 + np.arange(3),
                   sponge_quat=sponge * 4 + XYZW_FROM_WXYZ)


def constant_values(objects, gripper, config: Mapping, geometry, sponge_half_size, robot_base_pos) -> dict:
    """The ``skill_info()`` values fixed while the model, the episode's config and geometry stay: from the
    scene's ``ObjectMeasures``, the gripper's ``GripperGeometry``, the config and its ``SceneGeometry``, the
    sponge's (3,) half size [m] and the arm's (3,) root body position [m]."""
    return {
        "object_half_size": frozen(objects.half_sizes[0]),
        "object_rest_z": float(objects.rest_z[0]),
        "objects_half_size": frozen(objects.half_sizes),
        "objects_rest_z": frozen(objects.rest_z),
        "object_types": objects.types,
        "objects_geometry": objects.geometries,
        "objects_footprint": frozen(objects.footprints),
        "gripper_open_width": gripper.open_width,
        "gripper_palm_height": gripper.palm_height,
        "gripper_hand_reach": gripper.hand_reach,
        "gripper_hand_half_width": gripper.hand_half_width,
        "object_spacing": float(config["object_spacing"]),
        "object_clearance": float(config["object_clearance"]),
        "sponge_half_size": frozen(sponge_half_size),
        "sponge_home_pos": frozen(geometry.sponge_home_pos),
        "segment_centers": frozen(geometry.segment_centers),
        "segment_half_sizes": frozen(geometry.segment_half_sizes),
        "table_top_z": geometry.table_top_z,
        "table_center": frozen(geometry.table_center),
        "table_half_size": frozen(geometry.table_half_size),
        "robot_base_pos": frozen(robot_base_pos),
    }


class SkillInfoReader:
    """Builds the [SkillInfo][tableclean_suite.environments.skill_info.SkillInfo] of one simulation data.

    Args:
        views: the data's [DataViews][tableclean_suite.environments.skill_info.DataViews].
        grasped: () -> bool (M + 1,) the grasp flags (objects, then the sponge).
        dirt_fraction: () -> (N,) each segment's dirty fraction.
        clock: () -> a comparable stamp of the simulation state (a lazy key is computed only while it holds).
    """

    __slots__ = ("views", "grasped", "dirt_fraction", "clock")

    def __init__(self, views: DataViews, grasped: Callable[[], np.ndarray], dirt_fraction: Callable[[], np.ndarray],
                 clock: Callable[[], Any]):
        self.views, self.grasped, self.dirt_fraction, self.clock = views, grasped, dirt_fraction, clock

    def read(self, constants: Mapping[str, Any], stamp: Any) -> SkillInfo:
        """``constants`` plus this state's cheap values, the others (``LAZY_SKILL_INFO``) read on first use;
        ``stamp`` is ``clock()`` now."""
        views = self.views
        info = SkillInfo.create(constants, self, LAZY_SKILL_INFO, self.clock, stamp)
        info["eef_pos"] = views.eef_pos.copy()
        info["gripper_qpos"] = views.qpos[views.fingers]  # fancy indexing copies
        info["objects_pos"] = views.xpos[views.objects_pos]
        return info

    # the lazy keys: each computes its group on the first read
    def _eef_quat(self, info: SkillInfo) -> None:
        info["eef_quat"] = mat2quat(np.array(self.views.eef_xmat).reshape(3, 3)).astype(float)

    def _eef_rot(self, info: SkillInfo) -> None:
        info["eef_rot"] = np.array(self.views.eef_xmat).reshape(3, 3)

    def _object_pos(self, info: SkillInfo) -> None:
        info["object_pos"] = self.views.xpos[self.views.objects_pos[0]]  # fancy indexing copies

    def _objects_quat(self, info: SkillInfo) -> None:
        info["objects_quat"] = self.views.xquat[self.views.objects_quat]  # xyzw rows

    def _object_quat(self, info: SkillInfo) -> None:
        info["object_quat"] = self.views.xquat[self.views.objects_quat[0]]

    def _grasp_flags(self, info: SkillInfo) -> None:
        grasped = self.grasped()
        info["objects_grasped"] = grasped[:-1]
        flags = grasped.tolist()  # Python bools, as bool() of the entries
        info["object_grasped"] = flags[0]
        info["sponge_grasped"] = flags[-1]

    def _sponge(self, info: SkillInfo) -> None:
        views = self.views
        info["sponge_pos"] = views.xpos[views.sponge_pos]
        info["sponge_quat"] = views.xquat[views.sponge_quat]  # xyzw

    def _dirt(self, info: SkillInfo) -> None:
        info["dirt_fraction"] = self.dirt_fraction()

    def _qvel(self, info: SkillInfo) -> None:
        info["qvel"] = np.array(self.views.qvel)


#: ``skill_info()``'s keys computed on first read, by group.
LAZY_SKILL_INFO: dict[str, Filler] = {
    key: fill
    for keys, fill in (
        (("object_pos",), SkillInfoReader._object_pos),
        (("eef_quat",), SkillInfoReader._eef_quat),
        (("eef_rot",), SkillInfoReader._eef_rot),
        (("objects_quat",), SkillInfoReader._objects_quat),
        (("object_quat",), SkillInfoReader._object_quat),
        (("objects_grasped", "object_grasped", "sponge_grasped"), SkillInfoReader._grasp_flags),
        (("sponge_pos", "sponge_quat"), SkillInfoReader._sponge),
        (("dirt_fraction",), SkillInfoReader._dirt),
        (("qvel",), SkillInfoReader._qvel),
    )
    for key in keys
}
