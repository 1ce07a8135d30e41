"""``TableClean.skill_info`` (read every control step by the skills): its grasp flags, quaternions and
positions, computed in one compiled pass / one gathering, equal the per-body contact test, robosuite's
``convert_quat`` and MuJoCo's arrays (the grip site's rotation matrix too), and the compiled contact queries equal
their numpy definitions, at every control step of a plan that grasps the sponge, wipes and grasps an object; its constant values
are shared read-only arrays rebuilt for a new config."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from robosuite.utils.transform_utils import convert_quat

from tableclean_suite.controllers import SkillController, make_skill_env
from tableclean_suite.environments.config import DEFAULT_TABLECLEAN_CONFIG
from tableclean_suite.environments.contact_kernels import contact_within
from tableclean_suite.environments.skill_info import StaleSkillInfoError
from tableclean_suite.robosuite_adapter import mj_data, mj_model
from tableclean_suite.task import TaskModel, start_layout

MODEL = TaskModel()
#: The env's default wiping contact distance [m] (the env's own check compares contacts against it).
WIPE_CONTACT_DIST = float(DEFAULT_TABLECLEAN_CONFIG["wipe_contact_dist"])


@pytest.mark.slow
def test_grasp_flags_and_quaternions_match_the_per_body_reads():
    env = make_skill_env(1, 1, seed=2)
    seen = {"sponge": 0, "object": 0, "steps": 0, "pressing": 0}

    def check() -> None:
        info = env.skill_info()
        contacts = env.contacts
        expected = np.array([grasped(env, mask) for mask in contacts.objects])
        np.testing.assert_array_equal(info["objects_grasped"], expected)
        assert info["object_grasped"] == expected[0]
        assert info["sponge_grasped"] == grasped(env, contacts.sponge)
        quats = env.sim.data.body_xquat
        np.testing.assert_array_equal(info["objects_quat"],
                                      np.array([convert_quat(np.array(quats[b]), to="xyzw") for b in env.object_body_ids]))
        np.testing.assert_array_equal(info["sponge_quat"], convert_quat(np.array(quats[env.sponge_body_id]), to="xyzw"))
        np.testing.assert_array_equal(info["objects_pos"], env.sim.data.body_xpos[env.object_body_ids])
        np.testing.assert_array_equal(info["sponge_pos"], env.sim.data.body_xpos[env.sponge_body_id])
        robot = env.robots[0]
        np.testing.assert_array_equal(info["eef_rot"], env.sim.data.site_xmat[robot.eef_site_id[robot.arms[0]]].reshape(3, 3))
        assert env.sponge_press_force() == press_force_per_contact(env)
        contact, ncon = env.sim.data.contact, env.sim.data.ncon
        pressing = any_contact(contact.geom1[:ncon], contact.geom2[:ncon], contacts.sponge, contacts.table)
        within = contact_within(contact.geom1[:ncon], contact.geom2[:ncon], contact.dist[:ncon], contacts.sponge,
                                contacts.table, WIPE_CONTACT_DIST)
        assert env.contacts.sponge_on_table(WIPE_CONTACT_DIST) == within
        assert within == bool((pressing & (contact.dist[:ncon] <= WIPE_CONTACT_DIST)).any())
        seen["pressing"] += within
        seen["sponge"] += info["sponge_grasped"]
        seen["object"] += bool(expected.any())
        seen["steps"] += 1

    try:
        env.reset()
        plan = MODEL.shortest_plan(start_layout(1, 1))
        picks = [k for k, action in enumerate(plan) if MODEL.action_name(action) == "pick"]
        results = SkillController(env, MODEL, on_step=check).execute_plan(plan[: picks[0] + 1])
        assert all(r.success for r in results), [r.reason for r in results]
        assert seen["sponge"] > 0 and seen["object"] > 0 and seen["steps"] == sum(r.steps for r in results)
        assert seen["pressing"] > 0
    finally:
        env.close()


def any_contact(geom1: np.ndarray, geom2: np.ndarray, mask_a: np.ndarray, mask_b: np.ndarray) -> np.ndarray:
    """Bool (ncon,): contacts pairing a geom of ``mask_a`` with one of ``mask_b`` (either order); ``geom1``,
    ``geom2`` MuJoCo's active contacts' geom ids, the masks bool lookups over all geom ids."""
    return (mask_a[geom1] & mask_b[geom2]) | (mask_a[geom2] & mask_b[geom1])


def grasped(env, mask: np.ndarray) -> bool:
    """Both finger pads touch a geom of ``mask`` (robosuite's grasp criterion, per body with numpy masks)."""
    data = mj_data(env.sim)
    ncon = data.ncon
    geom1, geom2 = data.contact.geom1[:ncon], data.contact.geom2[:ncon]
    return ncon > 0 and all(any_contact(geom1, geom2, pad, mask).any() for pad in env.contacts.pads)


def press_force_per_contact(env) -> float:
    """``sponge_press_force`` from its definition: MuJoCo's ``mj_contactForce`` per sponge-table contact
    (found with numpy masks), summed in contact order, at least 0 [N]."""
    model, data = mj_model(env.sim), mj_data(env.sim)
    ncon = data.ncon
    if ncon == 0:
        return 0.0
    pressing = any_contact(data.contact.geom1[:ncon], data.contact.geom2[:ncon], env.contacts.sponge,
                                  env.contacts.table)
    wrench, total = np.zeros(6), 0.0
    for i in np.flatnonzero(pressing):
        mujoco.mj_contactForce(model, data, int(i), wrench)
        total += float(wrench[0])
    return max(total, 0.0)


@pytest.mark.slow
def test_constant_values_are_shared_read_only_and_follow_a_new_config():
    env = make_skill_env(1, 1, seed=2)
    try:
        env.reset()
        first, second = env.skill_info(), env.skill_info()
        assert first["segment_centers"] is second["segment_centers"]  # built once, not copied per call
        with pytest.raises(ValueError, match="read-only"):
            first["segment_centers"][0, 0] = 1.0
        assert first["eef_pos"] is not second["eef_pos"] and first["eef_pos"].flags.writeable
        env.task_config = {**env.task_config, "object_clearance": 0.5}  # a new config object (as a randomised reset)
        assert env.skill_info()["object_clearance"] == 0.5
        env.step(np.concatenate([first["eef_pos"], [np.pi, 0.0, 0.0, -1.0]]))
        with pytest.raises(StaleSkillInfoError):
            first["eef_quat"]
        # a state written back at the same simulation time is another state too
        state, info = env.get_scene_state(), env.skill_info()
        env.set_scene_state(state)
        with pytest.raises(StaleSkillInfoError):
            info["objects_quat"]
    finally:
        env.close()
