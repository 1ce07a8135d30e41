"""Vectorised contact and wiping geometry on MuJoCo's flat arrays, cheap enough for every physics substep."""

from __future__ import annotations

import numpy as np


def geom_mask(n_geoms: int, geom_ids) -> np.ndarray:
    """Bool lookup (n_geoms,) that is True at ``geom_ids``."""
    mask = np.zeros(n_geoms, dtype=bool)
    mask[np.asarray(list(geom_ids), dtype=int)] = True
    return mask


def box_lowest_z(pos: np.ndarray, mat: np.ndarray, half_size) -> float:
    """World z of the lowest corner of a box with centre ``pos`` (3,), rotation ``mat`` (9,) row-major."""
    return float(pos[2] - (abs(mat[6]) * half_size[0] + abs(mat[7]) * half_size[1] + abs(mat[8]) * half_size[2]))


def markers_under_box(marker_xyz: np.ndarray, box_pos: np.ndarray, box_mat: np.ndarray,
                      half_size, reach: float) -> np.ndarray:
    """Bool (N,): markers whose centre lies within ``reach`` of the box on all three of its local axes.

    Args:
        marker_xyz: (N, 3) world positions of the markers.
        box_pos: (3,) world position of the box centre.
        box_mat: (9,) or (3, 3) world rotation matrix of the box (row-major, as MuJoCo's ``xmat``).
        half_size: (3,) half extents of the box along its local axes [m].
        reach: slack added to every half extent [m], >= 0.
    """
    local = (marker_xyz - box_pos) @ np.reshape(box_mat, (3, 3))  # R^T p for every marker
    return np.all(np.abs(local) <= np.asarray(half_size) + reach, axis=1)
