"""Small geometric helpers the skills share (pure NumPy, world frame, quaternions xyzw)."""

from __future__ import annotations

import math

import numpy as np


def quat_to_matrix(quat: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) of a unit quaternion (4,) in robosuite's xyzw order."""
    q = np.asarray(quat, dtype=float)
    # Python floats for the 3x3 entries; q.dot(q) under the root is what np.linalg.norm computes: the same bits
    x, y, z, w = (q / math.sqrt(q.dot(q))).tolist()
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def clip_scalar(value: float, low: float, high: float) -> float:
    """``float(np.clip(value, low, high))`` for scalars without its ~3 us of dispatch: the same result,
    a NaN ``value`` and the bound's signed zero when ``value`` equals it included (numpy's max, then min)."""
    value = low if low >= value else value
    return float(high if high <= value else value)


def gripper_yaw(eef_quat: np.ndarray) -> float:
    """Yaw (rad) of a roughly downward gripper: heading of its x axis in the world xy plane."""
    rot = quat_to_matrix(eef_quat)
    return float(np.arctan2(rot[1, 0], rot[0, 0]))


def box_lowest_z(pos: np.ndarray, quat: np.ndarray, half_size: np.ndarray) -> float:
    """World z (m) of the lowest corner of a box with centre ``pos`` (3,), orientation ``quat`` (4,, xyzw)."""
    reach = np.abs(quat_to_matrix(quat)[2])  # the world z of the box's axes
    return float(pos[2] - reach.dot(np.asarray(half_size, dtype=float)))


def world_footprint(quat: np.ndarray, half_size: np.ndarray) -> np.ndarray:
    """(2,) half extents along world x and y (m) of an upright box's footprint (its axis-aligned bound)."""
    rot = quat_to_matrix(quat)
    return np.abs(rot[:2, :2]) @ np.asarray(half_size, dtype=float)[:2]
