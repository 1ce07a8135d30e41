"""The TableClean robosuite environment: registration, reset layouts, observables, wiping, rewards, seeding."""

import numpy as np
import pytest
import robosuite

import tableclean_suite  # noqa: F401  (registers TableClean)
from tableclean_suite.environments import DEFAULT_TABLECLEAN_CONFIG, TableClean
from tableclean_suite.robosuite_adapter import fresh_observations, mj_data
from tableclean_suite.task import (
    START_LAYOUTS,
    TABLE1_STATES,
    TaskModel,
    TaskSpec,
    TaskState,
    start_layout,
)

SEGMENT_1, SEGMENT_2 = 0, 1  # 0-based segment indices of the scene

GRAVITY = 9.81
HOVER_GAP = 0.005  # the sponge's underside 5 mm above the table top
PRESS_DEPTH = 0.0005  # the sponge's underside 0.5 mm into the table top
WIPE_STRIDE = 0.03  # raster spacing of the driven sponge [m]


def make(**kwargs) -> TableClean:
    settings = dict(robots="Panda", has_renderer=False, has_offscreen_renderer=False, use_camera_obs=False,
                    ignore_done=True, seed=0)
    settings.update(kwargs)
    return robosuite.make("TableClean", **settings)


_ENVS = {}


def env_for(object_segment, arm_segment, **kwargs) -> TableClean:
    """One shared environment per layout and options (making one takes about a second)."""
    key = (object_segment, arm_segment, tuple(sorted(kwargs.items())))
    if key not in _ENVS:
        _ENVS[key] = make(object_segment=object_segment, arm_segment=arm_segment, **kwargs)
    return _ENVS[key]


@pytest.fixture(scope="module", autouse=True)
def _close_envs():
    yield
    for env in _ENVS.values():
        env.close()
    _ENVS.clear()


@pytest.fixture
def paper_env():
    """Layout (1, 1) freshly reset: object and arm over segment 1, both segments dirty."""
    env = env_for(1, 1)
    env.reset()
    return env


# -- driving the sponge directly (no skill controller) -------------------------------------------
def put_sponge(env, pos, hold=False):
    """Teleport the sponge (flat, at rest) to ``pos``; ``hold`` cancels gravity so it hovers in place."""
    env.sim.data.set_joint_qpos(env.sponge.joints[0], np.concatenate([pos, [1.0, 0.0, 0.0, 0.0]]))
    env.sim.data.set_joint_qvel(env.sponge.joints[0], np.zeros(6))
    mass = env.sim.model.body_subtreemass[env.sponge_body_id]
    env.sim.data.xfrc_applied[env.sponge_body_id, 2] = mass * GRAVITY if hold else 0.0
    env.sim.forward()


def raster(env, segment: int, underside_z: float, hold: bool):
    """Sweep the sponge over ``segment`` (0-based) with its underside at ``underside_z``, one control step per pose."""
    info = env.skill_info()
    center, half = info["segment_centers"][segment], info["segment_half_sizes"][segment]
    zero = np.zeros(env.action_dim)
    for x in np.arange(center[0] - half[0], center[0] + half[0] + 1e-9, WIPE_STRIDE):
        for y in np.arange(center[1] - half[1], center[1] + half[1] + 1e-9, WIPE_STRIDE):
            put_sponge(env, [x, y, underside_z + info["sponge_half_size"][2]], hold=hold)
            env.step(zero)
    put_sponge(env, info["sponge_home_pos"])


# -- registration and arguments (fast) -----------------------------------------------------------
def test_table_clean_is_registered_by_importing_the_package():
    assert "TableClean" in robosuite.ALL_ENVIRONMENTS


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"object_segment": 3}, r"object_segment must be 1, 2 or None.*3"),
        ({"arm_segment": 0}, r"arm_segment must be 1, 2 or None.*0"),
        ({"dirty_segments": (1, 3)}, r"dirty_segments.*3"),
        ({"task_config": {"segment_size": (-0.1, 0.2)}}, r"segment_size.*positive"),
        ({"task_config": {"placement_noise": -0.01}}, r"placement_noise.*>= 0"),
        ({"task_config": {"object_type": "banana"}}, r"unknown object_type 'banana'.*allowed.*cube"),
        ({"task_config": {"segmnet_size": (0.2, 0.2)}}, r"unknown task_config key.*segmnet_size"),
        ({"task_config": {"segment_size": (0.2, 0.5)}}, r"do not fit"),
    ],
)
def test_bad_arguments_raise_clear_errors(kwargs, match):
    with pytest.raises(ValueError, match=match):
        make(**kwargs)


