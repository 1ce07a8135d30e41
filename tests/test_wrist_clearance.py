"""The arm above the hand stays off tall neighbours: the place's wrist clearance and the wipe's bounded lead.

Traced on `cereal` mixed (seed 1): a box put down at S3's corner beside the 15 cm cereal standing at
S3's centre was cleared by the hand, but the Panda's link 7, 10 cm above the grip site and 4.4 cm
across the fingers' axis (the hand: 3.2 cm), tipped the cereal (episodes 56, 68, 151); and a clean of
S1 tipped the cereal standing on S2 when the wipe's lead over the lagging sponge took the hand 2 cm
past the strokes' end, which cleared it by exactly ``HAND_CLEARANCE`` (episodes 6, 63).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from tableclean_suite.controllers.clean import HAND_CLEARANCE, spare_clear_of
from tableclean_suite.controllers.configs import ReleaseConfig
from tableclean_suite.controllers.place import place_spot
from tableclean_suite.controllers.primitives import Release, line_angle, object_body
from tableclean_suite.environments import placement
from tableclean_suite.environments.gripper_geometry import GripperGeometry, wrist_half_width
from tableclean_suite.environments.object_geometry import ObjectGeometry

TABLE_Z = 0.8
HAND_HALF_WIDTH = 0.032  # m, the Panda hand across the fingers' axis
WRIST_HALF_WIDTH = 0.044  # m, the Panda's link 7 across it, from 9.7 cm above the grip site
PANDA = GripperGeometry(open_width=0.08, palm_height=0.031, hand_reach=0.104, hand_half_width=HAND_HALF_WIDTH,
                        wrist_heights=(0.0, 0.097), wrist_half_widths=(HAND_HALF_WIDTH, WRIST_HALF_WIDTH))
#: the hand and wrist of a gripper whose links above the hand are no wider than it
NARROW = GripperGeometry(open_width=0.08, palm_height=0.031, hand_reach=0.104, hand_half_width=HAND_HALF_WIDTH,
                         wrist_heights=(0.0, 0.097), wrist_half_widths=(HAND_HALF_WIDTH, HAND_HALF_WIDTH))
UPRIGHT = [0.0, 0.0, 0.0, 1.0]
CENTER = np.array([0.11, 0.11, TABLE_Z])
HALF = 0.09  # m, a segment's half side


def _box(hx, hy, hz) -> ObjectGeometry:
    return ObjectGeometry(np.array([[sx * hx, sy * hy, sz * hz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]))


def _info(neighbour_half) -> dict:
    """A box held above the segment, ``neighbour_half`` (3,) m: the box standing at the segment's centre."""
    held = np.array([0.0, 0.3, 1.0])
    rest = TABLE_Z + neighbour_half[2]
    return {"objects_pos": np.array([[*CENTER[:2], rest], held]), "objects_quat": [UPRIGHT, UPRIGHT],
            "objects_rest_z": [rest, TABLE_Z + 0.0225],
            "objects_geometry": [_box(*neighbour_half), _box(0.0225, 0.0225, 0.0225)],
            "objects_grasped": np.array([False, True]),
            "object_types": [SimpleNamespace(footprint_radius=None, grasp_depth=None, yaw_rule=None)] * 2,
            "objects_footprint": np.array([float(np.hypot(*neighbour_half[:2])), 0.032]),
            "eef_pos": held + [0.0, 0.0, 0.001], "gripper_palm_height": 0.031,
            "gripper_hand_half_width": HAND_HALF_WIDTH, "gripper_hand_reach": 0.104, "object_clearance": 0.01,
            "segment_centers": np.array([[-0.11, -0.11, TABLE_Z], [-0.11, 0.11, TABLE_Z], CENTER]),
            "segment_half_sizes": np.array([[HALF, HALF]] * 3)}


def _distance(spot, half) -> float:
    """m from ``spot`` (2,) to the upright box of half extents ``half`` at the segment's centre."""
    low, high = CENTER[:2] - half[:2], CENTER[:2] + half[:2]
    return float(np.linalg.norm(spot - np.clip(spot, low, high)))


