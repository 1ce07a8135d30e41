"""Placement by oriented footprints (no physics): the reset's grid, its noise caps, and the place's free spot."""

import numpy as np
import pytest

from tableclean_suite.environments import placement
from tableclean_suite.environments.placement import (
    DoesNotFit,
    extent,
    free_spot,
    narrow_yaw,
    outline_of,
    row_layout,
    turned,
)

SEGMENT = np.array([0.09, 0.09])  # half extents of a segment of three (m)
SPACING, CLEARANCE, NOISE = 0.08, 0.01, 0.03  # the default config's object_spacing, object_clearance, placement_noise


def rectangle(half_x: float, half_y: float) -> np.ndarray:
    return np.array([[-half_x, -half_y], [half_x, -half_y], [half_x, half_y], [-half_x, half_y]])


CEREAL = rectangle(0.05, 0.015)  # robosuite's cereal box seen from above
BOX = rectangle(0.0225, 0.0225)  # the paper's cube


def _gap(a, b) -> float:
    """Distance [m] between two axis-aligned rectangles given as (lower (2,), upper (2,))."""
    outside = np.maximum(np.maximum(a[0] - b[1], b[0] - a[1]), 0.0)
    return float(np.linalg.norm(outside))


def _boxes(layout: placement.RowLayout, outlines):
    return [(o + lo, o + hi) for o, (lo, hi) in
            zip(layout.offsets, (extent(out, yaw, layout.yaw_noise) for out, yaw in zip(outlines, layout.yaws)))]


def test_a_long_narrow_object_and_a_box_fit_side_by_side_along_the_row():
    layout = row_layout([CEREAL, BOX], SEGMENT, SPACING, CLEARANCE, NOISE)
    # their discs (5.2 + 3.2 cm radii) would need 18 cm + clearance; the footprints need 10 + 1 + 4.5 cm
    assert np.allclose(layout.size, [0.155, 0.045])
    assert np.allclose(layout.yaws, 0.0)  # fits as built: nobody turned
    boxes = _boxes(layout, [CEREAL, BOX])
    # the footprints, moved by any noise up to their caps, keep the clearance and stay inside the segment
    for signs in ((1, -1), (-1, 1)):
        moved = [(lo + s * cap, hi + s * cap) for (lo, hi), s, cap in zip(boxes, signs, layout.xy_noise)]
        assert _gap(*moved) >= CLEARANCE - 1e-9
    for (lo, hi), cap in zip(boxes, layout.xy_noise):
        assert np.all(lo - cap >= -SEGMENT - 1e-9) and np.all(hi + cap <= SEGMENT + 1e-9)


def test_objects_are_turned_narrow_side_along_the_row_only_when_they_do_not_fit_as_built():
    layout = row_layout([CEREAL, CEREAL], SEGMENT, SPACING, CLEARANCE, NOISE)
    assert sorted(np.abs(layout.yaws)) == pytest.approx([0.0, np.pi / 2])
    assert layout.size[0] <= 2 * SEGMENT[0] + 1e-9
    assert narrow_yaw(CEREAL) == pytest.approx(-np.pi / 2) and narrow_yaw(turned(CEREAL, np.pi / 2)) == pytest.approx(0.0)


def test_what_does_not_fit_even_turned_is_refused_with_the_size_it_needs():
    plank = rectangle(0.1, 0.1)
    with pytest.raises(DoesNotFit, match=r"their grid needs 22\.0 x 20\.0 cm .* a segment is 18\.0 x 18\.0 cm") as error:
        row_layout([plank, rectangle(0.005, 0.005)], SEGMENT, 0.0, CLEARANCE, NOISE)
    assert np.allclose(error.value.size, [0.22, 0.2])


def test_a_single_object_keeps_the_centre_and_the_full_noise():
    layout = row_layout([BOX], [0.12, 0.12], SPACING, CLEARANCE, NOISE)
    assert np.array_equal(layout.offsets, [[0.0, 0.0]]) and layout.xy_noise[0] == NOISE and layout.yaw_noise == 0.0
    # two equal boxes: object_spacing apart, as the grid of equal pitch
    pair = row_layout([BOX, BOX], SEGMENT, SPACING, CLEARANCE, NOISE)
    assert np.allclose(pair.offsets, [[-SPACING / 2, 0.0], [SPACING / 2, 0.0]])  # along x, centred


