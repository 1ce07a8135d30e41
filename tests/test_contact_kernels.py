"""The compiled contact kernels against the MuJoCo bindings they stand in for."""

import mujoco
import numpy as np
import pytest

from tableclean_suite.environments.contact_kernels import (
    LOOKUP_BODY,
    LOOKUP_PADS,
    NATIVE_CONTACT_FORCE,
    NATIVE_DATA,
    NATIVE_MODEL,
    PAD_A,
    PAD_B,
    PRESSING,
    SURFACE,
    contacts_between,
    grasped_bodies,
    press_normal_force,
)
from tableclean_suite.robosuite_adapter import c_address, mujoco_contact_force_address

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


def _masks(model, *names):
    mask = np.zeros(model.ngeom, dtype=bool)
    for name in names:
        mask[model.geom(name).id] = True
    return mask


def _bindings_sum(model, data, pressing, surface) -> float:
    """The env's per-contact reference: ``mj_contactForce``'s normal force summed over the contacts pairing
    the two masks, in contact order, through MuJoCo's Python bindings."""
    contact, total, wrench = data.contact, 0.0, np.zeros(6)
    for i in contacts_between(contact.geom1, contact.geom2, pressing, surface).tolist():
        mujoco.mj_contactForce(model, data, i, wrench)
        total += float(wrench[0])
    return total


def _native(model, data) -> np.ndarray:
    """press_normal_force's (3,) int64 addresses."""
    native = np.zeros(3, dtype=np.int64)
    native[[NATIVE_CONTACT_FORCE, NATIVE_MODEL, NATIVE_DATA]] = [mujoco_contact_force_address(), c_address(model),
                                                                 c_address(data)]
    return native


def _roles(pressing, surface) -> np.ndarray:
    roles = np.zeros(pressing.size, dtype=np.int64)
    roles[pressing] |= PRESSING
    roles[surface] |= SURFACE
    return roles


@pytest.mark.skipif(mujoco_contact_force_address() is None, reason="MuJoCo's library not found or versions unchecked")
@pytest.mark.parametrize("boxes", [("box_a",), ("box_b",), ("box_a", "box_b")])
def test_press_force_is_the_pairwise_sum_clipped_as_pythons_max(boxes):
    model, data = _pressed_scene()
    floor, pressing = _masks(model, "floor"), _masks(model, *boxes)
    contact = data.contact
    assert data.ncon > 0
    expected = max(_bindings_sum(model, data, pressing, floor), 0.0)
    assert expected > 0.0  # the boxes rest on the floor: a real force to compare
    got = press_normal_force(_native(model, data), contact.geom, _roles(pressing, floor), np.zeros(6))
    assert got == expected  # bit for bit: the same contacts summed in the same order
    # roles the other way round pair the same contacts
    assert press_normal_force(_native(model, data), contact.geom, _roles(floor, pressing), np.zeros(6)) == expected
    # no pairing contact, and no contact at all, give 0.0
    neither = _roles(_masks(model, "box_a"), _masks(model, "box_b"))
    assert press_normal_force(_native(model, data), contact.geom, neither, np.zeros(6)) == 0.0
    assert press_normal_force(_native(model, data), np.zeros((0, 2), dtype=np.int32), _roles(pressing, floor),
                              np.zeros(6)) == 0.0


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
