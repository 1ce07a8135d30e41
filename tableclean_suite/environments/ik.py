"""Deterministic damped-least-squares inverse kinematics for the arm's reset pose.

Used once per (model, segment) to find joint positions that put the gripper site above a segment
with the orientation of the robot's default pose; the result is cached by the environment.
"""

from __future__ import annotations

import mujoco
import numpy as np

#: Damping of the least-squares step (larger: slower but steadier).
IK_DAMPING = 1e-4
#: Maximum iterations and the position [m] / orientation [rad] errors at which to stop.
IK_MAX_ITERATIONS = 300
IK_POS_TOLERANCE = 1e-4
IK_ROT_TOLERANCE = 1e-3


def _orientation_error(current: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Axis-angle-like error (3,) rotating ``current`` (3x3) towards ``target`` (3x3), small-angle form."""
    return 0.5 * sum(np.cross(current[:, i], target[:, i]) for i in range(3))


def solve_site_pose(model: mujoco.MjModel, qpos_addrs, dof_addrs, site_id: int, target_pos, target_mat,
                    q_init) -> np.ndarray:
    """Joint positions (same order as ``qpos_addrs``) placing site ``site_id`` at ``target_pos``/``target_mat``.

    Uses a scratch ``MjData`` (the caller's simulation is not touched), starts at ``q_init``, clamps
    to joint ranges, and raises ``RuntimeError`` when it does not converge.
    """
    data = mujoco.MjData(model)
    qpos_addrs = np.asarray(qpos_addrs)
    dof_addrs = np.asarray(dof_addrs)
    target_pos = np.asarray(target_pos, dtype=float)
    target_mat = np.asarray(target_mat, dtype=float).reshape(3, 3)
    joint_ids = model.dof_jntid[dof_addrs]
    limited = model.jnt_limited[joint_ids].astype(bool)
    low, high = model.jnt_range[joint_ids].T
    q = np.array(q_init, dtype=float)
    jacp = np.zeros((3, model.nv))
    jacr = np.zeros((3, model.nv))
    for _ in range(IK_MAX_ITERATIONS):
        data.qpos[qpos_addrs] = q
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        pos_err = target_pos - data.site_xpos[site_id]
        rot_err = _orientation_error(data.site_xmat[site_id].reshape(3, 3), target_mat)
        if np.linalg.norm(pos_err) < IK_POS_TOLERANCE and np.linalg.norm(rot_err) < IK_ROT_TOLERANCE:
            return q
        mujoco.mj_jacSite(model, data, jacp, jacr, site_id)
        jac = np.vstack([jacp[:, dof_addrs], jacr[:, dof_addrs]])
        err = np.concatenate([pos_err, rot_err])
        step = jac.T @ np.linalg.solve(jac @ jac.T + IK_DAMPING * np.eye(6), err)
        q = q + step
        q[limited] = np.clip(q[limited], low[limited], high[limited])
    raise RuntimeError(f"arm IK did not converge to {target_pos} (last position error {np.linalg.norm(pos_err):.4f} m)")


def site_pose(model: mujoco.MjModel, qpos_addrs, site_id: int, q) -> tuple[np.ndarray, np.ndarray]:
    """World position (3,) and rotation matrix (3, 3) of a site for joint positions ``q``."""
    data = mujoco.MjData(model)
    data.qpos[np.asarray(qpos_addrs)] = q
    mujoco.mj_kinematics(model, data)
    return data.site_xpos[site_id].copy(), data.site_xmat[site_id].reshape(3, 3).copy()
