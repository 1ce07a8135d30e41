"""``TableClean.skill_info`` (read every control step by the skills): its grasp flags and quaternions,
computed in one compiled pass / one indexing, equal the per-body contact test and robosuite's
``convert_quat`` at every control step of a plan that grasps the sponge and an object."""

from __future__ import annotations

import numpy as np
import pytest
from robosuite.utils.transform_utils import convert_quat

from tableclean_suite.controllers import SkillController, make_skill_env
from tableclean_suite.task import TaskModel, start_layout

MODEL = TaskModel()


@pytest.mark.slow
def test_grasp_flags_and_quaternions_match_the_per_body_reads():
    env = make_skill_env(1, 1, seed=2)
    seen = {"sponge": 0, "object": 0, "steps": 0}

    def check() -> None:
        info = env.skill_info()
        expected = np.array([env._grasped(mask) for mask in env._object_masks])
        np.testing.assert_array_equal(info["objects_grasped"], expected)
        assert info["object_grasped"] == expected[0]
        assert info["sponge_grasped"] == env._grasped(env._sponge_mask)
        quats = env.sim.data.body_xquat
        np.testing.assert_array_equal(info["objects_quat"],
                                      np.array([convert_quat(np.array(quats[b]), to="xyzw") for b in env.object_body_ids]))
        np.testing.assert_array_equal(info["sponge_quat"], convert_quat(np.array(quats[env.sponge_body_id]), to="xyzw"))
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
    finally:
        env.close()
