"""Skill.hover_z is the travel height its definition gives from every object's exact top, bit for bit."""

from types import SimpleNamespace

import numpy as np
import pytest

from tableclean_suite.controllers.geometry import box_lowest_z
from tableclean_suite.controllers.move import MoveSkill
from tableclean_suite.controllers.skill import object_heights
from tableclean_suite.environments.object_geometry import ObjectGeometry


def reference_hover_z(config, info) -> float:
    """hover_z by its definition: every object's top and bottom computed exactly."""
    table = float(info["table_top_z"])
    z = table + config["hover_height"]
    tops, bottoms = object_heights(info)
    grasped = np.asarray(info["objects_grasped"], dtype=bool).tolist()
    eef_z = float(info["eef_pos"][2])
    drop = None
    if True in grasped:
        drop = eef_z - bottoms[grasped.index(True)]
    elif bool(info["sponge_grasped"]):
        drop = eef_z - box_lowest_z(info["sponge_pos"], info["sponge_quat"], info["sponge_half_size"])
    if drop is not None:
        z = max(z, table + max(drop, 0.0) + config["carry_lift"])
        carried = max(drop, 0.0) + config["carry_clearance"]
    for j, (held, top) in enumerate(zip(grasped, tops)):
        if held:
            continue
        clearance = config["fingertip_depth"] + info["object_types"][j].clearance() if drop is None else carried
        z = max(z, top + clearance)
    return z


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
def test_hover_z_is_the_exact_tops_result_bit_for_bit(holding):
    skill = MoveSkill(SimpleNamespace(control_freq=20.0))
    rng = np.random.default_rng(7)
    raised = 0
    for _ in range(3000):
        info = _info(rng, int(rng.integers(1, 4)), holding)
        z = skill.hover_z(info)
        assert z == reference_hover_z(skill.config, info)
        raised += z > float(info["table_top_z"]) + skill.config["hover_height"]
    assert 0 < raised < 3000  # both: travel at hover_height and raised by an object or the carried body


def test_a_geometry_of_points_only_gives_the_exact_top():
    skill = MoveSkill(SimpleNamespace(control_freq=20.0))
    rng = np.random.default_rng(3)
    info = _info(rng, 2, "nothing")
    info["objects_geometry"] = [SimpleNamespace(points=s.points) for s in info["objects_geometry"]]
    assert skill.hover_z(info) == reference_hover_z(skill.config, info)
