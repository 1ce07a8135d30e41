"""The wipe keeps the hand clear of objects around the segment; placement keeps objects away from neighbours."""

import numpy as np
import pytest

from tableclean_suite.bench.object_table import FALLBACK_PARTNER, markdown, partner_for
from tableclean_suite.controllers.clean import HAND_CLEARANCE, Wipe, hand_obstacles
from tableclean_suite.controllers.wipe_pattern import boustrophedon, clear_area
from tableclean_suite.environments.object_geometry import ObjectGeometry
from tableclean_suite.environments.placement import free_spot, other_segments, row_layout

CENTER = np.array([0.0, 0.0])
REACH = np.array([0.05, 0.065])  # sponge-centre half extents of an 18 cm segment, m
HAND = np.array([0.032, 0.104])  # the Panda hand's half extents with its long axis along y, m


def _hand_boxes(points, offset=np.zeros(2), hand=HAND):
    return [(p + offset - hand, p + offset + hand) for p in points]


def _gap(box_a, box_b):
    """Separation [m] of two axis-aligned boxes (negative: overlap depth along the shallower axis)."""
    (la, ha), (lb, hb) = box_a, box_b
    return float(np.max(np.maximum(lb - ha, la - hb)))


def test_clear_area_cuts_off_an_obstacle_beyond_a_strokes_end_and_keeps_the_margin():
    obstacle = np.array([[-0.02, -0.17, 0.02, -0.13]])  # a 4 cm object 4 cm beyond the segment's -y edge (at -0.09)
    center, half = clear_area(CENTER, REACH, np.zeros(2), HAND, obstacle, HAND_CLEARANCE)
    low, high = center - half, center + half
    assert high[1] == pytest.approx(REACH[1]) and low[0] == pytest.approx(-REACH[0])  # the other sides stay
    assert low[1] == pytest.approx(-0.13 + HAND[1] + HAND_CLEARANCE)  # the -y side moved just enough
    corners = np.array([[x, y] for x in (low[0], high[0]) for y in (low[1], high[1])])
    for box in _hand_boxes(corners):
        assert _gap(box, (obstacle[0, :2], obstacle[0, 2:])) >= HAND_CLEARANCE - 1e-12


def test_clear_area_ignores_objects_out_of_reach_and_beside_the_lanes_costs_little():
    far = np.array([[0.3, 0.3, 0.34, 0.34]])
    center, half = clear_area(CENTER, REACH, np.zeros(2), HAND, far, HAND_CLEARANCE)
    assert np.allclose(center, CENTER) and np.allclose(half, REACH)
    beside = np.array([[0.13, -0.02, 0.17, 0.02]])  # beside the lanes (x): the hand's narrow side faces it
    center, half = clear_area(CENTER, REACH, np.zeros(2), HAND, beside, HAND_CLEARANCE)
    assert np.allclose(half, REACH)  # 0.05 + 0.032 + 0.01 < 0.13: nothing to cut


def test_clear_area_follows_the_hand_offset_and_refuses_bad_sizes():
    obstacle = np.array([[-0.02, 0.13, 0.02, 0.17]])
    _, plain = clear_area(CENTER, REACH, np.zeros(2), HAND, obstacle, HAND_CLEARANCE)
    _, shifted = clear_area(CENTER, REACH, np.array([0.0, 0.01]), HAND, obstacle, HAND_CLEARANCE)
    assert (plain[1] * 2) - (shifted[1] * 2) == pytest.approx(0.01)  # a hand 1 cm further toward it: 1 cm less
    with pytest.raises(ValueError, match="margin"):
        clear_area(CENTER, REACH, np.zeros(2), HAND, obstacle, -0.01)
    with pytest.raises(ValueError, match="half extents"):
        clear_area(CENTER, np.array([-0.1, 0.1]), np.zeros(2), HAND, obstacle, 0.0)


def test_every_point_of_a_pattern_in_the_clear_area_keeps_the_hand_clear():
    obstacles = np.array([[-0.05, -0.17, -0.01, -0.12], [0.12, 0.0, 0.16, 0.04]])
    center, half = clear_area(CENTER, REACH, np.zeros(2), HAND, obstacles, HAND_CLEARANCE)
    footprint = np.array([0.04, 0.025])
    points = boustrophedon(center, half + footprint, footprint, 0.0, along_x=False)
    assert np.all(np.abs(points - center) <= half + 1e-12)
    for box in _hand_boxes(points):
        for obstacle in obstacles:
            assert _gap(box, (obstacle[:2], obstacle[2:])) >= HAND_CLEARANCE - 1e-12


