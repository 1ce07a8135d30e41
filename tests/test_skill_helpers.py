"""The skills' per-step helpers give numpy's results bit for bit: ``clip_scalar`` as ``np.clip`` (NaN and signed
zeros included), the objects' height extremes as ``object_geometry``'s."""

from __future__ import annotations

import itertools
import math

import numpy as np

from tableclean_suite.controllers.geometry import clip_scalar, quat_to_matrix


def same_float(a: float, b: float) -> bool:
    """Equal bits as floats: both NaN, or equal with the same sign (so 0.0 and -0.0 differ)."""
    return (math.isnan(a) and math.isnan(b)) or (a == b and math.copysign(1.0, a) == math.copysign(1.0, b))


def test_clip_scalar_is_np_clip_bit_for_bit():
    rng = np.random.default_rng(3)
    values = [-1.0, -0.0, 0.0, 0.5, 1.0, 2.0, math.nan, math.inf, -math.inf, np.float64(-0.0), *rng.normal(size=300)]
    bounds = [(-0.0, 1.0), (0.0, 1.0), (-1.0, -0.0), (0.5, 0.5), (0.0, 0.0), (-0.0, -0.0),
              *(tuple(sorted(rng.normal(size=2))) for _ in range(30))]
    for value, (low, high) in itertools.product(values, bounds):
        expected = float(np.clip(value, low, high))
        got = clip_scalar(value, low, high)
        assert type(got) is float and same_float(got, expected), (value, low, high, got, expected)


def test_object_heights_are_world_lowest_and_highest_z_bit_for_bit():
    """skill.object_heights (the hover height's tops and bottoms) gives object_geometry's world_lowest_z /
    world_z_range at each object's pose: random point clouds of 1 to 300 points, poses and unnormalised quaternions."""
    from tableclean_suite.controllers.skill import object_heights
    from tableclean_suite.environments.object_geometry import ObjectGeometry, world_lowest_z, world_z_range

    rng = np.random.default_rng(6)
    for _ in range(300):
        count = int(rng.integers(1, 4))
        shapes = tuple(ObjectGeometry(rng.normal(size=(int(rng.integers(1, 300)), 3)) * 0.05) for _ in range(count))
        info = {"objects_pos": rng.normal(size=(count, 3)), "objects_quat": rng.normal(size=(count, 4)),
                "objects_geometry": shapes, "objects_half_size": np.ones((count, 3))}
        tops, bottoms = object_heights(info)
        for j, shape in enumerate(shapes):
            rot = quat_to_matrix(info["objects_quat"][j])
            assert tops[j] == world_z_range(shape, info["objects_pos"][j], rot)[1]
            assert bottoms[j] == world_lowest_z(shape, info["objects_pos"][j], rot)
