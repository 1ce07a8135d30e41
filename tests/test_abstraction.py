"""The physical-to-symbolic abstraction on synthetic observations (no MuJoCo)."""

import numpy as np
import pytest

from tableclean_suite.environments import DEFAULT_TABLECLEAN_CONFIG, AbstractionError, Fault, abstract_state
from tableclean_suite.environments.abstraction import segment_of_xy, segments_clean
from tableclean_suite.environments.config import make_config, scene_geometry
from tableclean_suite.task import TaskModel, TaskState

CONFIG = make_config()
GEOMETRY = scene_geometry(CONFIG)
REST_Z = GEOMETRY.table_top_z + CONFIG["object_half_size"][2]
HOVER = np.array([0.0, 0.0, CONFIG["arm_hover_height"]])
DIRTY, CLEAN = 1.0, 0.0


def center(segment: int) -> np.ndarray:
    """(3,) table-top centre of ``segment`` (0-based)."""
    return GEOMETRY.segment_centers[segment].copy()


def obs_for(state: TaskState) -> dict:
    """A physically consistent observation of ``state`` (object held 10 cm above the table when in gripper)."""
    eef = center(state.arm) + HOVER
    if state.holding:
        object_pos, grasped = eef - np.array([0.0, 0.0, 0.01]), True
    else:
        (segment,) = state.objects
        object_pos, grasped = center(segment) + [0.0, 0.0, REST_Z - GEOMETRY.table_top_z], False
    return {
        "dirt_fraction": np.array([CLEAN if clean else DIRTY for clean in state.clean]),
        "object_pos": object_pos,
        "object_grasped": grasped,
        "eef_pos": eef,
        "sponge_pos": GEOMETRY.sponge_home_pos.copy(),
        "sponge_grasped": False,
        "qvel": np.zeros(21),
    }


PAPER_START_OBS = obs_for(TaskState((False, False), (0,), 0))


def with_(obs: dict, **changes) -> dict:
    out = dict(obs)
    out.update(changes)
    return out


def fault_of(obs: dict, **kwargs) -> AbstractionError:
    with pytest.raises(AbstractionError) as info:
        abstract_state(obs, **kwargs)
    return info.value


@pytest.mark.parametrize("state", TaskModel().all_states(), ids=lambda s: str(s.index))
def test_every_state_round_trips_through_a_synthetic_observation(state):
    assert abstract_state(obs_for(state)) == state


def test_clean_threshold_follows_clean_fraction():
    threshold = 1.0 - CONFIG["clean_fraction"]
    assert segments_clean([threshold, threshold + 0.01]).tolist() == [True, False]
    assert segments_clean([0.5, 0.51], {"clean_fraction": 0.5}).tolist() == [True, False]
    assert segments_clean([0.0, 1.0, 0.0]).tolist() == [True, False, True]  # any number of segments
    with pytest.raises(ValueError, match="shape"):
        segments_clean([[0.0, 0.0]])


def test_grasped_but_resting_object_still_lies_on_its_segment():
    obs = with_(PAPER_START_OBS, object_grasped=True)
    assert abstract_state(obs).objects == (0,)


def test_arm_segment_margin_and_nearest_segment():
    margin = CONFIG["arm_segment_margin"]
    seg2 = center(1)
    half = GEOMETRY.segment_half_sizes[1]
    just_outside = seg2 + [half[0] + margin / 2, 0.0, 0.2]
    assert abstract_state(with_(PAPER_START_OBS, eef_pos=just_outside)).arm == 1
    # in the gap both grown areas contain the gripper: the nearer segment wins
    gap_y = GEOMETRY.table_center[1] + 0.001
    assert segment_of_xy([0.0, gap_y], GEOMETRY.segment_centers, GEOMETRY.segment_half_sizes, margin) == 1
    assert segment_of_xy([0.0, gap_y], GEOMETRY.segment_centers, GEOMETRY.segment_half_sizes) is None


