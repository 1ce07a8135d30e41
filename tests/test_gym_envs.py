"""Gymnasium envs: registration, check_env, the symbolic env equals TaskModel + RewardPattern, errors."""

import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import tableclean_suite  # noqa: F401  (registers the ids)
from tableclean_suite.gym_envs import SKILLS_ID, SYMBOLIC_ID, TableCleanSymbolicEnv
from tableclean_suite.rewards import get_reward_pattern
from tableclean_suite.task import PAPER_OPTIMAL_PLAN, Action, Outcome, TaskModel, decode

MODEL = TaskModel()
NON_TERMINAL = [s for s in MODEL.reachable_states() if not s.is_terminal]


def make(**kwargs):
    return gym.make(SYMBOLIC_ID, **kwargs)


def test_ids_are_registered_with_string_entry_points_and_the_paper_time_limit():
    for env_id, cls in ((SYMBOLIC_ID, "TableCleanSymbolicEnv"), (SKILLS_ID, "TableCleanSkillsEnv")):
        spec = gym.spec(env_id)
        assert isinstance(spec.entry_point, str) and spec.entry_point.endswith(cls)
        assert spec.max_episode_steps == 500


def test_import_does_not_load_the_physics_env():
    code = "import sys, tableclean_suite; print('tableclean_suite.gym_envs.skills' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip().splitlines()[-1] == "False"


@pytest.mark.parametrize("render_mode", [None, "ansi", "rgb_array"])
def test_symbolic_env_passes_check_env(render_mode):
    env = make(render_mode=render_mode)
    check_env(env.unwrapped, skip_render_check=render_mode is None)
    assert env.action_space == gym.spaces.Discrete(4)
    assert env.observation_space == gym.spaces.Discrete(24)


def test_paper_optimal_plan_from_state_4_gives_the_r4_reward_sequence():
    env = make(reward="r4")
    obs, info = env.reset(seed=0)
    assert obs == 0 and decode(obs) == MODEL.start_state  # Table 1 state 4 = code 0
    assert info["action_mask"].tolist() == MODEL.action_mask(0).tolist() == [1, 1, 1, 0]
    rewards, terminations = [], []
    for action in PAPER_OPTIMAL_PLAN:
        obs, reward, terminated, truncated, info = env.step(int(action))
        rewards.append(reward)
        terminations.append(terminated)
        assert not truncated
        assert info["action_mask"].tolist() == MODEL.action_mask(obs).tolist()
    # move +0.01, clean +1, move/pick/move/place/move +0.01 each, final clean +1 (terminal replaces relevant)
    assert rewards == pytest.approx([0.01, 1.0, 0.01, 0.01, 0.01, 0.01, 0.01, 1.0])
    assert terminations == [False] * 7 + [True]
    assert info["outcome"] == Outcome.TERMINAL and info["outcome_name"] == "terminal"
    assert decode(obs).is_terminal
    assert info["action_mask"].tolist() == [0, 0, 0, 0]


def test_scripted_episode_equals_task_model_and_reward_pattern_with_history():
    # a looping, improper and ineffective mix, checked step by step against the pure functions
    pattern = get_reward_pattern("r4")
    script = [Action.MOVE, Action.MOVE, Action.CLEAN, Action.PICK, Action.CLEAN, Action.PICK, Action.MOVE,
              Action.PLACE, Action.PLACE, Action.MOVE, Action.CLEAN]
    env = make(reward="r4")
    state, _ = env.reset(seed=3)
    previous = -1
    for action in script:
        expected_next, outcome = MODEL.step(state, action)
        expected_reward = pattern.reward(int(outcome), state, expected_next.index, previous)
        obs, reward, terminated, _, info = env.step(int(action))
        assert (obs, info["outcome"]) == (expected_next.index, int(outcome))
        assert reward == expected_reward
        assert terminated == expected_next.is_terminal
        previous, state = state, obs
    # the second move returned to s_{t-1}: the looping penalty, not the routine incentive
    env.reset(seed=0)
    assert env.step(0)[1] == pytest.approx(0.01)
    assert env.step(0)[1] == pytest.approx(-0.01)


