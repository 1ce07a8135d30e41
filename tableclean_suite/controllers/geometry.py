"""Small geometric helpers the skills share (pure NumPy, world frame, quaternions xyzw)."""

from __future__ import annotations

import numpy as np

#: Tolerance (m) under which two horizontal half extents count as equal (a square footprint).
SQUARE_TOLERANCE = 1e-3


def quat_to_matrix(quat: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) of a unit quaternion (4,) in robosuite's xyzw order."""
    x, y, z, w = np.asarray(quat, dtype=float) / np.linalg.norm(quat)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def wrap_angle(angle: float) -> float:
    """``angle`` (rad) wrapped to [-pi, pi)."""
    return float((angle + np.pi) % (2 * np.pi) - np.pi)


def gripper_yaw(eef_quat: np.ndarray) -> float:
    """Yaw (rad) of a roughly downward gripper: heading of its x axis in the world xy plane."""
    rot = quat_to_matrix(eef_quat)
    return float(np.arctan2(rot[1, 0], rot[0, 0]))


def grasp_yaw(body_quat: np.ndarray, half_size: np.ndarray, nominal_yaw: float) -> float:
    """Gripper yaw (rad) whose fingers close across the shorter horizontal side of a box.

    The Panda's fingers close along the x axis of its grip site, so that axis is
    aligned with the box's shorter horizontal axis.  Of the equivalent yaws
    (every half turn; every quarter turn for a square footprint) the one closest
    to ``nominal_yaw`` is returned, so the wrist never winds up.

    Args:
        body_quat: (4,) xyzw orientation of the box (assumed upright).
        half_size: (3,) half extents of the box in its own frame (m).
        nominal_yaw: preferred gripper yaw (rad), e.g. the current one.
    """
    rot = quat_to_matrix(body_quat)
    box_yaw = float(np.arctan2(rot[1, 0], rot[0, 0]))
    hx, hy = float(half_size[0]), float(half_size[1])
    if abs(hx - hy) <= SQUARE_TOLERANCE:
        period = 0.5 * np.pi
        base = box_yaw
    else:
        period = np.pi
        # fingers (gripper x) across the short side: short side along box y -> turn a quarter
        base = box_yaw + 0.5 * np.pi if hx > hy else box_yaw
    offset = wrap_angle(nominal_yaw - base)
    turns = np.round(offset / period)
    return wrap_angle(base + turns * period)


def box_lowest_z(pos: np.ndarray, quat: np.ndarray, half_size: np.ndarray) -> float:
    """World z (m) of the lowest corner of a box with centre ``pos`` (3,), orientation ``quat`` (4,, xyzw)."""
    rot = quat_to_matrix(quat)
    return float(pos[2] - np.abs(rot[2]) @ np.asarray(half_size, dtype=float))


def world_footprint(quat: np.ndarray, half_size: np.ndarray) -> np.ndarray:
    """(2,) half extents along world x and y (m) of an upright box's footprint (its axis-aligned bound)."""
    rot = quat_to_matrix(quat)
    return np.abs(rot[:2, :2]) @ np.asarray(half_size, dtype=float)[:2]