def test_hand_obstacles_counts_only_objects_reaching_the_hands_underside():
    cube = ObjectGeometry(np.array([[sx, sy, sz] for sx in (-0.02, 0.02) for sy in (-0.02, 0.02)
                                    for sz in (-0.02, 0.02)]))
    info = {"objects_pos": np.array([[0.0, 0.2, 0.82], [0.1, 0.2, 0.90]]), "objects_grasped": np.array([False, False]),
            "objects_quat": np.array([[0.0, 0.0, 0.0, 1.0]] * 2), "objects_geometry": (cube, cube)}
    boxes = hand_obstacles(info, hand_bottom_z=0.86)  # the low cube's top (0.84) is 2 cm below: not in the way
    assert boxes.shape == (1, 4) and np.allclose(boxes[0], [0.08, 0.18, 0.12, 0.22])
    info["objects_grasped"] = np.array([False, True])  # a held object is no obstacle
    assert hand_obstacles(info, hand_bottom_z=0.86).shape == (0, 4)


def _wipe_area_beside(object_top: float) -> np.ndarray:
    """(2,) half extents [m] of the wipe area of an 18 cm segment with an object of top ``object_top``
    (m above the table) 3.6 cm beyond its +y edge (examples/custom_object.py's scene), for a Panda hand."""
    table_z = 0.8
    wipe = Wipe(0)
    wipe.config = {"edge_inset": 1.0, "max_drift_correction": 0.01, "max_press_depth": 0.02}
    wipe.yaw = np.pi / 2  # strokes along y: the hand's long (closing) axis along y
    wipe.hold_offset = np.array([0.0, 0.0, 0.002])
    half_z = object_top / 2
    box = ObjectGeometry(np.array([[sx, sy, sz] for sx in (-0.03, 0.03) for sy in (-0.02, 0.02)
                                   for sz in (-half_z, half_z)]))  # the example's 6 x 4 cm box, object_top tall
    info = {"segment_centers": np.array([[-0.11, -0.11, table_z]]), "segment_half_sizes": np.array([[0.09, 0.09]]),
            "table_top_z": table_z, "sponge_half_size": np.array([0.04, 0.025, 0.015]),
            "gripper_palm_height": 0.031, "gripper_hand_reach": 0.104, "gripper_hand_half_width": 0.032,
            "objects_pos": np.array([[-0.167, 0.058, table_z + half_z]]), "objects_grasped": np.array([False]),
            "objects_quat": np.array([[0.0, 0.0, 0.0, 1.0]]), "objects_geometry": (box,)}
    _, half = wipe._wipe_area(info, np.array([0.04, 0.025]))
    return half


def test_the_palm_passes_over_an_object_lower_than_its_underside_but_not_a_taller_one():
    # wiping, the Panda palm's underside is ~4.5 cm above the table (sponge half height 1.5 cm + grip
    # offset + palm 3.1 cm): a 3 cm flat box beside the segment leaves the whole segment to the sponge
    assert np.allclose(_wipe_area_beside(0.03), [0.05, 0.065])
    # a 4.4 cm cube at the same spot reaches the palm: the +y side shrinks (the hand keeps its clearance)
    assert _wipe_area_beside(0.044)[1] < 0.065 - 0.005


def _wipe_choosing_yaw(box_xy) -> tuple[Wipe, np.ndarray, dict]:
    """A Panda-sized wipe of segment 1 of three (the arm's base at -x) with a 4.5 cm cube at ``box_xy``
    (world, m), after :meth:`Wipe._choose_yaw`; returns the wipe, its first pass's strokes and the scene."""
    table_z = 0.8
    wipe = Wipe(0)
    wipe.config = {"edge_inset": 1.0, "max_drift_correction": 0.02, "nominal_yaw": np.pi / 2, "wipe_overlap": 0.0,
                   "repeat_lane_shift": 0.5}
    wipe.grasp_yaw = wipe.yaw = np.pi / 2
    wipe.turned = False
    wipe.hold_offset = np.array([0.0, 0.0, 0.002])
    cube = ObjectGeometry(np.array([[sx, sy, sz] for sx in (-0.0225, 0.0225) for sy in (-0.0225, 0.0225)
                                    for sz in (-0.0225, 0.0225)]))
    info = {"segment_centers": np.array([[-0.11, -0.11, table_z], [-0.11, 0.11, table_z], [0.11, 0.11, table_z]]),
            "segment_half_sizes": np.array([[0.09, 0.09]] * 3), "table_top_z": table_z,
            "sponge_half_size": np.array([0.04, 0.025, 0.015]), "sponge_quat": np.array([0.0, 0.0, 0.0, 1.0]),
            "gripper_palm_height": 0.031, "gripper_hand_reach": 0.104, "gripper_hand_half_width": 0.032,
            "robot_base_pos": np.array([-0.56, 0.0, 0.912]),
            "objects_pos": np.array([[*box_xy, table_z + 0.0225]]), "objects_grasped": np.array([False]),
            "objects_quat": np.array([[0.0, 0.0, 0.0, 1.0]]), "objects_geometry": (cube,)}
    strokes = wipe._choose_yaw(info)
    return wipe, strokes, info