def test_object_between_segments_is_a_fault():
    pos = np.array([GEOMETRY.table_center[0], GEOMETRY.table_center[1], REST_Z])
    error = fault_of(with_(PAPER_START_OBS, object_pos=pos))
    assert error.fault == Fault.OBJECT_BETWEEN_SEGMENTS
    assert "neither segment" in str(error)


@pytest.mark.parametrize(
    "offset", [(0.0, 0.0, -0.2), (GEOMETRY.table_half_size[0] + 0.05, 0.0, 0.0)], ids=["fell_below", "off_edge"]
)
def test_object_off_the_table_is_a_fault(offset):
    pos = np.array([GEOMETRY.table_center[0], GEOMETRY.table_center[1], REST_Z]) + offset
    assert fault_of(with_(PAPER_START_OBS, object_pos=pos)).fault == Fault.OBJECT_OFF_TABLE


def test_object_lifted_but_not_grasped_is_a_fault():
    pos = PAPER_START_OBS["object_pos"] + [0.0, 0.0, 2 * CONFIG["lift_tolerance"]]
    error = fault_of(with_(PAPER_START_OBS, object_pos=pos))
    assert error.fault == Fault.OBJECT_LIFTED_NOT_GRASPED
    assert "not grasped" in str(error)
    # within the tolerance it still lies on its segment
    small = PAPER_START_OBS["object_pos"] + [0.0, 0.0, CONFIG["lift_tolerance"] / 2]
    assert abstract_state(with_(PAPER_START_OBS, object_pos=small)).objects == (0,)


def test_arm_not_over_a_segment_is_a_fault():
    far = GEOMETRY.segment_centers[0] + [-0.3, 0.0, 0.2]
    error = fault_of(with_(PAPER_START_OBS, eef_pos=far))
    assert error.fault == Fault.ARM_NOT_OVER_SEGMENT
    assert "neither segment" in str(error)


def test_sponge_away_from_home_is_a_fault_unless_the_check_is_off():
    away = GEOMETRY.sponge_home_pos + [0.0, 0.0, 2 * CONFIG["sponge_home_tolerance"]]
    obs = with_(PAPER_START_OBS, sponge_pos=away)
    assert fault_of(obs).fault == Fault.SPONGE_AWAY_FROM_HOME
    assert abstract_state(obs, check_sponge=False) == abstract_state(PAPER_START_OBS)
    grasped_at_home = with_(PAPER_START_OBS, sponge_grasped=True)
    assert "grasped" in str(fault_of(grasped_at_home))


@pytest.mark.parametrize(
    "changes",
    [
        {"object_pos": np.array([np.nan, 0.0, 0.8])},
        {"eef_pos": np.array([0.0, np.inf, 1.0])},
        {"qvel": np.full(21, 10 * DEFAULT_TABLECLEAN_CONFIG["max_stable_speed"])},
    ],
    ids=["nan_object", "inf_eef", "fast"],
)
def test_instability_is_a_fault(changes):
    error = fault_of(with_(PAPER_START_OBS, **changes))
    assert error.fault == Fault.UNSTABLE


def test_missing_key_raises_key_error_naming_it():
    obs = dict(PAPER_START_OBS)
    del obs["object_grasped"]
    with pytest.raises(KeyError, match="object_grasped"):
        abstract_state(obs)


def test_geometry_in_the_observation_overrides_the_config():
    swapped = GEOMETRY.segment_centers[::-1].copy()
    state = abstract_state(with_(PAPER_START_OBS, segment_centers=swapped))
    assert state.objects == (1,) and state.arm == 1


def test_unknown_or_bad_config_raises():
    with pytest.raises(ValueError, match="unknown task_config key"):
        abstract_state(PAPER_START_OBS, {"clean_fractoin": 0.5})
    with pytest.raises(ValueError, match="clean_fraction"):
        abstract_state(PAPER_START_OBS, {"clean_fraction": 1.5})
