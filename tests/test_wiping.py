"""The wiping geometry: which markers a pressing sponge covers."""

import numpy as np

from tableclean_suite.environments.wiping import markers_under_box

HALF = np.array([0.04, 0.025, 0.015])  # the default sponge
TABLE_Z = 0.8
PRESS_DEPTH = 0.001  # a pressing sponge sinks slightly into the table (soft contact)
MARKERS = np.array([[0.0, 0.0, TABLE_Z], [0.03, 0.0, TABLE_Z], [0.0, 0.3, TABLE_Z], [0.0, -0.3, TABLE_Z]])


def test_upright_sponge_covers_only_its_footprint():
    centre = np.array([0.0, 0.0, TABLE_Z + HALF[2] - PRESS_DEPTH])
    assert markers_under_box(MARKERS, centre, np.eye(3), HALF, 0.005).tolist() == [True, True, False, False]


def test_sponge_tipped_onto_its_side_does_not_wipe_far_away():
    # rotated 90 degrees about x: its local y axis is vertical, its local z axis lies along world y
    tipped = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    centre = np.array([0.0, 0.0, TABLE_Z + HALF[1] - PRESS_DEPTH])
    assert markers_under_box(MARKERS, centre, tipped, HALF, 0.005).tolist() == [True, True, False, False]


def test_hovering_sponge_covers_nothing():
    centre = np.array([0.0, 0.0, TABLE_Z + HALF[2] + 0.02])
    assert not markers_under_box(MARKERS, centre, np.eye(3), HALF, 0.005).any()
