"""Which yaw a grasp and a place aim at when another object lies next to the body (no physics).

The fingers close along the grip site's x axis; a grasp turns that line away from a lying
neighbour the hand would reach, and every yaw the skills choose stays within a quarter turn of
the config's ``nominal_yaw`` (a wrist wound further made the Panda's next half turn fold the arm).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tableclean_suite.controllers.configs import GraspConfig, ReleaseConfig
from tableclean_suite.environments.object_geometry import wrap_angle
from tableclean_suite.controllers.primitives import (
    FINGER_LINE_CLEARANCE,
    Grasp,
    Release,
    box_geometry,
    line_angle,
    line_yaw,
    nearest_neighbour,
    object_body,
)
from tableclean_suite.environments.object_geometry import ObjectGeometry

NOMINAL = 0.5 * np.pi  # GraspConfig's default nominal_yaw
TABLE_Z = 0.8
CUBE = np.array([0.02, 0.02, 0.02])  # m, the paper's box
HAND_REACH = 0.104  # m, the Panda hand's measured sideways reach


def _cylinder(radius: float, half_height: float) -> ObjectGeometry:
    angles = np.linspace(0.0, 2.0 * np.pi, 32, endpoint=False)
    ring = np.column_stack([radius * np.cos(angles), radius * np.sin(angles)])
    return ObjectGeometry(np.vstack([np.column_stack([ring, np.full(32, z)]) for z in (-half_height, half_height)]))


def _eef_quat(yaw: float) -> np.ndarray:
    return (Rotation.from_euler("z", yaw) * Rotation.from_euler("x", np.pi)).as_quat()  # pointing down; xyzw


def _info(shapes, xys, eef_yaw=NOMINAL, grasped=None) -> dict:
    """skill_info() of upright objects ``shapes`` standing on the table at ``xys`` (M, 2)."""
    xys = np.asarray(xys, dtype=float)
    centres = np.array([[x, y, TABLE_Z - s.lower[2]] for (x, y), s in zip(xys, shapes)])
    return {
        "objects_pos": centres,
        "objects_quat": np.tile([0.0, 0.0, 0.0, 1.0], (len(shapes), 1)),
        "objects_half_size": np.array([s.half_size for s in shapes]),
        "objects_geometry": list(shapes),
        "object_types": [SimpleNamespace(grasp_depth=None, yaw_rule=None)] * len(shapes),  # no overrides
        "objects_grasped": np.zeros(len(shapes), dtype=bool) if grasped is None else np.asarray(grasped),
        "objects_footprint": np.array([s.footprint_radius for s in shapes]),
        "gripper_hand_reach": HAND_REACH,
        "gripper_palm_height": 0.1,
        "eef_pos": np.array([0.0, 0.0, TABLE_Z + 0.1]),
        "eef_quat": _eef_quat(eef_yaw),
        "table_top_z": TABLE_Z,
    }


class _Skill:
    def __init__(self, config):
        self.config = config
        self.yaw = 0.0


def _grasp_yaw(info, obj=0) -> float:
    skill = _Skill(GraspConfig().as_dict())
    Grasp(object_body(obj, info)).start(skill, info)
    return skill.yaw


def test_line_helpers():
    assert line_angle(0.0, np.pi) == pytest.approx(0.0)
    assert line_angle(0.1, -0.1 + np.pi) == pytest.approx(0.2)
    assert line_angle(0.0, 0.5 * np.pi) == pytest.approx(0.5 * np.pi)
    assert line_yaw(-2.0, NOMINAL) == pytest.approx(np.pi - 2.0)  # the same line, a quarter turn of nominal
    assert line_yaw(1.0, NOMINAL) == pytest.approx(1.0)


def test_grasp_of_a_square_box_turns_its_fingers_off_a_neighbour_on_their_line():
    cube, cylinder = box_geometry(CUBE), _cylinder(0.025, 0.02)
    # the measured stall: a cylinder 6.8 cm from the box, nearly along world y (the nominal finger line)
    xys = [[0.0, 0.0], [0.014, 0.067]]
    yaw = _grasp_yaw(_info([cube, cylinder], xys))
    toward = np.arctan2(0.067, 0.014)
    assert line_angle(yaw, toward) >= FINGER_LINE_CLEARANCE
    assert line_angle(yaw, 0.0) == pytest.approx(0.0, abs=1e-9)  # still across a side of the cube
    assert abs(wrap_angle(yaw - NOMINAL)) <= 0.5 * np.pi + 1e-9
    # the same pair out of the hand's reach, or the neighbour held: the nominal grasp
    assert _grasp_yaw(_info([cube, cylinder], [[0.0, 0.0], [0.014, 0.3]])) == pytest.approx(NOMINAL)
    held = _info([cube, cylinder], xys, grasped=[False, True])
    assert _grasp_yaw(held) == pytest.approx(NOMINAL)


def test_grasp_of_a_round_body_turns_just_clear_of_the_neighbour_and_keeps_a_clear_yaw():
    can, other = _cylinder(0.033, 0.06), _cylinder(0.033, 0.06)
    toward = 0.5 * np.pi + 0.1  # neighbour almost on the current finger line (yaw pi/2)
    xys = [[0.0, 0.0], 0.08 * np.array([np.cos(toward), np.sin(toward)])]
    yaw = _grasp_yaw(_info([can, other], xys, eef_yaw=NOMINAL))
    assert line_angle(yaw, toward) == pytest.approx(FINGER_LINE_CLEARANCE)
    assert abs(wrap_angle(yaw - NOMINAL)) < FINGER_LINE_CLEARANCE  # the smaller of the two turns
    # a neighbour already across the fingers: the current yaw stays
    across = [[0.0, 0.0], [0.08, 0.0]]
    assert _grasp_yaw(_info([can, other], across, eef_yaw=NOMINAL)) == pytest.approx(NOMINAL)


def test_nearest_neighbour_skips_the_body_itself_low_objects_and_far_ones():
    cube, flat = box_geometry(CUBE), box_geometry([0.02, 0.02, 0.002])
    info = _info([cube, flat, cube], [[0.0, 0.0], [0.05, 0.0], [0.0, 0.09]])
    assert nearest_neighbour(info, [0.0, 0.0], TABLE_Z + 0.01, exclude=0) == 2  # the flat one is lower
    assert nearest_neighbour(info, [0.0, 0.0], TABLE_Z, exclude=0) == 1
    assert nearest_neighbour(info, [0.0, 0.0], TABLE_Z + 0.1, exclude=0) is None


def test_place_turns_the_hand_across_a_neighbour_at_the_yaw_nearest_nominal_not_the_current_one():
    cube, tall = box_geometry(CUBE), _cylinder(0.025, 0.1)
    # held cube (index 0) over a spot with a tall cylinder lying 6 cm along +x; the hand comes in turned far
    # from nominal
    info = _info([cube, tall], [[0.0, 0.0], [0.06, 0.0]], grasped=[True, False])
    info["eef_pos"] = np.array([0.0, 0.0, info["objects_pos"][0][2] + 0.01])
    skill = _Skill(ReleaseConfig().as_dict())
    skill.yaw = NOMINAL - 2.0  # rad; the equivalent across yaw nearest this is -pi/2, two turns of the wrist away
    release = Release(object_body(0), lambda skill, info: np.array([0.0, 0.0]),
                      lambda skill, info: float(TABLE_Z - cube.lower[2]))
    release.start(skill, info)
    assert skill.yaw == pytest.approx(NOMINAL)  # the fingers' line across the direction (+x) to the neighbour
    low = _info([cube, cube], [[0.0, 0.0], [0.06, 0.0]], grasped=[True, False])  # below the hand: no turn
    low["eef_pos"] = info["eef_pos"]
    skill.yaw = NOMINAL - 2.0
    release.start(skill, low)
    assert skill.yaw == pytest.approx(NOMINAL - 2.0)
