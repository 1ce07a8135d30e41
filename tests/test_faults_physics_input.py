"""Fault battery, physics input: every bad task_config value, horizon, controller and action is a
ValueError naming the key, the value and what is allowed, before anything is simulated."""

import numpy as np
import pytest
import robosuite

import tableclean_suite  # noqa: F401  (registers TableClean)
from tableclean_suite.environments.config import DEFAULT_TABLECLEAN_CONFIG, make_config

BAD_TASK_CONFIG = [
    ("marker_grid", 0, "2 integers >= 1"),
    ("marker_grid", (2.5, 2), "2 integers >= 1"),
    ("marker_grid", (0, 3), "2 integers >= 1"),
    ("segment_size", 3.0, "2 numbers"),
    ("segment_size", (0.2,), "2 numbers"),
    ("segment_size", ("0.2", "0.2"), "2 numbers"),
    ("table_full_size", (0.8, 0.8, -0.05), "3 positive numbers"),
    ("table_offset", None, "3 numbers"),
    ("table_friction", (float("nan"), 0.0, 0.0), "all finite"),
    ("table_friction", (0.0, 0.005, 0.0001), "sliding friction"),
    ("marker_radius", "0.01", "a number"),
    ("sponge_density", float("inf"), "all finite"),
    ("clean_fraction", 0.0, "(0, 1]"),
    ("clean_fraction", True, "(0, 1]"),
    ("segment_columns", 3, "1..2"),
    ("segment_columns", 1.5, "1..2"),
    ("segment_gap", [0.04], "a number"),
    ("placement_yaw_noise", 7.0, "rad"),
    ("placement_noise", -0.01, ">= 0"),
    ("reach_x", (0.2, -0.2), "low < high"),
    ("object_type", 5, "registered object type"),
]


@pytest.mark.parametrize("key, value, allowed", BAD_TASK_CONFIG, ids=[f"{k}={v!r}" for k, v, _ in BAD_TASK_CONFIG])
def test_a_bad_task_config_value_names_key_value_and_allowed(key, value, allowed):
    with pytest.raises(ValueError) as caught:
        make_config({key: value})
    message = str(caught.value)
    assert key in message and repr(value) in message and allowed in message and "\n" not in message, message


def test_every_default_passes_and_the_keys_all_have_a_check():
    assert make_config() == DEFAULT_TABLECLEAN_CONFIG
    with pytest.raises(ValueError, match="must be a dict"):
        make_config([("marker_grid", (2, 2))])


def _make(**kwargs):
    return robosuite.make("TableClean", robots="Panda", has_offscreen_renderer=False, use_camera_obs=False, **kwargs)


@pytest.mark.parametrize("kwargs, named", [
    (dict(horizon=-5), "horizon"), (dict(horizon=0), "horizon"), (dict(horizon=2.5), "horizon"),
    (dict(horizon="100"), "horizon"), (dict(control_freq=0), "control_freq"),
    (dict(control_freq=float("nan")), "control_freq"),
    (dict(controller_configs={"type": "BOGUS"}), "unknown controller type 'BOGUS'"),
    (dict(controller_configs="OSC_POSE"), "controller_configs must be a dict"),
])
def test_bad_episode_settings_and_controllers_are_named_before_building(kwargs, named):
    with pytest.raises(ValueError, match=named):
        _make(**kwargs)


@pytest.fixture(scope="module")
def env():
    environment = _make()
    environment.reset()
    yield environment
    environment.close()


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_action_raises_and_leaves_the_simulation_alone(env, bad):
    before = env.sim.data.qpos.copy()
    action = np.zeros(env.action_dim)
    action[2] = bad
    with pytest.raises(ValueError, match=r"non-finite entry \(\[2\]"):
        env.step(action)
    assert np.array_equal(env.sim.data.qpos, before)


def test_an_action_that_is_not_numbers_raises(env):
    with pytest.raises(ValueError, match="sequence of numbers"):
        env.step(["left"] * env.action_dim)
    reward = env.step(np.zeros(env.action_dim))[1]
    assert np.isfinite(reward)