# -- reset layouts ---------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("object_segment, arm_segment", START_LAYOUTS)
def test_reset_symbolic_state_is_the_start_layout(object_segment, arm_segment):
    env = env_for(object_segment, arm_segment)
    env.reset()
    assert env.symbolic_state() == start_layout(object_segment, arm_segment)
    gripper_open = env.robots[0].gripper["right"].init_qpos
    np.testing.assert_allclose(env.skill_info()["gripper_qpos"], gripper_open, atol=1e-3)


@pytest.mark.slow
def test_paper_layout_is_table1_state_4(paper_env):
    assert paper_env.symbolic_state() == TABLE1_STATES[4]
    assert paper_env.layout == (SEGMENT_1, SEGMENT_1)


@pytest.mark.slow
def test_only_the_requested_segments_start_dirty():
    env = env_for(2, 1, dirty_segments=(2,))
    env.reset()
    np.testing.assert_array_equal(env.dirt_fraction(), [0.0, 1.0])
    assert env.symbolic_state() == TaskState((True, False), (SEGMENT_2,), SEGMENT_1)


@pytest.mark.slow
def test_set_start_changes_the_next_reset_and_refuses_bad_numbers_without_changing_anything():
    env = env_for(1, 1, dirty_segments=(1, 2))
    try:
        env.set_start(2, 1, (2,))  # 1-based, as the constructor's arguments
        env.reset()
        assert env.layout == (SEGMENT_2, SEGMENT_1)
        assert env.symbolic_state() == TaskState((True, False), (SEGMENT_2,), SEGMENT_1)
        for bad, match in (((3, 1, (1,)), r"object_segment must be 1, 2 or None.*3"),
                           ((1, 1, (0,)), r"dirty_segments entry must be 1, 2.*0")):
            with pytest.raises(ValueError, match=match):
                env.set_start(*bad)
        assert (env.object_segment, env.arm_segment, env.dirty_segments) == (SEGMENT_2, SEGMENT_1, (SEGMENT_2,))
    finally:
        env.set_start(1, 1, (1, 2))


# -- observables and grounding ---------------------------------------------------------------------
@pytest.mark.slow
def test_observables_are_present_with_the_right_shapes(paper_env):
    obs = paper_env.step(np.zeros(paper_env.action_dim))[0]
    expected = {
        "robot0_eef_pos": (3,), "robot0_joint_pos": (7,), "robot0_gripper_qpos": (2,),
        "object_pos": (3,), "object_quat": (4,), "sponge_pos": (3,), "sponge_quat": (4,),
        "dirt_fraction": (2,), "gripper_to_object_pos": (3,), "symbolic_state_onehot": (TaskModel().n_states,),
    }
    for key, shape in expected.items():
        assert np.shape(obs[key]) == shape, key
    assert int(obs["symbolic_state_index"]) == TABLE1_STATES[4].index
    assert obs["symbolic_state_onehot"].sum() == 1 and obs["symbolic_state_onehot"][TABLE1_STATES[4].index] == 1
    np.testing.assert_allclose(obs["gripper_to_object_pos"], obs["object_pos"] - obs["robot0_eef_pos"], atol=1e-9)


