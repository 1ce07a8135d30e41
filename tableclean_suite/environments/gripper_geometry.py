"""What the mounted gripper's model says: how wide it opens, and how far its hand and wrist reach about the grip
site ([`GripperGeometry`][tableclean_suite.environments.gripper_geometry.GripperGeometry]), read from the compiled
scene (a copy of its kinematics), never from per-gripper constants.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import mujoco
import numpy as np

from tableclean_suite.environments.object_geometry import collision_points

#: Largest gap [m] ``mj_geomDistance`` looks for between the finger pads (far beyond any gripper's opening).
MAX_PAD_GAP = 0.5
#: Most finger joints a gripper may have: each is tried at both ends of its range (2^n poses);
#: robosuite's two-finger grippers have 2 (Panda, Rethink) to 6 (Robotiq 85 and 140, xArm7).
MAX_FINGER_JOINTS = 6


@dataclass(frozen=True)
class GripperGeometry:
    """Attributes, in metres (heights along the grip site's approach axis, which points down when the skills grasp):
    ``open_width``, the largest gap between the finger pads (``mj_geomDistance``) over the ends of the finger
    joints' ranges (what an object's narrow side must pass between); ``palm_height``, how far above the grip site
    the hand's (the non-finger geoms') lowest collision point lies (an object's top stays below it while the
    fingers close); ``hand_reach``, how far the hand reaches sideways from the grip site's axis;
    ``hand_half_width``, how far it reaches across the fingers' closing axis (the grip site's y)."""

    open_width: float
    palm_height: float
    hand_reach: float
    hand_half_width: float
    #: (K,) heights [m] above the grip site, ascending, of the collision points of every body fixed to it without a
    #: joint (the Panda's hand, flange, link 7); with `wrist_half_widths` (K,) [m]: the most any point at or below it
    #: reaches across the fingers' closing axis (see [`wrist_half_width`][tableclean_suite.environments.gripper_geometry.wrist_half_width]).
    wrist_heights: tuple = ()
    wrist_half_widths: tuple = ()


def wrist_half_width(geometry: GripperGeometry, height: float) -> float:
    """How far [m] across the fingers' closing axis (the grip site's y, either side) the hand and every link rigidly
    fixed to it reach at or below ``height`` [m] above the grip site: what a neighbour whose top is ``height``
    above the grip site can meet beside the hand.  0 when no collision point is that low."""
    k = int(np.searchsorted(np.asarray(geometry.wrist_heights, dtype=float), float(height), side="right"))
    return float(geometry.wrist_half_widths[k - 1]) if k > 0 else 0.0


def rigid_bodies(model: mujoco.MjModel, body: int) -> list[int]:
    """Ids of the bodies rigidly fixed to ``body``: those of its subtree root's rigid group (walked up to the first
    body with a joint, or the world's child), with no joint between them and it."""

    def root(b: int) -> int:
        while model.body_jntnum[b] == 0 and model.body_parentid[b] != 0:
            b = int(model.body_parentid[b])
        return b

    mine = root(int(body))
    return [b for b in range(1, model.nbody) if root(b) == mine]


def measure_gripper(model: mujoco.MjModel, qpos: np.ndarray, gripper, grip_site: str) -> GripperGeometry:
    """The [`GripperGeometry`][tableclean_suite.environments.gripper_geometry.GripperGeometry] of robosuite gripper model ``gripper`` mounted in ``model`` (arm at ``qpos``).

    A joint that a joint equality ties to a finger joint (a linkage's follower) moves with it as the equality says.

    Raises ``ValueError`` naming the gripper when it has more than `MAX_FINGER_JOINTS` finger joints
    (a hand, not a two-finger gripper: its open width would be measured over some of its joints only).
    """
    if len(gripper.joints) > MAX_FINGER_JOINTS:
        raise ValueError(f"gripper {type(gripper).__name__} has {len(gripper.joints)} finger joints; the skills "
                         f"measure grippers with at most {MAX_FINGER_JOINTS} (two-finger grippers)")
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    joints = [model.joint(name).id for name in gripper.joints]
    ranges = [model.jnt_range[j] for j in joints]
    left = [model.geom(n).id for n in gripper.important_geoms["left_fingerpad"]]
    right = [model.geom(n).id for n in gripper.important_geoms["right_fingerpad"]]
    # joints a joint equality ties to a finger joint (a linkage's followers): y - y0 = poly(x - x0), MuJoCo's rule
    couplings = [(model.jnt_qposadr[model.eq_obj1id[e]], model.jnt_qposadr[model.eq_obj2id[e]],
                  model.eq_data[e][4::-1]) for e in range(model.neq)
                 if model.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT and model.eq_obj2id[e] in joints]
    fromto = np.zeros(6)
    widest = 0.0
    for ends in itertools.product((0, 1), repeat=len(joints)):
        for joint, limits, end in zip(joints, ranges, ends):
            data.qpos[model.jnt_qposadr[joint]] = limits[end]
        for _ in couplings:  # as often as there are couplings: a chain of them settles
            for follower, leader, poly in couplings:
                data.qpos[follower] = model.qpos0[follower] + np.polyval(poly, data.qpos[leader] - model.qpos0[leader])
        mujoco.mj_kinematics(model, data)
        gap = min(mujoco.mj_geomDistance(model, data, a, b, MAX_PAD_GAP, fromto) for a in left for b in right)
        widest = max(widest, float(gap))
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    site = model.site(grip_site).id
    fingers = {model.geom(n).id for key in ("left_finger", "right_finger") for n in gripper.important_geoms[key]}
    rigid = set(rigid_bodies(model, int(model.site_bodyid[site])))  # the hand and the links fixed to it
    colliding = [g for g in range(model.ngeom) if model.geom_contype[g] or model.geom_conaffinity[g]]
    hand = [g for g in colliding if model.geom(g).name.startswith(gripper.naming_prefix) and g not in fingers]
    wrist = [g for g in colliding if int(model.geom_bodyid[g]) in rigid]
    # heights above the grip site along its approach axis (its z axis, which points down when the skills grasp)
    approach = data.site_xmat[site].reshape(3, 3)[:, 2]
    across = data.site_xmat[site].reshape(3, 3)[:, 1]
    relative = {}  # geom -> (K, 3) collision points [m] relative to the grip site, in world axes
    for geom in {*hand, *wrist}:
        body = int(model.geom_bodyid[geom])
        local = collision_points(model, data, body, [geom])  # in the geom's body frame
        relative[geom] = data.xpos[body] + local @ data.xmat[body].reshape(3, 3).T - data.site_xpos[site]
    palm = min(float(np.min(-relative[g] @ approach)) for g in hand)
    reach = max(float(np.max(np.linalg.norm(relative[g] - np.outer(relative[g] @ approach, approach), axis=1)))
                for g in hand)
    half_width = max(float(np.max(np.abs(relative[g] @ across))) for g in hand)
    levels = [-relative[g] @ approach for g in wrist]
    across_all = [np.abs(relative[g] @ across) for g in wrist]
    order = np.argsort(np.concatenate(levels), kind="stable") if levels else np.zeros(0, dtype=int)
    wrist_heights = np.concatenate(levels)[order] if levels else np.zeros(0)
    wrist_widths = np.maximum.accumulate(np.concatenate(across_all)[order]) if levels else np.zeros(0)
    return GripperGeometry(open_width=widest, palm_height=palm, hand_reach=reach, hand_half_width=half_width,
                           wrist_heights=tuple(float(h) for h in wrist_heights),
                           wrist_half_widths=tuple(float(w) for w in wrist_widths))
