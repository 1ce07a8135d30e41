"""The Gym envs in parallel: picklable ``info``, Gymnasium's async vector envs, ``action_masks()``."""

import pickle
from dataclasses import fields

import gymnasium as gym
import numpy as np
import pytest

from tableclean_suite.gym_envs import SKILLS_ID, SYMBOLIC_ID
from tableclean_suite.gym_envs.skills import SkillReport
from tableclean_suite.task import Action, Outcome, TaskModel

#: Parallel environments in the vector tests (the machine has two cores).
NUM_ENVS = 2


def test_skill_report_has_the_fields_of_skill_result_and_pickles():
    from tableclean_suite.controllers import SkillResult

    assert [f.name for f in fields(SkillReport)] == [f.name for f in fields(SkillResult)]
    model = TaskModel()
    result = SkillResult(Action.MOVE, True, False, 42, "ok", model.decode(0), model.decode(1), Outcome.ROUTINE,
                         model.decode(1), wall_time=1.5, env_time=1.0, final_phase="done", phase_steps={"travel": 42})
    report = SkillReport.of(result)
    copy = pickle.loads(pickle.dumps(report))
    assert copy == report == result and copy.phase_steps == {"travel": 42} and copy.wall_time == 1.5
    # timings are ignored, everything else is compared
    assert SkillReport.of(result) == SkillReport(**{**vars(report), "wall_time": 9.0, "env_time": 8.0})
    assert report != SkillReport(**{**vars(report), "steps": 41})
    with pytest.raises(Exception):  # frozen
        report.steps = 3


def test_symbolic_action_masks_through_wrappers():
    env = gym.make(SYMBOLIC_ID)
    with pytest.raises(RuntimeError, match="reset"):
        env.get_wrapper_attr("action_masks")()
    obs, info = env.reset(seed=0)
    mask = env.get_wrapper_attr("action_masks")()
    assert mask.dtype == np.bool_ and mask.shape == (env.action_space.n,)
    assert mask.tolist() == info["action_mask"].astype(bool).tolist() == [True, True, True, False]  # clean improper
    env.reset(options={"state": 8})
    env.step(Action.CLEAN.value)  # terminal
    assert not env.get_wrapper_attr("action_masks")().any()


def test_symbolic_async_vector_env_steps_and_masks():
    envs = gym.make_vec(SYMBOLIC_ID, num_envs=NUM_ENVS, vectorization_mode="async")
    try:
        obs, info = envs.reset(seed=[0, 1])
        assert obs.tolist() == [0] * NUM_ENVS
        masks = np.stack(envs.call("action_masks"))
        assert masks.shape == (NUM_ENVS, 4) and masks.dtype == np.bool_
        obs, reward, terminated, truncated, info = envs.step(np.array([Action.MOVE.value, Action.PICK.value]))
        assert obs.tolist() == [1, 4] and reward.tolist() == pytest.approx([0.01, 0.01])
        assert info["outcome_name"].tolist() == ["routine", "routine"]
    finally:
        envs.close()


@pytest.mark.slow
def test_skills_async_vector_env_resets_and_steps():
    envs = gym.make_vec(SKILLS_ID, num_envs=NUM_ENVS, vectorization_mode="async")
    try:
        obs, info = envs.reset(seed=[0, 1])
        assert obs.tolist() == [0] * NUM_ENVS
        assert np.stack(envs.call("action_masks")).tolist() == [[True, True, True, False]] * NUM_ENVS
        # env 0 moves (physics), env 1 tries to clean under the object (improper: refused)
        obs, reward, terminated, truncated, info = envs.step(np.array([Action.MOVE.value, Action.CLEAN.value]))
        assert obs.tolist() == [1, 0] and reward.tolist() == pytest.approx([0.01, -1.0])
        reports = info["skill_result"]
        assert all(isinstance(r, SkillReport) for r in reports)
        assert reports[0].success and reports[0].steps > 0 and reports[1].improper and reports[1].steps == 0
        obs, reward, terminated, truncated, info = envs.step(np.array([Action.MOVE.value, Action.PICK.value]))
        assert obs.tolist() == [0, 4] and not terminated.any() and not truncated.any()
        model = TaskModel()
        expected = [model.action_mask(code).astype(bool).tolist() for code in (0, 4)]
        assert expected[1] == [True, True, True, False]  # holding: cleaning is improper
        assert np.stack(envs.call("action_masks")).tolist() == expected
    finally:
        envs.close()
