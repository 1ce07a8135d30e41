"""Grasp heights of round generated objects: the pads close on the widest slice the fingers reach first (a capsule's
dome under a cap, a tapered can under its lip), and the catalog's holding heights stay as they were."""

from __future__ import annotations

import numpy as np
import pytest

from tableclean_suite.controllers import primitives
from tableclean_suite.controllers.configs import PickConfig
from tableclean_suite.controllers.primitives import PAD_HALF_HEIGHT, SLICE_MARGIN, holding_z
from tableclean_suite.environments.object_generator import random_objects
from tableclean_suite.environments.object_geometry import object_geometry
from tableclean_suite.environments.objects import BUILTIN_OBJECTS

PALM = 0.031  # m, the Panda hand's palm above its grip site
CONFIG = {name: getattr(PickConfig(), name) for name in ("fingertip_depth", "tip_clearance", "palm_clearance")}


def _capped_capsule():
    """A generated capsule (4.8 cm wide, 13.9 cm tall) with a narrower cap: both its episodes failed CLOSE."""
    kind = random_objects(87, 2)[86]
    assert kind.build.params["body"] == "capsule" and "cap" in kind.build.params["features"]
    return kind, object_geometry(kind.build("o", {}))


def test_a_capped_capsule_is_held_by_the_cap_above_its_dome():
    _, shape = _capped_capsule()
    k = int(np.argmin(shape.widths()))
    z = holding_z(np.zeros(3), np.eye(3), shape, CONFIG, PALM)
    pads = shape.slice_width(z - PAD_HALF_HEIGHT, z + PAD_HALF_HEIGHT, k)
    below = shape.slice_width(z - CONFIG["fingertip_depth"], z - PAD_HALF_HEIGHT, k)
    assert pads > 0 and below <= pads + 2 * SLICE_MARGIN  # the fingertips meet no wider part of the dome
    top = float(shape.upper[2])
    assert z <= top - PAD_HALF_HEIGHT and top - z <= PALM - CONFIG["palm_clearance"]


@pytest.mark.parametrize("kind", BUILTIN_OBJECTS, ids=lambda kind: kind.name)
def test_the_catalog_holding_heights_do_not_move(kind, monkeypatch):
    shape = object_geometry(kind.build("o", {"object_half_size": (0.025, 0.025, 0.025)}))
    for closing in [None, *np.arange(0.0, np.pi, np.pi / 18)]:
        new = holding_z(np.zeros(3), np.eye(3), shape, CONFIG, PALM, closing)
        with monkeypatch.context() as patch:
            patch.setattr(primitives, "fitting_z", lambda geometry, z, *rest: z)
            assert new == holding_z(np.zeros(3), np.eye(3), shape, CONFIG, PALM, closing)


@pytest.mark.slow
def test_a_generated_capped_capsule_is_picked():
    """Was: gripped on its dome, the fingertips closed on the wider part below and the pads never touched."""
    from tableclean_suite.controllers import SkillController, make_skill_env
    from tableclean_suite.environments.objects import register_object
    from tableclean_suite.task import TaskModel, TaskSpec

    kind, _ = _capped_capsule()
    register_object(kind, overwrite=True)
    model = TaskModel(spec=TaskSpec("grasp_height_capsule", segments=3, objects=(kind.name, "box")))
    env = make_skill_env(task=model.spec, seed=2)
    try:
        env.set_start(None, 2, None, object_segments=[2, 3])
        env.reset()
        result = SkillController(env, model).execute_plan(["pick"])[-1]
        assert result.success, result.reason
        assert result.retries == 0 and result.state_after.held_object == 0
    finally:
        env.close()