@pytest.mark.parametrize("reward", ["r1", "r2", "r3", "r4"])
def test_every_pair_matches_the_model(reward):
    pattern = get_reward_pattern(reward)
    env = make(reward=reward)
    for state in NON_TERMINAL:
        for action in Action:
            obs, info = env.reset(options={"state": state.index})
            assert obs == state.index and info["action_mask"].tolist() == MODEL.action_mask(state).tolist()
            nxt, outcome = MODEL.step(state, action)
            obs, r, terminated, truncated, info = env.step(action.value)
            assert obs == nxt.index and info["outcome"] == outcome
            assert r == pattern.reward(int(outcome), state.index, nxt.index, -1)
            assert terminated == nxt.is_terminal and not truncated


def test_improper_action_keeps_the_state_and_costs_minus_one():
    env = make()
    env.reset(options={"state": 0})  # object on the arm's segment: clean is improper
    obs, reward, terminated, _, info = env.step(Action.CLEAN.value)
    assert (obs, reward, terminated, info["outcome_name"]) == (0, -1.0, False, "improper")


def test_registry_truncates_after_500_steps():
    env = make()
    env.reset(seed=0)
    for t in range(500):
        _, _, terminated, truncated, _ = env.step(Action.MOVE.value)
        assert not terminated
        assert truncated == (t == 499)


def test_uniform_start_draws_the_four_layouts_and_seeding_repeats():
    env = make(model=TaskModel(start="uniform_unclean"))
    starts = [env.reset(seed=seed)[0] for seed in range(40)]
    assert set(starts) == {s.index for s in TaskModel(start="uniform_unclean").start_states()}
    assert starts == [env.reset(seed=seed)[0] for seed in range(40)]


@pytest.mark.parametrize("task", ["three_segments", "three_segments_two_objects"])
def test_symbolic_env_builds_any_task_spec_with_its_start_mode(task):
    model = TaskModel(spec=task, start="uniform_unclean")
    env = make(task=task, start="uniform_unclean")
    check_env(env.unwrapped, skip_render_check=True)
    assert env.action_space == gym.spaces.Discrete(model.n_actions)
    assert env.observation_space == gym.spaces.Discrete(model.n_states)
    assert env.unwrapped.model.spec.name == task and env.unwrapped.model.n_segments == 3
    layouts = {s.index for s in model.start_states()}
    starts = {env.reset(seed=seed)[0] for seed in range(20 * len(layouts))}
    assert starts == layouts  # every all-unclean layout, nothing else
    # a step is the spec's model, not the paper's
    state, _ = env.reset(seed=0)
    for action in range(model.n_actions):
        env.reset(options={"state": state})
        obs, _, terminated, _, info = env.step(action)
        expected, outcome = model.step(state, action)
        assert (obs, info["outcome"], terminated) == (expected.index, int(outcome), expected.is_terminal)


def test_symbolic_env_refuses_unknown_task_and_start_with_the_allowed_names():
    with pytest.raises(ValueError, match="five_segments"):
        make(task="five_segments")
    with pytest.raises(ValueError, match="uniform_unclean"):
        make(task="three_segments", start="random")
    with pytest.raises(ValueError, match="either model= or task="):
        make(model=TaskModel(), task="three_segments")


def test_skills_env_refuses_a_spec_the_scene_cannot_build():
    # refused before any MuJoCo model is built (fast), naming the spec and the limit
    from tableclean_suite.task import TaskSpec

    with pytest.raises(ValueError, match=r"task 'five_segments'.*at most 4 segments"):
        gym.make(SKILLS_ID, task=TaskSpec("five_segments", segments=5))
    with pytest.raises(ValueError, match=r"unknown object_type 'banana'; allowed: .*box"):
        gym.make(SKILLS_ID, task=TaskSpec("fruit", objects=("banana",)))


