"""Skill.hover_z is the travel height its definition gives from every object's exact top (to rounding)."""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tableclean_suite.controllers.move import MoveSkill
from tableclean_suite.environments.object_geometry import ObjectGeometry

#: m, rounding between hover_z's heights and scipy's rotation of every point.
ROUNDING = 1e-12


def _world_z(pos, quat, points) -> np.ndarray:
    return float(pos[2]) + np.asarray(points) @ Rotation.from_quat(quat).as_matrix()[2]


def reference_hover_z(config, info) -> float:
    """hover_z by its definition, from the world height of every collision point (and sponge corner)."""
    table = float(info["table_top_z"])
    heights = [_world_z(p, q, g.points) for p, q, g in
               zip(info["objects_pos"], info["objects_quat"], info["objects_geometry"])]
    grasped = [bool(g) for g in info["objects_grasped"]]
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * info["sponge_half_size"]
    heights_allowed = [table + config["hover_height"]]
    drop = None
    if True in grasped:
        drop = float(info["eef_pos"][2]) - heights[grasped.index(True)].min()
    elif info["sponge_grasped"]:
        drop = float(info["eef_pos"][2]) - _world_z(info["sponge_pos"], info["sponge_quat"], corners).min()
    if drop is not None:
        heights_allowed.append(table + max(drop, 0.0) + config["carry_lift"])
    for j, held in enumerate(grasped):
        if not held:
            clearance = (config["fingertip_depth"] + info["object_types"][j].clearance() if drop is None
                         else max(drop, 0.0) + config["carry_clearance"])
            heights_allowed.append(heights[j].max() + clearance)
    return max(heights_allowed)


def _random_quat(rng, tilt):
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = tilt * rng.uniform(-np.pi, np.pi)
    yaw = rng.uniform(-np.pi, np.pi)
    a = np.array([*(np.sin(angle / 2) * axis), np.cos(angle / 2)])  # xyzw
    b = np.array([0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2)])
    x1, y1, z1, w1 = b
    x2, y2, z2, w2 = a
    return np.array([w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2])


def _info(rng, n_objects, holding):
    table = 0.8
    shapes = [ObjectGeometry(rng.uniform(-1, 1, size=(12, 3)) * rng.uniform(0.01, 0.08, size=3))
              for _ in range(n_objects)]
    tilt = rng.choice([0.0, 0.02, 1.0])
    quats = np.array([_random_quat(rng, tilt) for _ in range(n_objects)])
    # centres near resting height, some raised so that their tops reach the hover height
    pos = np.column_stack([rng.uniform(-0.3, 0.3, n_objects), rng.uniform(-0.3, 0.3, n_objects),
                           table + rng.uniform(0.0, 0.12, n_objects)])
    grasped = np.zeros(n_objects, dtype=bool)
    if holding == "object":
        grasped[rng.integers(n_objects)] = True
    kinds = [SimpleNamespace(clearance=lambda c=float(rng.uniform(0.0, 0.03)): c) for _ in range(n_objects)]
    return {
        "table_top_z": table, "objects_pos": pos, "objects_quat": quats, "objects_geometry": shapes,
        "objects_grasped": grasped, "object_types": kinds, "eef_pos": np.array([0.0, 0.0, table + rng.uniform(0.05, 0.3)]),
        "sponge_grasped": holding == "sponge", "sponge_pos": np.array([0.0, 0.0, table + rng.uniform(0.0, 0.2)]),
        "sponge_quat": _random_quat(rng, 0.05), "sponge_half_size": np.array([0.04, 0.03, 0.015]),
    }


@pytest.mark.parametrize("holding", ["nothing", "object", "sponge"])
def test_hover_z_is_the_exact_tops_result(holding):
    skill = MoveSkill(SimpleNamespace(control_freq=20.0))
    rng = np.random.default_rng(7)
    raised = 0
    for _ in range(3000):
        info = _info(rng, int(rng.integers(1, 4)), holding)
        z = skill.hover_z(info)
        assert z == pytest.approx(reference_hover_z(skill.config, info), abs=ROUNDING)
        raised += z > float(info["table_top_z"]) + skill.config["hover_height"]
    assert 0 < raised < 3000  # both: travel at hover_height and raised by an object or the carried body


def test_a_geometry_of_points_only_gives_the_exact_top():
    skill = MoveSkill(SimpleNamespace(control_freq=20.0))
    rng = np.random.default_rng(3)
    info = _info(rng, 2, "nothing")
    info["objects_geometry"] = [SimpleNamespace(points=s.points) for s in info["objects_geometry"]]
    assert skill.hover_z(info) == pytest.approx(reference_hover_z(skill.config, info), abs=ROUNDING)
