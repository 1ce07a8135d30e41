"""The dirt is MuJoCo state: its encoding, robosuite's get_state/set_state, a recorded demo replayed."""

import json
from pathlib import Path

import numpy as np
import pytest

from tableclean_suite.environments import dirt_state
from tableclean_suite.environments.config import make_config
from tableclean_suite.environments.dirt_state import MAX_MARKERS_PER_SEGMENT, DirtStateError
from tableclean_suite.task import Action, TaskModel

PRESS_DEPTH = 0.0005  # the sponge's underside 0.5 mm into the table top


# -- the encoding (no physics) --------------------------------------------------------------------
@pytest.mark.parametrize("n_markers", [1, 25, MAX_MARKERS_PER_SEGMENT])
def test_every_set_of_wiped_flags_round_trips_exactly(n_markers):
    rng = np.random.default_rng(n_markers)
    for flags in [np.zeros(n_markers, bool), np.ones(n_markers, bool), *(rng.random((20, n_markers)) < 0.5)]:
        position = dirt_state.encode(flags)
        assert 0.0 <= position < 1.0
        np.testing.assert_array_equal(dirt_state.decode(position, n_markers), flags)


def test_positions_that_encode_no_flags_are_reported_naming_the_joint():
    for bad in (0.3, -0.5, 1.0, np.nan):
        with pytest.raises(DirtStateError, match=r"dirt_state_s2_joint is at .*encodes no wiped flags of 4 markers"):
            dirt_state.decode(bad, 4, "dirt_state_s2_joint")
    with pytest.raises(ValueError, match=rf"markers per segment must be an integer in \[1, {MAX_MARKERS_PER_SEGMENT}\], got 53"):
        dirt_state.encode(np.zeros(53, bool))
    with pytest.raises(ValueError, match=r"marker_grid.*56 markers per segment.*at most 52"):
        make_config({"marker_grid": (8, 7)})


# -- physics --------------------------------------------------------------------------------------
def _make(**kwargs):
    from tableclean_suite.controllers import make_skill_env

    return make_skill_env(**kwargs)


def _press_sponge_on_segment_2(env):
    """One control step with the sponge pressed on segment 2's centre: wipes some of its markers."""
    info = env.skill_info()
    pos = info["segment_centers"][1] + [0.0, 0.0, info["sponge_half_size"][2] - PRESS_DEPTH]
    env.sim.data.set_joint_qpos(env.sponge.joints[0], np.concatenate([pos, [1.0, 0.0, 0.0, 0.0]]))
    env.sim.data.set_joint_qvel(env.sponge.joints[0], np.zeros(6))
    env.sim.forward()
    env.step(np.concatenate([info["eef_pos"], [np.pi, 0.0, 0.0], [-1.0]]))


@pytest.mark.slow
def test_robosuite_state_save_and_restore_carries_the_dirt_into_a_fresh_env():
    env, fresh = _make(object_segment=1, arm_segment=1), _make(object_segment=1, arm_segment=1)
    try:
        env.reset()
        _press_sponge_on_segment_2(env)
        wiped = ~env.dirt.present().reshape(env.n_segments, -1)
        assert 0 < wiped[1].sum() < wiped.shape[1] and not wiped[0].any()
        saved = env.sim.get_state().flatten()  # what DataCollectionWrapper records
        fresh.reset()
        assert fresh.dirt.present().all()
        fresh.sim.set_state_from_flattened(saved)
        fresh.sim.forward()
        np.testing.assert_array_equal(fresh.dirt.present(), env.dirt.present())
        np.testing.assert_array_equal(fresh.dirt_fraction(), env.dirt_fraction())
        fresh._get_observations(force_update=True)  # what robomimic's reset_to does next: visuals follow
        np.testing.assert_array_equal(fresh.sim.model.geom_rgba[fresh.marker_geom_ids, 3],
                                      fresh.dirt.present().astype(float))
        # the scene-state snapshot restores the dirt too, and a bad dirt state is reported, not guessed
        snapshot = fresh.get_scene_state()
        fresh.reset()
        fresh.set_scene_state(snapshot)
        np.testing.assert_array_equal(fresh.dirt.present(), env.dirt.present())
        fresh.sim.data.qpos[fresh.dirt.qpos_addr[1]] = 0.3
        with pytest.raises(DirtStateError, match="dirt_state_s2_joint"):
            fresh.dirt_fraction()
    finally:
        env.close()
        fresh.close()


@pytest.mark.slow
def test_skill_demo_recorded_with_data_collection_wrapper_replays_state_by_state(tmp_path):
    import robosuite
    from robosuite.wrappers import DataCollectionWrapper

    from tableclean_suite.controllers import SkillController

    model = TaskModel()
    # robosuite's env.step path: the wrapper records in its step()
    env = DataCollectionWrapper(_make(object_segment=2, arm_segment=1, seed=3, fast_control=False), str(tmp_path))
    try:
        env.reset()
        result = SkillController(env, model).execute(Action.CLEAN)  # wipes segment 1, sponge back home
        assert result.success, result.reason
        recorded_state, recorded_success = env.symbolic_state(), env._check_success()
        recorded_dirt = env.dirt_fraction()
        assert recorded_state.clean == (True, False) and recorded_dirt[0] < 1.0
        meta_live = env.get_ep_meta()
    finally:
        env.close()  # flushes the episode
    (episode,) = [p for p in Path(tmp_path).iterdir() if p.is_dir()]
    states = np.concatenate([np.load(f, allow_pickle=True)["states"] for f in sorted(episode.glob("state_*.npz"))])
    assert len(states) == result.steps + 1  # the initial state, then one per control step
    meta = json.loads((episode / "ep_meta.json").read_text())
    assert meta["task_spec"] == model.spec.to_dict() == meta_live["task_spec"]
    assert meta["task_config"]["marker_grid"] == list(make_config()["marker_grid"])
    assert meta["task_config"].keys() == make_config().keys()
    assert meta["start"] == {"object_segment": 2, "arm_segment": 1, "dirty_segments": [1, 2]}

    replay = robosuite.make("TableClean", robots="Panda", has_renderer=False, has_offscreen_renderer=False,
                            use_camera_obs=False, ignore_done=True)
    try:
        replay.reset()
        replay.reset_from_xml_string((episode / "model.xml").read_text())
        dirt = []
        for state in states:
            replay.sim.set_state_from_flattened(state)
            replay.sim.forward()
            dirt.append(replay.dirt_fraction())
        assert replay.symbolic_state() == recorded_state  # dirt included
        assert replay._check_success() == recorded_success
        np.testing.assert_array_equal(replay.dirt_fraction(), recorded_dirt)
        dirt = np.array(dirt)
        assert dirt[0].tolist() == [1.0, 1.0] and np.all(np.diff(dirt[:, 0]) <= 0)  # wiped step by step
    finally:
        replay.close()