def test_the_wipe_turns_its_hand_when_an_object_blocks_the_strokes_ends_and_strokes_toward_the_arm():
    # the cube 3 cm from the edge segment 1 shares with segment 2: at the grasp's yaw the hand, 10.4 cm
    # long along the strokes (y), would leave the edge row; turned, its 3.2 cm half width faces the cube
    wipe, strokes, info = _wipe_choosing_yaw((-0.059, 0.054))
    assert wipe.yaw == pytest.approx(0.0)  # a quarter turn clockwise of the nominal pi/2
    assert np.allclose(strokes[:, 1].max() + 0.04, -0.02)  # the sponge (4 cm half length along y) reaches the edge
    starts, ends = strokes[0::2], strokes[1::2]
    assert np.all(ends[:, 0] < starts[:, 0])  # every stroke toward the arm's base (-x)
    assert wipe._stroke_direction(info) == -1
    # nothing in the way: the grasp's yaw and its back-and-forth strokes stay
    wipe, strokes, info = _wipe_choosing_yaw((0.3, 0.3))
    assert wipe.yaw == np.pi / 2 and wipe._stroke_direction(info) == 0
    assert list(np.sign(strokes[1::2, 1] - strokes[0::2, 1])) == [1, -1, 1]  # along y, back and forth


def test_boustrophedon_runs_every_stroke_one_way_when_asked():
    footprint, half = np.array([0.025, 0.04]), np.array([0.09, 0.09])
    for direction in (-1, 1):
        points = boustrophedon(CENTER, half, footprint, 0.0, along_x=True, direction=direction)
        starts, ends = points[0::2], points[1::2]
        assert np.all(np.sign(ends[:, 0] - starts[:, 0]) == direction) and np.all(starts[:, 1] == ends[:, 1])
    both_ways = boustrophedon(CENTER, half, footprint, 0.0, along_x=True)
    assert list(np.sign(both_ways[1::2, 0] - both_ways[0::2, 0])) == [1, -1, 1]
    with pytest.raises(ValueError, match="direction"):
        boustrophedon(CENTER, half, footprint, 0.0, along_x=True, direction=2)


def test_free_spot_takes_the_centre_else_the_spot_farthest_from_the_other_segments():
    center, half = np.array([-0.11, 0.11]), np.array([0.09, 0.09])
    assert np.allclose(free_spot(center, half, 0.03, [], 0.01), center)
    others = [(np.array([-0.11, 0.11, 0.82]), 0.03)]
    # segment 2 of three: segment 1 below it (-y), segment 3 to its right (+x)
    neighbours = other_segments([[-0.11, -0.11], [-0.11, 0.11], [0.11, 0.11]], [[0.09, 0.09]] * 3, 1)
    spot = free_spot(center, half, 0.03, others, 0.01, neighbours)
    assert spot[0] < center[0] and spot[1] > center[1]  # the corner away from both neighbours
    assert np.linalg.norm(spot - center) >= 0.03 + 0.03 + 0.01 - 1e-9
    assert np.all(np.abs(spot - center) + 0.03 <= half + 1e-9)


def test_reset_spots_run_along_x_across_the_wiping_hand():
    box = np.array([[-0.0225, -0.0225], [0.0225, -0.0225], [0.0225, 0.0225], [-0.0225, 0.0225]])
    offsets = row_layout([box, box], [0.12, 0.12], 0.1, 0.01, 0.0).offsets
    assert np.allclose(offsets, [[-0.05, 0.0], [0.05, 0.0]])