def test_the_wrist_profile_reads_the_widest_point_at_or_below_a_height():
    assert wrist_half_width(PANDA, 0.05) == HAND_HALF_WIDTH
    assert wrist_half_width(PANDA, 0.097) == WRIST_HALF_WIDTH and wrist_half_width(PANDA, 0.2) == WRIST_HALF_WIDTH
    assert wrist_half_width(PANDA, -0.01) == 0.0
    assert wrist_half_width(GripperGeometry(0.08, 0.031, 0.104, 0.032), 0.1) == 0.0  # not measured: nothing


def test_a_box_is_put_farther_from_a_cereal_that_reaches_the_wrist_and_as_before_beside_a_low_one():
    cereal = np.array([0.05, 0.015, 0.075])  # the 10 x 3 x 15 cm cereal, long along x, at the segment's centre
    info = _info(cereal)
    hand_only = place_spot(info, 2, 1, [0], place_clearance=0.006)
    with_wrist = place_spot(info, 2, 1, [0], place_clearance=0.006, gripper=PANDA)
    # the hand's disc about the spot kept clear (the old rule), but not the wrist's: link 7 met the cereal
    assert HAND_HALF_WIDTH + 0.01 - 2e-3 <= _distance(hand_only, cereal) < WRIST_HALF_WIDTH + 0.01
    assert _distance(with_wrist, cereal) >= WRIST_HALF_WIDTH + 0.01 - 2e-3
    assert np.all(np.abs(with_wrist - CENTER[:2]) <= HALF - 0.0225 + 1e-9)  # the box still on the segment
    # a wrist no wider than the hand, or a neighbour below the wrist: the very spot of the hand's rule
    assert np.array_equal(place_spot(info, 2, 1, [0], place_clearance=0.006, gripper=NARROW), hand_only)
    low = _info(np.array([0.05, 0.015, 0.05]))  # 10 cm: it reaches the hand, not the wrist
    assert np.array_equal(place_spot(low, 2, 1, [0], place_clearance=0.006, gripper=PANDA),
                          place_spot(low, 2, 1, [0], place_clearance=0.006))


def test_release_turns_the_narrow_side_to_the_nearest_point_of_a_neighbour_that_reaches_the_wrist():
    cereal = np.array([0.05, 0.015, 0.075])
    info = _info(cereal)
    spot = CENTER[:2] + [0.06, 0.06]  # beyond the cereal's +x, +y corner (0.05, 0.015 from the centre)
    info["eef_pos"] = np.array([*info["objects_pos"][1][:2], TABLE_Z + 0.03])
    info["objects_pos"][1] = [*info["objects_pos"][1][:2], TABLE_Z + 0.03]
    config = ReleaseConfig().as_dict()

    def turned(gripper) -> float:
        skill = SimpleNamespace(config=config, yaw=0.0, env=SimpleNamespace(gripper_geometry=gripper))
        Release(object_body(1), lambda skill, info: spot, lambda skill, info: TABLE_Z + 0.0225).start(skill, info)
        return skill.yaw

    corner = CENTER[:2] + cereal[:2] - spot
    centre = CENTER[:2] - spot
    # the finger line (long axis) across the direction to the corner: the narrow side faces it
    assert line_angle(turned(PANDA), np.arctan2(corner[1], corner[0]) + 0.5 * np.pi) == pytest.approx(0.0, abs=1e-9)
    # the hand alone reaches it: across the direction to its centre, as before
    assert line_angle(turned(NARROW), np.arctan2(centre[1], centre[0]) + 0.5 * np.pi) == pytest.approx(0.0, abs=1e-9)


def test_nearest_point_and_grown_footprints():
    rectangle = np.array([[-0.05, -0.015], [0.05, -0.015], [0.05, 0.015], [-0.05, 0.015]])
    assert np.allclose(placement.nearest_point([1.0, 2.0], rectangle, [1.1, 2.1]), [1.05, 2.015])
    assert np.allclose(placement.nearest_point([1.0, 2.0], rectangle, [1.0, 1.9]), [1.0, 1.985])
    assert np.allclose(placement.nearest_point([0.0, 0.0], 0.02, [0.0, 0.1]), [0.0, 0.02])
    big = placement.grown(rectangle, 0.012)
    assert placement.grown(0.02, 0.01) == pytest.approx(0.03) and placement.grown(rectangle, 0.0) is rectangle
    directions = np.stack([np.cos(np.linspace(0, 2 * np.pi, 90)), np.sin(np.linspace(0, 2 * np.pi, 90))])
    reach, grown_reach = (rectangle @ directions).max(axis=0), (big @ directions).max(axis=0)
    assert np.all(grown_reach >= reach + 0.012 - 1e-12)  # covers every point within the margin
    assert np.all(grown_reach <= reach + 0.012 / np.cos(np.pi / placement.DISC_POINTS) + 1e-12)