def test_the_yaw_noise_enters_the_extent_and_is_capped_to_what_fits():
    # a rectangle turned by any yaw in +-0.3 rad: the extent is the largest over the yaws (dense sampling agrees)
    lo, hi = extent(CEREAL, 0.0, 0.3)
    yaws = np.linspace(-0.3, 0.3, 2001)
    sampled = np.array([turned(CEREAL, y) for y in yaws])
    assert np.allclose(hi, sampled.max(axis=(0, 1)), atol=1e-6) and np.allclose(lo, sampled.min(axis=(0, 1)), atol=1e-6)
    assert hi[1] == pytest.approx(0.05 * np.sin(0.3) + 0.015 * np.cos(0.3))
    # two 8 cm cubes fit an 18 cm segment only nearly square to the row: a tenth of a radian of noise is capped to
    # the largest that fits (8 (cos + sin) + 1 + 8 (cos + sin) <= 18 cm), which turning cannot help
    cube = rectangle(0.04, 0.04)
    layout = row_layout([cube, cube], SEGMENT, SPACING, CLEARANCE, NOISE, yaw_noise=0.1)
    limit = np.arcsin((0.17 / 0.16) / np.sqrt(2.0)) - np.pi / 4  # cos + sin = sqrt(2) sin(yaw + pi / 4)
    assert layout.yaw_noise == pytest.approx(limit, abs=0.1 / 2 ** placement.YAW_CAP_STEPS)
    assert layout.yaw_noise <= limit and layout.size[0] <= 2 * SEGMENT[0] + 1e-9
    assert row_layout([cube, cube], SEGMENT, SPACING, CLEARANCE, NOISE, yaw_noise=0.05).yaw_noise == 0.05  # fits: kept
    # a cereal box beside a cube fits at any yaw noise: their discs are 10.4 + 1 + 6.4 cm along the row
    assert row_layout([CEREAL, BOX], SEGMENT, SPACING, CLEARANCE, NOISE, yaw_noise=np.pi / 2).yaw_noise == np.pi / 2


def test_free_spot_places_an_oriented_footprint_beside_a_lying_object():
    center = np.array([-0.11, 0.11])
    others = [(center, BOX)]  # a cube lying at the centre
    spot = free_spot(center, SEGMENT, CEREAL, others, CLEARANCE)
    mine = (spot + CEREAL.min(axis=0), spot + CEREAL.max(axis=0))
    theirs = (center + BOX.min(axis=0), center + BOX.max(axis=0))
    assert _gap(mine, theirs) >= CLEARANCE - 2e-3  # the sampled directions may cost ~1 mm, never more
    assert np.all(mine[0] >= center - SEGMENT - 1e-9) and np.all(mine[1] <= center + SEGMENT + 1e-9)
    # as a disc (the old rule) the cereal box has no spot clear of the cube on this segment
    disc = np.linalg.norm(CEREAL, axis=1).max()
    spot_disc = free_spot(center, SEGMENT, disc, [(center, float(np.linalg.norm(BOX, axis=1).max()))], CLEARANCE)
    assert np.linalg.norm(spot_disc - center) < disc + np.linalg.norm(BOX, axis=1).max() + CLEARANCE


def test_outline_of_a_point_cloud_is_its_convex_hull_seen_from_above():
    points = np.array([[0, 0, 0], [1, 0, 1], [1, 1, 0], [0, 1, 2], [0.5, 0.5, 3]], dtype=float)
    assert sorted(map(tuple, outline_of(points))) == [(0, 0), (0, 1), (1, 0), (1, 1)]


