"""The compiled contact kernels against the MuJoCo bindings they stand in for."""

import mujoco
import numpy as np
import pytest

from tableclean_suite.environments.contact_kernels import contacts_between, normal_force_between
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


@pytest.mark.skipif(mujoco_contact_force_address() is None, reason="MuJoCo's library not found or versions unchecked")
@pytest.mark.parametrize("boxes", [("box_a",), ("box_b",), ("box_a", "box_b")])
def test_normal_force_sum_is_the_bindings_sum_bit_for_bit(boxes):
    model, data = _pressed_scene()
    floor, pressing = _masks(model, "floor"), _masks(model, *boxes)
    contact = data.contact
    assert data.ncon > 0
    expected, wrench = 0.0, np.zeros(6)
    for i in contacts_between(contact.geom1, contact.geom2, pressing, floor).tolist():
        mujoco.mj_contactForce(model, data, i, wrench)
        expected += float(wrench[0])
    assert expected > 0.0  # the boxes rest on the floor: a real force to compare
    got = normal_force_between(mujoco_contact_force_address(), c_address(model), c_address(data), contact.geom1,
                               contact.geom2, pressing, floor, np.zeros(6))
    assert got == expected
    # the masks in the other order pair the same contacts
    assert normal_force_between(mujoco_contact_force_address(), c_address(model), c_address(data), contact.geom1,
                                contact.geom2, floor, pressing, np.zeros(6)) == expected


@pytest.mark.skipif(mujoco_contact_force_address() is None, reason="MuJoCo's library not found or versions unchecked")
def test_normal_force_sum_is_zero_without_a_pairing_contact():
    model, data = _pressed_scene()
    contact = data.contact
    assert normal_force_between(mujoco_contact_force_address(), c_address(model), c_address(data), contact.geom1,
                                contact.geom2, _masks(model, "box_a"), _masks(model, "box_b"), np.zeros(6)) == 0.0
