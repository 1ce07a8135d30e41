"""The compiled contact kernels against the MuJoCo bindings they stand in for."""

import mujoco
import numpy as np

from tableclean_suite.environments.contact_kernels import (
    LOOKUP_BODY,
    LOOKUP_PADS,
    PAD_A,
    PAD_B,
    grasped_bodies,
)

SCENE = """
<mujoco>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="a" pos="0 0 0.049"><freejoint/><geom name="box_a" type="box" size="0.05 0.05 0.05" mass="1"/></body>
    <body name="b" pos="0.3 0 0.099"><freejoint/><geom name="box_b" type="box" size="0.1 0.1 0.1" mass="3"/></body>
  </worldbody>
</mujoco>
"""


def _pressed_scene():
    model = mujoco.MjModel.from_xml_string(SCENE)
    data = mujoco.MjData(model)
    for _ in range(20):
        mujoco.mj_step(model, data)
    return model, data


#: Random contact sets :func:`test_grasped_bodies_is_both_pads_touching_each_body` checks.
GRASP_CASES = 200


def _pairs(geom: np.ndarray, mask_a: np.ndarray, mask_b: np.ndarray) -> np.ndarray:
    """Bool (ncon,): contacts (rows of ``geom``) pairing a geom of ``mask_a`` with one of ``mask_b``, either order."""
    return (mask_a[geom[:, 0]] & mask_b[geom[:, 1]]) | (mask_a[geom[:, 1]] & mask_b[geom[:, 0]])


def test_grasped_bodies_is_both_pads_touching_each_body():
    """The kernel against the per-body definition (robosuite's grasp criterion): body b is grasped when a
    contact pairs one of its geoms with a pad-a geom and another (or the same) with a pad-b geom."""
    rng = np.random.default_rng(0)
    n_geoms, n_bodies = 12, 3
    for _ in range(GRASP_CASES):
        body = rng.integers(-1, n_bodies, size=n_geoms)
        pad_a, pad_b = rng.random(n_geoms) < 0.25, rng.random(n_geoms) < 0.25  # a geom may be both
        geom = rng.integers(0, n_geoms, size=(int(rng.integers(0, 8)), 2)).astype(np.int32)
        lookup = np.zeros((n_geoms, 2), dtype=np.int64)
        lookup[:, LOOKUP_BODY] = body
        lookup[pad_a, LOOKUP_PADS] |= PAD_A
        lookup[pad_b, LOOKUP_PADS] |= PAD_B
        expected = np.array([all(_pairs(geom, pad, body == b).any() for pad in (pad_a, pad_b))
                             for b in range(n_bodies)], dtype=bool)
        got = grasped_bodies(geom, lookup, n_bodies)
        assert got.dtype == np.bool_ and got.shape == (n_bodies,)
        np.testing.assert_array_equal(got, expected)
    # MuJoCo's own contact view (strided int32 rows): the sponge-like box_a resting on the floor is "held" by it
    model, data = _pressed_scene()
    lookup = np.zeros((model.ngeom, 2), dtype=np.int64)
    lookup[:, LOOKUP_BODY] = -1
    lookup[model.geom("box_a").id, LOOKUP_BODY] = 0
    lookup[model.geom("floor").id, LOOKUP_PADS] = PAD_A | PAD_B
    np.testing.assert_array_equal(grasped_bodies(data.contact.geom, lookup, 2), [True, False])
