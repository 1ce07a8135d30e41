"""The physical task for any spec: layout, object registry, multi-object abstraction, staging, skills and plans.

Unit tests run without MuJoCo; the ``slow`` ones build scenes and run skills in physics.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tableclean_suite.environments import AbstractionError, Fault, abstract_state
from tableclean_suite.environments.config import LayoutError, make_config, max_segments, scene_geometry
from tableclean_suite.environments.objects import ObjectType, get_object_type, object_type_names, register_object
from tableclean_suite.environments.placement import footprint_of, free_spot
from tableclean_suite.physics_backend import check_physical_task, start_of
from tableclean_suite.task import HELD, Outcome, TaskModel, TaskSpec, TaskState, get_task_spec, task_spec_names

CONFIG = make_config()
SPEC = "three_segments_two_objects"
MODEL = TaskModel(spec=SPEC)
GAP_SAMPLING = 2e-3  # m the sampled directions of footprint_gap may take off a gap (a 10 cm footprint: ~1 mm)
#: Directions footprint_gap samples over a full turn.
GAP_DIRECTIONS = 360


def footprint_gap(xy_a, footprint_a, xy_b, footprint_b) -> float:
    """Gap [m] between two footprints (a radius or an outline (K, 2), as placement's) with origins at world
    ``xy_a`` and ``xy_b``: their largest separation along GAP_DIRECTIONS directions (never more than the true
    gap; negative when they overlap)."""
    angles = np.arange(GAP_DIRECTIONS) * (2 * np.pi / GAP_DIRECTIONS)
    directions = np.stack([np.cos(angles), np.sin(angles)])

    def reach(footprint, sign):  # how far the footprint reaches along each direction (times sign)
        if np.ndim(footprint) == 0:
            return np.full(GAP_DIRECTIONS, float(footprint))
        return (np.asarray(footprint, dtype=float) @ (sign * directions)).max(axis=0)

    along = (np.asarray(xy_b, dtype=float)[:2] - np.asarray(xy_a, dtype=float)[:2]) @ directions
    return float(np.max(along - reach(footprint_b, -1) - reach(footprint_a, 1)))


# ---------------------------------------------------------------------------------------------
# unit tests
# ---------------------------------------------------------------------------------------------
def test_footprint_gap_of_two_rectangles_and_two_discs():
    cereal = np.array([[-0.05, -0.015], [0.05, -0.015], [0.05, 0.015], [-0.05, 0.015]])
    box = np.array([[-0.0225, -0.0225], [0.0225, -0.0225], [0.0225, 0.0225], [-0.0225, 0.0225]])
    assert footprint_gap([0.0, 0.0], cereal, [0.1, 0.0], box) == pytest.approx(0.1 - 0.05 - 0.0225, abs=1e-4)
    assert footprint_gap([0.0, 0.0], 0.02, [0.03, 0.04], 0.01) == pytest.approx(0.02, abs=1e-5)
    assert footprint_gap([0.0, 0.0], cereal, [0.0, 0.0], box) < 0  # overlapping


def test_paper_layout_is_unchanged_and_larger_layouts_stay_in_reach():
    paper = scene_geometry(CONFIG, 2)
    np.testing.assert_allclose(paper.segment_centers[:, :2], [[0.0, -0.14], [0.0, 0.14]])
    np.testing.assert_allclose(paper.segment_half_sizes, 0.12)
    low, high = CONFIG["reach_x"]
    for n in (3, 4):
        g = scene_geometry(CONFIG, n)
        assert len(g.segment_centers) == n
        x = g.segment_centers[:, 0] - g.table_center[0]
        assert np.all(x - g.segment_half_sizes[:, 0] >= low - 1e-9) and np.all(x + g.segment_half_sizes[:, 0] <= high + 1e-9)
        steps = np.linalg.norm(np.diff(np.vstack([g.segment_centers, g.segment_centers[:1]]), axis=0), axis=1)
        assert np.all(steps < 0.5)  # MOVE k -> k + 1 (and N -> 1) goes to a neighbouring segment
        for a in range(n):  # segments never overlap
            for b in range(a + 1, n):
                assert np.any(np.abs(g.segment_centers[a, :2] - g.segment_centers[b, :2]) >= 2 * g.segment_half_sizes[a] - 1e-9)


def test_more_segments_than_the_reach_allows_are_refused_naming_the_limit():
    assert max_segments(CONFIG) == 4
    with pytest.raises(LayoutError, match=r"at most 4 segments, got 5.*reach band"):
        scene_geometry(CONFIG, 5)
    with pytest.raises(ValueError, match=r"task 'five'.*at most 4 segments"):
        check_physical_task(TaskModel(spec=TaskSpec("five", segments=5)))


def test_every_builtin_spec_is_accepted_by_the_physical_check():
    from tableclean_suite.task.spec import BUILTIN_SPECS

    for spec in BUILTIN_SPECS:  # not what other tests registered in this process
        check_physical_task(TaskModel(spec=spec))


def test_a_spec_whose_action_has_no_skill_is_refused():
    from tableclean_suite.task import ActionRule, register_action

    register_action(ActionRule("teleport_test", lambda s: (s, Outcome.ROUTINE)), overwrite=True)
    spec = TaskSpec("with_teleport", actions=("move", "pick", "place", "clean", "teleport_test"))
    with pytest.raises(ValueError, match=r"no skill registered for action\(s\) \['teleport_test'\]"):
        check_physical_task(TaskModel(spec=spec))


def test_object_registry_ships_the_types_and_refuses_bad_ones():
    catalog = {"box", "cylinder", "can", "bread", "bottle", "lemon", "milk", "cereal", "tall_box", "tower_box",
               "tall_cylinder"}
    assert catalog <= set(object_type_names())
    assert get_object_type("cylinder").yaw_rule is None  # derived from the geometry: round
    with pytest.raises(ValueError, match=r"unknown object_type 'banana'; allowed: .*bread.*cylinder"):
        get_object_type("banana")
    with pytest.raises(ValueError, match="footprint_radius"):
        ObjectType("flat", lambda name, config: None, footprint_radius=0.0)
    with pytest.raises(ValueError, match="yaw_rule"):
        ObjectType("flat", lambda name, config: None, footprint_radius=0.02, yaw_rule="diagonal")
    with pytest.raises(ValueError, match="already registered"):
        register_object(get_object_type("box"))
    with pytest.raises(ValueError, match="do not fit side by side"):
        check_physical_task(TaskModel(spec=TaskSpec("crowded", segments=3, objects=("bread",) * 5)))


def test_free_spot_keeps_clear_of_the_objects_lying_there():
    center, half = np.array([0.0, 0.0, 0.8]), np.array([0.09, 0.09])
    assert np.allclose(free_spot(center, half, 0.03, [], 0.01), [0.0, 0.0])
    others = [(np.array([0.0, 0.0, 0.82]), 0.032)]
    spot = free_spot(center, half, 0.03, others, 0.01)
    assert np.linalg.norm(spot) >= 0.03 + 0.032 + 0.01 - 1e-9
    assert np.all(np.abs(spot) + 0.03 <= half + 1e-9)


def test_staging_plan_defers_lower_numbered_objects_on_the_arms_segment():
    # o1 on S1, o2 held, arm over S1: PICK would take o1, so o1 starts on S2 and is put back after the pick
    state = TaskState((False, False, False), (0, HELD), 0)
    assert start_of(state) == ((2, 1), 1, (1, 2, 3), (0,))
    assert start_of(TaskState((True, False, False), (HELD, 0), 0)) == ((1, 1), 1, (2, 3), ())


def _obs(objects_pos, grasped, rest_z=0.8225):
    geometry = scene_geometry(CONFIG, 3)
    return {
        "dirt_fraction": np.ones(3), "eef_pos": geometry.segment_centers[0] + [0, 0, 0.1],
        "objects_pos": np.asarray(objects_pos, dtype=float), "objects_grasped": np.asarray(grasped),
        "objects_rest_z": np.full(len(objects_pos), rest_z),
        "segment_centers": geometry.segment_centers, "segment_half_sizes": geometry.segment_half_sizes,
        "sponge_pos": geometry.sponge_home_pos,
    }


def test_multi_object_abstraction_reads_every_object_and_reports_what_it_cannot_map():
    geometry = scene_geometry(CONFIG, 3)
    c = geometry.segment_centers
    state = abstract_state(_obs([c[0] + [0, 0, 0.0225], c[2] + [0, 0, 0.0225]], [False, False]), CONFIG)
    assert state == TaskState((False, False, False), (0, 2), 0)
    held = abstract_state(_obs([c[0] + [0, 0, 0.1], c[2] + [0, 0, 0.0225]], [True, False]), CONFIG)
    assert held.objects == (HELD, 2)
    with pytest.raises(AbstractionError) as error:
        abstract_state(_obs([c[0] + [0, 0, 0.1], c[0] + [0, 0, 0.1]], [True, True]), CONFIG)
    assert error.value.fault == Fault.OBJECTS_HELD
    between = (c[0] + c[1]) / 2 + [0, 0, 0.0225]
    with pytest.raises(AbstractionError) as error:
        abstract_state(_obs([c[0] + [0, 0, 0.0225], between], [False, False]), CONFIG)
    assert error.value.fault == Fault.OBJECT_BETWEEN_SEGMENTS and "object 2" in str(error.value)


# ---------------------------------------------------------------------------------------------
# physics
# ---------------------------------------------------------------------------------------------
def _make(task, **kwargs):
    import robosuite

    import tableclean_suite  # noqa: F401

    settings = dict(robots="Panda", has_renderer=False, has_offscreen_renderer=False, use_camera_obs=False,
                    ignore_done=True, seed=0, task=task)
    settings.update(kwargs)
    return robosuite.make("TableClean", **settings)


@pytest.mark.slow
@pytest.mark.parametrize("name", task_spec_names())
def test_scene_builds_every_registered_spec(name):
    spec = get_task_spec(name)
    env = _make(name, object_segment=1, arm_segment=1)
    try:
        env.reset()
        assert env.n_segments == spec.segments and len(env.objects) == spec.n_objects
        assert [k.name for k in env.object_types] == list(spec.objects)
        assert env.dirt.present().shape == (spec.segments * 25,) and env.dirt.present().all()
        assert len(env.arena.dirt_state_joint_names) == spec.segments
        assert env.symbolic_state() == TaskModel(spec=name).start_state
        meta = env.get_ep_meta()
        assert meta["task_spec"] == spec.to_dict() and meta["object_types"] == list(spec.objects)
        info = env.skill_info()
        assert info["segment_centers"].shape == (spec.segments, 3) and info["objects_pos"].shape == (spec.n_objects, 3)
        # objects sharing segment 1 keep object_clearance between their footprints (as they stand)
        pos = info["objects_pos"]
        for a in range(len(pos)):
            for b in range(a + 1, len(pos)):
                gap = footprint_gap(pos[a], footprint_of(info, a), pos[b], footprint_of(info, b))
                assert gap >= env.task_config["object_clearance"] - GAP_SAMPLING
    finally:
        env.close()


@pytest.mark.slow
def test_unknown_object_type_fails_at_construction_with_the_registered_names():
    with pytest.raises(ValueError, match=r"unknown object_type 'banana'; allowed: .*box.*cylinder"):
        _make(TaskSpec("fruit", objects=("banana",)))


@pytest.fixture(scope="module")
def skill_env():
    from tableclean_suite.controllers import SkillController, make_skill_env

    env = make_skill_env(None, None, task=SPEC, seed=7)
    yield env, SkillController(env, MODEL)
    env.close()


def _stage(env, controller, state, seed=0):
    from tableclean_suite.physics_backend import stage

    return stage(env, controller, state, seed=seed)


# canonical states of a 3-segment, 2-object (box + cylinder) spec and the skill under test
U = (False, False, False)
CANONICAL = {
    "move_empty": (TaskState(U, (0, 0), 0), "move"),
    "move_holding_cylinder_row_to_row": (TaskState(U, (1, HELD), 1), "move"),
    "move_back_to_segment_1": (TaskState(U, (1, 1), 2), "move"),
    "pick_box_with_cylinder_beside": (TaskState(U, (0, 0), 0), "pick"),
    "pick_cylinder": (TaskState(U, (1, 2), 2), "pick"),
    "pick_held_staging_with_box_deferred": (TaskState(U, (0, HELD), 0), "place"),
    "place_next_to_the_box": (TaskState(U, (2, HELD), 2), "place"),
    "clean_far_row": (TaskState(U, (0, 0), 2), "clean"),
}


@pytest.mark.slow
@pytest.mark.parametrize("case", list(CANONICAL))
def test_each_skill_from_its_canonical_states_reaches_the_models_successor(skill_env, case):
    env, controller = skill_env
    state, action = CANONICAL[case]
    assert _stage(env, controller, state) == state
    result = controller.execute(action)
    expected, outcome = MODEL.step(state, action)
    assert result.success, result.reason
    assert env.symbolic_state() == expected == result.state_after and result.outcome == outcome


@pytest.mark.slow
@pytest.mark.parametrize("start", [TaskState(U, (0, 0), 0), TaskState(U, (2, 1), 1), TaskState(U, (1, 0), 2)])
def test_optimal_plan_reaches_the_terminal_state(skill_env, start):
    env, controller = skill_env
    assert _stage(env, controller, start, seed=3) == start
    results = controller.execute_plan(MODEL.shortest_plan(start))
    assert all(r.success for r in results), [r.reason for r in results if not r.success]
    assert results[-1].state_after.is_terminal and results[-1].outcome == Outcome.TERMINAL
    assert len(results) == len(MODEL.shortest_plan(start))


@pytest.mark.slow
def test_data_collection_wrapper_records_with_the_fast_stepper_on(tmp_path):
    from robosuite.wrappers import DataCollectionWrapper

    from tableclean_suite.controllers import SkillController, make_skill_env
    from tableclean_suite.controllers.fast_control import fast_stepper_of

    inner = make_skill_env(1, 1, seed=0)  # fast_control=True by default
    assert fast_stepper_of(inner) is not None
    env = DataCollectionWrapper(inner, str(tmp_path))
    try:
        env.reset()
        result = SkillController(env).execute("pick")
        assert result.success, result.reason
    finally:
        env.close()
    (episode,) = [p for p in Path(tmp_path).iterdir() if p.is_dir()]
    states = np.concatenate([np.load(f, allow_pickle=True)["states"] for f in sorted(episode.glob("state_*.npz"))])
    assert len(states) == result.steps + 1  # every control step went through the wrapper's step()


@pytest.mark.slow
def test_physics_backend_trains_on_a_larger_spec_and_follows_the_model():
    """train(backend="physics") on three segments and two objects: where physics agrees with the
    model (no faults, no skill failures), the records equal the symbolic backend's, value for value."""
    from tableclean_suite.learners import train

    kwargs = dict(learner="q_learning", reward="r2", runs=1, iterations=12, seed=0, task="three_segments_two_objects")
    physics = train(backend="physics", workers=1, **kwargs)
    assert physics.q.shape == (1, 384, 4)
    assert physics.info["physics"]["faults"] == 0 and physics.info["physics"]["skill_failures"] == 0
    symbolic = train(**kwargs)
    for name in ("states", "actions", "outcomes", "rewards", "episode_end"):
        np.testing.assert_array_equal(getattr(physics, name), getattr(symbolic, name))