def test_the_partner_actually_used_is_named_in_the_table():
    assert partner_for("milk", "mixed", "box") == "box"
    assert partner_for("box", "mixed", "box") == FALLBACK_PARTNER
    assert partner_for("box", "alone", "box") == ""
    row = {"object": "box", "setting": "mixed", "partner": FALLBACK_PARTNER, "skill": "pick", "executions": 2,
           "successes": 2, "success_rate": 1.0, "agreements": 2, "fidelity": 1.0, "episodes": 1,
           "episode_successes": 1, "seconds": 1.0}
    assert f"| box | mixed | {FALLBACK_PARTNER} | 1/1 |" in markdown([row])


def test_the_lower_bound_is_clopper_pearsons_and_the_table_shows_it_with_the_counts():
    from tableclean_suite.bench.object_table import lower_bound

    assert lower_bound(300, 300) == pytest.approx(0.05 ** (1 / 300))  # no failure: the exact closed form
    assert lower_bound(0, 0) == 0.0
    assert lower_bound(299, 300) < lower_bound(300, 300) < 1.0
    row = {"object": "can", "setting": "alone", "partner": "", "skill": "pick", "episodes": 300, "episode_successes": 300}
    many = markdown([dict(row, executions=300, successes=300, agreements=299)])
    few = markdown([dict(row, executions=100, successes=100, agreements=100)])
    # 0.05 ** (1/300) = 0.99006, 299 of 300: 0.98427; 0.05 ** (1/100) = 0.97049
    assert many.endswith("| 300/300, fid 299/300: >= 99.0 % / 98.4 % |")
    assert few.endswith("| 100/100, fid 100/100: >= 97.0 % / 97.0 % |")
    assert "ok" not in many.split() and "below" not in many.split()


def test_a_bound_is_rounded_down_never_up():
    row = {"object": "milk", "setting": "mixed", "partner": "box", "skill": "clean", "episodes": 155,
           "episode_successes": 154, "executions": 464, "successes": 463, "agreements": 463}
    line = markdown([row])
    assert line.endswith("| 154/155 | 463/464, fid 463/464: >= 98.9 % / 98.9 % |")  # 0.98977: not rounded up to 99.0


#: A layout the reset's placement and the place skill produced (lemon mixed, seed 1, episode 18 of 155, before
#: placement by outlines): segment 2 holds a lemon at its centre and the 4.5 cm box 3 cm from the edge it shares
#: with segment 1, whose clean is next (world xy, m; both at yaw 0).
EDGE_BOX_LAYOUT = ((-0.112, 0.111), (-0.059, 0.054))


@pytest.mark.slow
def test_a_clean_beside_a_box_at_the_shared_edge_turns_the_hand_and_wipes_the_edge_row():
    # the box is taller than the wiping palm's underside: at the grasp's yaw the hand (10.4 cm along the
    # strokes) kept out of its way only by leaving the segment's edge row of dirt (5 of 25 markers); turned a
    # quarter, the hand's narrow side faces the box and the sponge reaches the edge
    from tableclean_suite.controllers import SkillController, make_skill_env
    from tableclean_suite.controllers import clean
    from tableclean_suite.task import Action, TaskModel, TaskSpec, TaskState

    model = TaskModel(spec=TaskSpec("edge_box", segments=3, objects=("lemon", "box")))
    env = make_skill_env(task=model.spec, seed=0)
    yaws = []
    choose = clean.Wipe._choose_yaw

    def recording(wipe, info):
        strokes = choose(wipe, info)
        yaws.append((wipe.grasp_yaw, wipe.yaw, wipe._stroke_direction(info)))
        return strokes

    try:
        env.set_start_state(TaskState(clean=(False, True, True), objects=(1, 1), arm=0))
        env.reset()
        for j, xy in enumerate(EDGE_BOX_LAYOUT):
            env._set_object_pose(j, xy, 0.0)
        env.sim.forward()
        clean.Wipe._choose_yaw = recording
        result = SkillController(env, model).execute(Action.CLEAN)
        present = env.dirt.present().reshape(env.n_segments, -1)[0].sum()
    finally:
        clean.Wipe._choose_yaw = choose
        env.close()
    assert result.success, (result.reason, present)
    (grasp_yaw, yaw, direction), = yaws
    assert abs(abs(yaw - grasp_yaw) - clean.QUARTER_TURN) < 0.01  # turned a quarter
    assert direction == -1  # the arm stands at -x: every stroke pulls the sponge toward it
    assert result.state_after.objects == (1, 1)  # nothing knocked over or off
