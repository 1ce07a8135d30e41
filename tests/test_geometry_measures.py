"""What the object and gripper geometry modules measure, without a scene (no physics)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tableclean_suite.environments.gripper_geometry import MAX_FINGER_JOINTS, measure_gripper
from tableclean_suite.environments.object_geometry import (
    ObjectGeometry,
    world_lowest_z,
    world_z_range,
)


def _shape() -> ObjectGeometry:
    return ObjectGeometry(np.random.default_rng(3).uniform([-0.03, -0.02, -0.05], [0.04, 0.02, 0.06], (200, 3)))


def test_one_projection_gives_the_same_lowest_and_highest_points_bit_for_bit():
    shape = _shape()
    pos = np.array([0.1, -0.2, 0.83])
    for angles in ([0.0, 0.0, 0.0], [0.3, -0.2, 1.1], [np.pi, 0.0, 0.4]):
        rot = Rotation.from_euler("xyz", angles).as_matrix()
        low, high = world_z_range(shape, pos, rot)
        assert (low, high) == (world_lowest_z(shape, pos, rot), float(pos[2] + np.max(shape.points @ rot[2])))
        assert low < high


def test_extents_and_widths_are_computed_once_and_read_only():
    shape = _shape()
    assert shape.lower is shape.lower and shape.widths() is shape.widths()
    np.testing.assert_array_equal(shape.lower, shape.points.min(axis=0))
    np.testing.assert_array_equal(shape.upper, shape.points.max(axis=0))
    for measure in (shape.lower, shape.upper, shape.half_size, shape.widths()):
        with pytest.raises(ValueError, match="read-only"):
            measure[0] = 1.0
    assert shape.narrow_width == pytest.approx(float(shape.widths().min()))


class _Hand:
    """A robosuite-like gripper model with more finger joints than a two-finger gripper has."""

    joints = [f"gripper0_joint_{k}" for k in range(MAX_FINGER_JOINTS + 5)]


def test_a_gripper_with_too_many_finger_joints_is_refused_naming_it():
    with pytest.raises(ValueError, match=rf"gripper _Hand has {MAX_FINGER_JOINTS + 5} finger joints; .* at most "
                                         rf"{MAX_FINGER_JOINTS}"):
        measure_gripper(None, np.zeros(0), _Hand(), "gripper0_grip_site")