def test_renderings():
    env = make(render_mode="ansi")
    env.reset(options={"state": 0})
    text = env.render()
    assert "state 0" in text and "[obj]" in text and "ARM" in text
    env.step(Action.MOVE.value)
    assert "last: move (routine)" in env.render()
    env = make(render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert frame.std() > 10  # a picture, not a blank frame
    env.step(Action.MOVE.value)
    assert not np.array_equal(frame, env.render())  # the arm moved


def test_bad_arguments_raise_clear_errors():
    with pytest.raises(ValueError, match="unknown reward pattern 'r9'"):
        make(reward="r9")
    with pytest.raises(ValueError, match="render_mode"):
        TableCleanSymbolicEnv(render_mode="human")
    with pytest.raises(TypeError, match="TaskModel"):
        make(model="paper")
    env = make().unwrapped
    with pytest.raises(RuntimeError, match="reset"):
        env.step(0)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="Discrete"):
        env.step(4)
    with pytest.raises(ValueError, match="unknown reset option"):
        env.reset(options={"start": 0})
    with pytest.raises(ValueError, match="terminal"):
        env.reset(options={"state": 20})
    env.reset(options={"state": 8})
    env.step(Action.CLEAN.value)  # terminal
    with pytest.raises(RuntimeError, match="terminated"):
        env.step(Action.MOVE.value)


@pytest.mark.slow
def test_skills_env_passes_check_env_and_steps_physics():
    env = gym.make(SKILLS_ID, render_mode="rgb_array", frame_size=(64, 96))
    try:
        check_env(env.unwrapped, skip_render_check=True)
        obs, info = env.reset(seed=0)
        assert obs == 0 and info["action_mask"].tolist() == [1, 1, 1, 0]
        frame = env.render()
        assert frame.shape == (64, 96, 3) and frame.std() > 5
        obs, reward, terminated, truncated, info = env.step(Action.MOVE.value)
        assert (obs, reward, terminated, truncated) == (1, pytest.approx(0.01), False, False)
        assert info["skill_result"].success and info["skill_result"].steps > 0
        obs, reward, _, _, info = env.step(Action.PICK.value)  # nothing to pick on segment 2: no motion
        assert (obs, reward, info["outcome_name"], info["skill_result"].steps) == (1, pytest.approx(-0.01), "ineffective", 0)  # r4: stays put
        obs, reward, _, _, info = env.step(Action.MOVE.value)
        assert (obs, reward) == (0, pytest.approx(0.01))  # s_{t-1} is 1 (the pick stayed): no loop
        obs, reward, _, _, info = env.step(Action.CLEAN.value)  # improper: refused
        assert (obs, reward, info["skill_result"].improper, info["skill_result"].steps) == (0, -1.0, True, 0)
    finally:
        env.close()
    with pytest.raises(ValueError, match="frame_size"):
        gym.make(SKILLS_ID, frame_size=(0, 10))


def test_record_video_writes_an_episode_with_the_video_extra(tmp_path):
    """Gymnasium's RecordVideo works on the envs' rgb_array frames (the video extra brings moviepy)."""
    from gymnasium.wrappers import RecordVideo

    folder = tmp_path / "videos"
    env = RecordVideo(gym.make(SYMBOLIC_ID, render_mode="rgb_array"), str(folder), episode_trigger=lambda k: k == 0,
                      disable_logger=True)
    env.reset(seed=0)
    for action in PAPER_OPTIMAL_PLAN:
        terminated = env.step(int(action))[2]
    env.close()
    assert terminated
    videos = list(folder.glob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 0


def test_symbolic_env_applies_a_looping_rule_that_looks_back_a_whole_episode():
    """r4_cycle penalises MOVE round a ring of three segments once it returns to a visited state
    (the env keeps the episode's history for it; the paper's r4 would not see the cycle)."""
    from tableclean_suite.task import TaskSpec

    rewards = {}
    for pattern in ("r4", "r4_cycle"):
        env = gym.make("TableCleanSymbolic-v0", reward=pattern, task=TaskSpec("ring", segments=3)).unwrapped
        env.reset(seed=0)
        move = env.model.action_names.index("move")
        rewards[pattern] = [env.step(move)[1] for _ in range(4)]
    assert rewards["r4_cycle"][:2] == [0.01, 0.01] and rewards["r4_cycle"][2:] == [-0.01, -0.01]
    assert rewards["r4"] == [0.01] * 4