@pytest.mark.slow
def test_skill_info_has_the_contract_keys_and_shapes(paper_env):
    info = paper_env.skill_info()
    shapes = {
        "eef_pos": (3,), "eef_quat": (4,), "gripper_qpos": (2,), "object_pos": (3,), "object_quat": (4,),
        "object_half_size": (3,), "sponge_pos": (3,), "sponge_quat": (4,), "sponge_half_size": (3,),
        "sponge_home_pos": (3,), "segment_centers": (2, 3), "segment_half_sizes": (2, 2), "dirt_fraction": (2,),
    }
    for key, shape in shapes.items():
        assert np.shape(info[key]) == shape, key
    assert isinstance(info["table_top_z"], float)
    assert info["object_grasped"] is False and info["sponge_grasped"] is False
    np.testing.assert_allclose(info["sponge_pos"], info["sponge_home_pos"], atol=2e-3)
    # eef_quat is the eef *site* orientation, as the robot's robot0_eef_quat_site observable
    site_quat = fresh_observations(paper_env)["robot0_eef_quat_site"]
    assert abs(abs(np.dot(info["eef_quat"], site_quat)) - 1.0) < 1e-5
    for segment in (SEGMENT_1, SEGMENT_2):
        assert paper_env.segment_of_position(info["segment_centers"][segment][:2]) == segment
    assert paper_env.segment_of_position(info["sponge_home_pos"][:2]) is None


# -- wiping ------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_hovering_5mm_above_removes_no_dirt(paper_env):
    raster(paper_env, SEGMENT_2, paper_env.skill_info()["table_top_z"] + HOVER_GAP, hold=True)
    np.testing.assert_array_equal(paper_env.dirt_fraction(), [1.0, 1.0])


@pytest.mark.slow
def test_pressing_the_sponge_cleans_that_segment_only(paper_env):
    env = paper_env
    top = env.skill_info()["table_top_z"]
    info = env.skill_info()
    put_sponge(env, info["segment_centers"][1] + [0.0, 0.0, info["sponge_half_size"][2] - PRESS_DEPTH])
    env.step(np.zeros(env.action_dim))
    first = env.dirt_fraction()
    assert 0.0 < first[1] < 1.0 and first[0] == 1.0  # some, not all, markers went with one press
    wiped = ~env.dirt.present().reshape(env.n_segments, -1)[1]
    assert np.all(env.sim.model.geom_rgba[env.marker_geom_ids[len(wiped):][wiped], 3] == 0.0)  # hidden
    raster(env, SEGMENT_2, top - PRESS_DEPTH, hold=False)
    assert env.dirt_fraction()[0] == 1.0
    assert env.dirt_fraction()[1] <= 1.0 - DEFAULT_TABLECLEAN_CONFIG["clean_fraction"]
    env.step(np.zeros(env.action_dim))
    assert env.symbolic_state() == TaskState((False, True), (SEGMENT_1,), SEGMENT_1)


@pytest.mark.slow
def test_success_and_rewards_once_every_dirty_segment_is_clean():
    env = env_for(1, 1, dirty_segments=(2,))
    env.reset()
    zero = np.zeros(env.action_dim)
    assert not env._check_success() and env.reward() == 0.0
    env.reward_shaping = True
    try:
        # segment 1 starts clean (wiping 1.0 of 2), the object lies on the table, the sponge is home
        assert env.staged_rewards() == (pytest.approx(1.0), 0.25, 0.5)
        assert env.reward() == pytest.approx(1.75 / 3.0 * env.reward_scale)
        raster(env, SEGMENT_2, env.skill_info()["table_top_z"] - PRESS_DEPTH, hold=False)
        for _ in range(5):
            env.step(zero)  # let the sponge settle at home
        assert env._check_success()
        assert env.reward() == pytest.approx(env.reward_scale)
    finally:
        env.reward_shaping = False
    put_sponge(env, env.skill_info()["sponge_home_pos"] + [0.0, 0.0, 0.1], hold=True)
    assert not env._check_success()  # the sponge must be home


# -- seeding and rendering ----------------------------------------------------------------------------
def initial_physical_state(seed: int) -> np.ndarray:
    env = make(seed=seed)  # random layout and placement noise
    try:
        env.reset()
        return np.concatenate([env.sim.data.qpos, env.dirt_fraction()]).copy()
    finally:
        env.close()


@pytest.mark.slow
def test_same_seed_same_initial_state_different_seed_differs():
    first, again, other = initial_physical_state(3), initial_physical_state(3), initial_physical_state(4)
    np.testing.assert_array_equal(first, again)
    assert not np.allclose(first, other)