def test_the_hand_keeps_its_half_width_clear_of_a_lying_object_that_reaches_it():
    center = np.array([0.11, 0.11])
    cereal_at = center + [0.0, 0.0]
    # a cube beside a lying cereal box: 1 cm between the footprints would do for the cube...
    plain = free_spot(center, SEGMENT, BOX, [(cereal_at, CEREAL)], CLEARANCE)
    gap_plain = _gap((plain + BOX.min(axis=0), plain + BOX.max(axis=0)),
                     (cereal_at + CEREAL.min(axis=0), cereal_at + CEREAL.max(axis=0)))
    assert gap_plain >= CLEARANCE - 2e-3
    # ...but the cereal box's top reaches the hand lowering the cube: the hand's 3.2 cm half width keeps 1 cm too
    hand = 0.032
    spot = free_spot(center, SEGMENT, BOX, [(cereal_at, CEREAL)], CLEARANCE, hand=hand, under_hand=[(cereal_at, CEREAL)])
    lo, hi = cereal_at + CEREAL.min(axis=0), cereal_at + CEREAL.max(axis=0)
    nearest = np.clip(spot, lo, hi)
    assert np.linalg.norm(spot - nearest) >= hand + CLEARANCE - 2e-3
    assert np.linalg.norm(plain - np.clip(plain, lo, hi)) < hand + CLEARANCE


def test_free_spot_refuses_objects_under_the_hand_without_the_hand():
    center = np.array([0.11, 0.11])
    with pytest.raises(ValueError, match="under_hand names 1 object.*hand .* is None"):
        free_spot(center, SEGMENT, BOX, [], CLEARANCE, under_hand=[(center, CEREAL)])


def test_footprint_of_reads_the_pose_and_the_override():
    from types import SimpleNamespace

    from tableclean_suite.environments.object_geometry import ObjectGeometry

    corners = np.array([[sx * 0.05, sy * 0.015, sz * 0.075] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    quarter = [0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4)]  # xyzw: a quarter turn about z
    info = {"object_types": [SimpleNamespace(footprint_radius=None), SimpleNamespace(footprint_radius=0.04)],
            "objects_footprint": [0.052, 0.04], "objects_geometry": [ObjectGeometry(corners)] * 2,
            "objects_quat": [quarter, quarter]}
    outline = placement.footprint_of(info, 0)
    assert np.allclose(outline.min(axis=0), [-0.015, -0.05]) and np.allclose(outline.max(axis=0), [0.015, 0.05])
    assert placement.footprint_of(info, 1) == 0.04  # an overridden footprint stays a disc


def test_place_spot_keeps_the_hand_off_a_tall_neighbour_wherever_the_object_hangs_off_the_grip_site():
    from types import SimpleNamespace

    from tableclean_suite.controllers.place import place_spot
    from tableclean_suite.environments.object_geometry import ObjectGeometry

    def corners(hx, hy, hz):
        return np.array([[sx * hx, sy * hy, sz * hz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])

    upright = [0.0, 0.0, 0.0, 1.0]
    center = np.array([-0.11, -0.11, 0.8])

    def info(grip_offset):
        held_at = np.array([0.0, 0.3, 1.0])  # the box in the hand, above the table
        return {"objects_pos": np.array([[-0.11, -0.11, 0.875], held_at]),
                "objects_quat": [upright, upright], "objects_rest_z": [0.875, 0.8225],
                "objects_geometry": [ObjectGeometry(corners(0.02, 0.02, 0.075)), ObjectGeometry(corners(0.0225, 0.0225, 0.0225))],
                "object_types": [SimpleNamespace(footprint_radius=None)] * 2, "objects_footprint": [0.028, 0.032],
                "eef_pos": held_at + [grip_offset, 0.0, 0.0], "gripper_palm_height": 0.031,
                "gripper_hand_half_width": 0.032, "object_clearance": 0.01,
                "segment_centers": np.array([center, [-0.11, 0.11, 0.8], [0.11, 0.11, 0.8]]),
                "segment_half_sizes": np.array([[0.09, 0.09]] * 3)}

    tower = (np.array([-0.13, -0.13]), np.array([-0.09, -0.09]))  # the 15 cm tower's footprint: it reaches the hand
    for grip_offset in (0.0, 0.01):
        spot = place_spot(info(grip_offset), 0, 1, [0], place_clearance=0.006)
        distance = np.linalg.norm(spot - np.clip(spot, *tower))
        assert distance >= 0.032 + grip_offset + 0.01 - 2e-3  # the hand's half width, the offset, the clearance