def test_the_wipes_lead_stops_where_the_hand_would_meet_a_standing_object():
    # episode 6's first clean of S1: the hand long along y (half extents 3.2 x 10.4 cm), the strokes' grip-site
    # area, the drift correction's 2 cm spare on every side, the cereal standing on S2 8 cm beyond the edge
    hand = np.array([0.032, 0.104])
    area = np.array([[-0.164, -0.175], [-0.064, -0.045]])
    bounds = area + np.array([[-0.02, -0.02], [0.02, 0.02]])
    cereal = np.array([[-0.175, 0.069, -0.075, 0.099]])
    assert cereal[0, 1] - (area[1, 1] + hand[1]) == pytest.approx(HAND_CLEARANCE)  # the strokes' end clears it
    out = spare_clear_of(bounds, area, hand, cereal, HAND_CLEARANCE)
    assert out[1, 1] == pytest.approx(area[1, 1])  # no lead toward it
    assert cereal[0, 1] - (out[1, 1] + hand[1]) >= HAND_CLEARANCE - 1e-12
    assert np.array_equal(out[0], bounds[0]) and out[1, 0] == bounds[1, 0]  # the other sides keep their spare
    half_way = cereal + [0.0, 0.01, 0.0, 0.01]  # 1 cm farther: half the spare stays
    assert spare_clear_of(bounds, area, hand, half_way, HAND_CLEARANCE)[1, 1] == pytest.approx(area[1, 1] + 0.01)
    far = cereal + [0.0, 0.1, 0.0, 0.1]
    assert np.array_equal(spare_clear_of(bounds, area, hand, far, HAND_CLEARANCE), bounds)
    assert np.array_equal(spare_clear_of(bounds, area, hand, np.zeros((0, 4)), HAND_CLEARANCE), bounds)


@pytest.mark.slow
def test_the_panda_measures_link_7_wider_than_the_hand_above_it():
    from tableclean_suite.bench.object_table import spec_for
    from tableclean_suite.controllers import make_skill_env

    env = make_skill_env(task=spec_for("cereal", "mixed", "box"), seed=1)
    try:
        geometry = env.gripper_geometry
        # up to just below link 7 (9.7 cm above the grip site): the hand, widest near its top
        assert wrist_half_width(geometry, 0.095) == pytest.approx(geometry.hand_half_width, abs=1e-3)
        assert wrist_half_width(geometry, 0.12) > geometry.hand_half_width + 0.01  # link 7
        assert geometry.wrist_heights == tuple(sorted(geometry.wrist_heights))
    finally:
        env.close()


@pytest.mark.slow
def test_cereal_mixed_episodes_the_arm_tipped_the_cereal_in_now_succeed():
    """Seed 1, episodes 6 (a clean's lead) and 56 (a place's wrist) of the objects table's cereal mixed cell; the
    episodes before are only reset (the layouts' random stream is drawn at reset alone)."""
    from tableclean_suite.bench.object_table import spec_for
    from tableclean_suite.controllers import SkillController, make_skill_env
    from tableclean_suite.task import TaskModel

    model = TaskModel(spec=spec_for("cereal", "mixed", "box"))
    env = make_skill_env(task=model.spec, seed=1)
    try:
        controller = SkillController(env, model)
        for episode in range(57):
            env.reset()
            if episode not in (6, 56):
                continue
            results = controller.execute_plan(model.shortest_plan(env.symbolic_state()))
            failed = [(model.action_name(r.action), r.reason) for r in results if not r.success]
            assert not failed, f"episode {episode}: {failed}"
            assert env.symbolic_state().is_terminal
            quat = np.asarray(env.skill_info()["objects_quat"][0], dtype=float)  # the cereal, xyzw
            tilt = np.degrees(np.arccos(np.clip(1 - 2 * (quat[0] ** 2 + quat[1] ** 2), -1.0, 1.0)))
            assert tilt < 2.0, f"episode {episode}: the cereal stands {tilt:.1f} degrees off upright"
    finally:
        env.close()
