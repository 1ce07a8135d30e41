"""The skills' speed bench (:mod:`tableclean_suite.bench.skill_speed`) on a real episode: the fast path logs
the state at the start of every control step for the raw-MuJoCo replay, without an ``on_step`` callback
(whose time would count as executor overhead and which would keep the compiled phase loop out)."""

from __future__ import annotations

import numpy as np
import pytest

from tableclean_suite.bench import skill_speed
from tableclean_suite.controllers import make_skill_env
from tableclean_suite.controllers.fast_control import fast_stepper_of


@pytest.mark.slow
def test_fast_episode_logs_every_control_steps_state_for_the_replay():
    env = make_skill_env(1, 1, seed=1, hard_reset=False)
    try:
        records = skill_speed._empty_records()
        states = skill_speed._run_episode(env, records, record_states=True)
        episode = records["episodes"][-1]
        assert episode["terminal"] and episode["steps"] == len(states) > 0
        assert fast_stepper_of(env).state_log is None  # the log is handed over, the stepper no longer logs
        sizes = {field: getattr(env.sim.data, field).size for field in skill_speed.REPLAY_FIELDS}
        assert all({f: s[f].size for f in skill_speed.REPLAY_FIELDS} == sizes for s in states)
        moved = [not np.array_equal(a["qpos"], b["qpos"]) for a, b in zip(states, states[1:])]
        assert all(moved)  # one row per control step, each after the previous step's physics
        steps, seconds = skill_speed._replay_mujoco(env, states)
        assert steps == len(states) and seconds > 0
    finally:
        env.close()


def test_recording_states_needs_the_fast_stepper():
    env = make_skill_env(1, 1, seed=1, fast_control=False)
    try:
        with pytest.raises(ValueError, match="fast stepper"):
            skill_speed._run_episode(env, skill_speed._empty_records(), record_states=True)
    finally:
        env.close()


def test_the_skill_goals_say_how_far_from_their_goal_they_are():
    assert skill_speed.overhead_against_goal(0.0652) == "6.52% (1.30x the 5% goal, 1.52 points over)"
    assert skill_speed.overhead_against_goal(0.04) == "4.00% (0.80x the 5% goal, 1.00 points under)"
    assert skill_speed.speedup_against_goal(5.33) == "5.33x (1.07x the 5x goal, 0.330 above)"
    assert skill_speed.raw_ratio_against_goal(0.7996) == "0.80 (1.00x the 0.8 goal, 0.000 below)"
    assert skill_speed.raw_ratio_against_goal(0.796) == "0.80 (0.99x the 0.8 goal, 0.004 below)"


@pytest.mark.slow
def test_the_warm_up_leaves_the_timed_episodes_as_without_it(monkeypatch):
    warmed = []
    original = skill_speed.warm_up
    monkeypatch.setattr(skill_speed, "warm_up", lambda *a, **k: warmed.append(a) or original(*a, **k))
    with_warm_up = skill_speed.compare_paths(1, seed=1)
    without = skill_speed.compare_paths(1, seed=1, warm=False)
    assert len(warmed) == 1
    for path in ("robosuite", "fast"):
        steps = [ep["steps"] for ep in with_warm_up[path]["episodes"]]
        assert steps == [ep["steps"] for ep in without[path]["episodes"]] and all(s > 0 for s in steps)