@pytest.mark.slow
@pytest.mark.parametrize("object_type", ["box", "can"])
def test_other_object_types_reset_to_the_start_layout(object_type):
    env = make(object_segment=2, arm_segment=1, task_config={"object_type": object_type})
    try:
        env.reset()
        for _ in range(5):
            env.step(np.zeros(env.action_dim))
        assert env.symbolic_state() == start_layout(2, 1)
    finally:
        env.close()


@pytest.mark.slow
def test_offscreen_frame_is_not_blank():
    try:
        env = make(object_segment=1, arm_segment=2, has_offscreen_renderer=True)
        env.reset()
        frame = env.sim.render(width=160, height=120, camera_name="tableview")
    except Exception as error:  # no usable OpenGL backend on this machine
        pytest.skip(f"offscreen rendering unavailable: {error}")
    env.close()
    assert frame.shape == (120, 160, 3)
    assert frame.std() > 10  # a real scene, not a uniform colour
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 100


# -- the scene starts where the task spec says -------------------------------------------
THREE_SEGMENTS_FIXED = TaskSpec("three_fixed", segments=3, objects=("box", "cylinder"),
                                start_state=TaskState((False, True, False), (2, 0), 1))


def test_task_spec_fixed_start_is_the_reset_state_in_robosuite_make_and_make_skill_env():
    from tableclean_suite.controllers import make_skill_env

    for env in (make(task=THREE_SEGMENTS_FIXED), make_skill_env(task=THREE_SEGMENTS_FIXED, seed=0)):
        try:
            for _ in range(2):
                env.reset()
                assert env.symbolic_state() == THREE_SEGMENTS_FIXED.start_state
        finally:
            env.close()


def test_uniform_unclean_spec_draws_all_unclean_layouts_at_each_reset():
    spec = TaskSpec("three_uniform", segments=3, objects=("box",), start="uniform_unclean")
    env = make(task=spec)
    try:
        seen = set()
        for _ in range(12):
            env.reset()
            state = env.symbolic_state()
            assert not any(state.clean) and not state.holding
            seen.add(state.index)
        assert len(seen) >= 4  # 9 layouts; a fixed start would give one
    finally:
        env.close()


def test_an_explicit_layout_wins_over_the_spec_and_no_task_keeps_drawing():
    env = make(task=THREE_SEGMENTS_FIXED, object_segment=2, arm_segment=3)
    try:
        env.reset()
        state = env.symbolic_state()
        assert state.objects == (1, 1) and state.arm == 2 and not any(state.clean)
    finally:
        env.close()
    plain = env_for(None, None)
    arms = set()
    for _ in range(8):
        plain.reset()
        arms.add(plain.symbolic_state().arm)
    assert arms == {0, 1}


def test_a_spec_starting_with_a_held_object_is_refused_by_the_scene_naming_the_remedy():
    from tableclean_suite.task import HELD

    spec = TaskSpec("held_start", start_state=TaskState((False, False), (HELD,), 0))
    with pytest.raises(ValueError, match="held_start.*holds an object.*physics_backend.stage"):
        make(task=spec)


def test_dirt_positions_read_the_dirt_state_joints():
    """The dirt markers' positions (the decoded caches' key) equal the joints' qpos gathered by address, also for
    unevenly spaced addresses."""
    from tableclean_suite.controllers import make_skill_env
    from tableclean_suite.environments.state_reading import DirtMarkers

    env = make_skill_env(2, 1, seed=4)
    try:
        env.reset()
        dirt = env.dirt
        qpos = env.sim.data.qpos
        addr = dirt.qpos_addr
        qpos[list(addr)] = np.arange(1, len(addr) + 1) * 0.25
        assert dirt.positions() == tuple(float(qpos[a]) for a in addr)
        uneven = (addr[0], addr[0] + 1, addr[0] + 3)
        other = DirtMarkers(mj_data(env.sim), dirt.joints, uneven, dirt.qvel_addr, dirt.markers_per_segment,
                            np.zeros((0, 4)), np.zeros(0, dtype=int))
        assert other.positions() == tuple(float(qpos[a]) for a in uneven)
    finally:
        env.close()
