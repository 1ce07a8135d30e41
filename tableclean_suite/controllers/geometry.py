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


def z_row_entries(quat: np.ndarray) -> tuple[float, float, float]:
    """The last row of [`quat_to_matrix`][tableclean_suite.controllers.geometry.quat_to_matrix] (``quat`` (4,) xyzw)
    as Python floats: the world z of the body frame's axes, all a height needs (the same bits)."""
    q = np.asarray(quat, dtype=float)
    norm = math.sqrt(q.dot(q))
    x, y, z, w = q.tolist()  # divided as Python floats: IEEE division, the bits of numpy's q / norm
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    return 2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)


def clip_scalar(value: float, low: float, high: float) -> float:
    """``float(np.clip(value, low, high))`` for scalars without its ~3 us of dispatch: the same result,
    a NaN ``value`` and the bound's signed zero when ``value`` equals it included (numpy's max, then min)."""
    value = low if low >= value else value
    return float(high if high <= value else value)


def wrap_angle(angle: float) -> float:
    """``angle`` (rad) wrapped to [-pi, pi)."""
    return float((angle + np.pi) % (2 * np.pi) - np.pi)


def gripper_yaw(eef_quat: np.ndarray) -> float:
    """Yaw (rad) of a roughly downward gripper: heading of its x axis in the world xy plane."""
    rot = quat_to_matrix(eef_quat)
    return float(np.arctan2(rot[1, 0], rot[0, 0]))


#: rad, how far a yaw read off a rotation matrix must be from the tolerance for `clear_yaw_verdict` to decide
#: (robosuite's float32 ``mat2quat`` moves the yaw by up to ~6e-6 rad)
YAW_VERDICT_MARGIN = 1e-3
#: the least length of the x axis' horizontal part for `clear_yaw_verdict` to decide (near vertical, the yaw
#: is ill-conditioned)
YAW_VERDICT_MIN_HORIZONTAL = 0.1


def clear_yaw_verdict(rot: np.ndarray, yaw: float, tolerance: float) -> bool | None:
    """Whether the yaw (rad) of rotation matrix ``rot`` (3, 3) is within ``tolerance`` (rad) of ``yaw``, when that is
    clear: None when the yaw's distance from ``yaw`` lies within `YAW_VERDICT_MARGIN` of the tolerance or
    the x axis is near vertical.  A clear verdict is that of [`gripper_yaw`][tableclean_suite.controllers.geometry.gripper_yaw] of the matrix's quaternion from
    robosuite's ``mat2quat`` (an eigen-decomposition in float32), without computing that quaternion."""
    cos_part, sin_part = float(rot[0, 0]), float(rot[1, 0])
    if math.hypot(cos_part, sin_part) < YAW_VERDICT_MIN_HORIZONTAL:
        return None
    gap = abs(wrap_angle(math.atan2(sin_part, cos_part) - yaw))
    if abs(gap - tolerance) <= YAW_VERDICT_MARGIN:
        return None
    return gap <= tolerance


def box_lowest_z(pos: np.ndarray, quat: np.ndarray, half_size: np.ndarray) -> float:
    """World z (m) of the lowest corner of a box with centre ``pos`` (3,), orientation ``quat`` (4,, xyzw)."""
    reach = np.array([abs(entry) for entry in z_row_entries(quat)])  # np.abs of the z row, without its dispatch
    return float(pos[2] - reach.dot(np.asarray(half_size, dtype=float)))


def world_footprint(quat: np.ndarray, half_size: np.ndarray) -> np.ndarray:
    """(2,) half extents along world x and y (m) of an upright box's footprint (its axis-aligned bound)."""
    rot = quat_to_matrix(quat)
    return np.abs(rot[:2, :2]) @ np.asarray(half_size, dtype=float)[:2]
