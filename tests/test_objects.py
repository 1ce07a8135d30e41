"""Registering objects in one line (a MujocoObject class, a callable, a user's MJCF file) and the
scene's refusal of objects the gripper cannot hold or a segment cannot take."""

import numpy as np
import pytest
import robosuite
from robosuite.models.objects import BoxObject, MilkObject

import tableclean_suite  # noqa: F401  (registers TableClean)
from tableclean_suite.environments.object_geometry import object_geometry
from tableclean_suite.environments.objects import (
    GRASP_WIDTH_MARGIN,
    OBJECT_TYPES,
    ObjectType,
    get_object_type,
    make_object,
    register_object,
    type_geometry,
)
from tableclean_suite.task import TaskSpec

#: A user's MJCF object in robosuite's layout: a 3 x 5 x 8 cm box with its sites.
USER_XML = """<mujoco model="user_block">
  <worldbody>
    <body>
      <body name="object">
        <geom name="block" type="box" size="0.015 0.025 0.04" pos="0 0 0" group="0" density="500"
              friction="1 0.005 0.0001" rgba="0.2 0.7 0.3 1"/>
      </body>
      <site rgba="0 0 0 0" size="0.005" pos="0 0 -0.04" name="bottom_site"/>
      <site rgba="0 0 0 0" size="0.005" pos="0 0 0.04" name="top_site"/>
      <site rgba="0 0 0 0" size="0.005" pos="0.025 0.025 0" name="horizontal_radius_site"/>
    </body>
  </worldbody>
</mujoco>
"""


def _scene(spec: TaskSpec):
    return robosuite.make("TableClean", robots="Panda", task=spec, has_renderer=False, has_offscreen_renderer=False,
                          use_camera_obs=False, ignore_done=True, seed=0)


def test_register_object_takes_a_class_a_callable_or_a_full_type():
    by_class = register_object("test_milk_class", MilkObject, overwrite=True)
    assert isinstance(make_object(by_class.name, {}, "m"), MilkObject)
    by_callable = register_object("test_slab", lambda name: BoxObject(name=name, size=[0.02, 0.03, 0.01]),
                                  yaw_rule="short_side", overwrite=True)
    assert by_callable.yaw_rule == "short_side" and by_callable.footprint_radius is None
    np.testing.assert_allclose(type_geometry(by_callable, {}).half_size, [0.02, 0.03, 0.01])
    full = register_object(ObjectType("test_full", lambda name, config: BoxObject(name=name, size=[0.02] * 3),
                                      footprint_radius=0.05), overwrite=True)
    assert get_object_type("test_full") is full
    with pytest.raises(TypeError, match="exactly one of a builder and xml"):
        register_object("test_none")
    with pytest.raises(TypeError, match="not a robosuite MujocoObject"):
        register_object("test_bad_class", dict)


def test_object_types_is_a_live_read_only_view_of_the_registry():
    register_object("test_view_box", BoxObject, overwrite=True)
    assert OBJECT_TYPES["test_view_box"] is get_object_type("test_view_box") and "test_view_box" in OBJECT_TYPES
    assert "banana" not in OBJECT_TYPES and OBJECT_TYPES.get("banana") is None
    with pytest.raises(KeyError, match="unknown object type 'banana'; allowed: box, "):
        OBJECT_TYPES["banana"]
    with pytest.raises(TypeError):
        OBJECT_TYPES["banana"] = OBJECT_TYPES["box"]


def test_geometry_comes_from_the_collision_meshes_not_robosuites_sites():
    milk = MilkObject(name="milk")
    shape = object_geometry(milk)
    # robosuite's bottom_site says 8.5 cm below the origin; the mesh ends 6.1 cm below it
    assert milk.bottom_offset[2] == pytest.approx(-0.085)
    assert shape.lower[2] == pytest.approx(-0.061, abs=1e-3) and shape.height == pytest.approx(0.144, abs=2e-3)
    assert shape.narrow_width == pytest.approx(0.0397, abs=1e-3)


def test_a_users_mjcf_file_registers_in_one_line_and_builds_in_the_scene(tmp_path):
    path = tmp_path / "user_block.xml"
    path.write_text(USER_XML)
    kind = register_object("test_user_block", xml=path, overwrite=True)
    shape = type_geometry(kind, {})
    np.testing.assert_allclose(shape.lower, [-0.015, -0.025, -0.04], atol=1e-9)
    assert shape.narrow_width == pytest.approx(0.03)
    env = _scene(TaskSpec("user_block_scene", objects=("test_user_block",)))
    try:
        env.reset()
        info = env.skill_info()
        assert info["objects_rest_z"][0] == pytest.approx(info["table_top_z"] + 0.04)
        assert env.symbolic_state() == env.task_model.start_state
    finally:
        env.close()
    with pytest.raises(ValueError, match="does not exist"):
        register_object("test_missing", xml=tmp_path / "missing.xml")
    broken = tmp_path / "broken.xml"
    broken.write_text(USER_XML.replace('name="object"', 'name="thing"'))
    with pytest.raises(ValueError, match="not in robosuite's object layout"):
        register_object("test_broken", xml=broken)


def test_the_scene_refuses_an_object_too_wide_for_the_open_gripper_naming_measure_and_limit():
    register_object("test_wide_box", lambda name: BoxObject(name=name, size=[0.04, 0.04, 0.02]), overwrite=True)
    with pytest.raises(ValueError) as error:
        _scene(TaskSpec("wide_box_scene", objects=("test_wide_box",)))
    message = str(error.value)
    assert "'test_wide_box' cannot be grasped" in message and "8.0 cm" in message
    # the limit is the Panda gripper's measured pad gap (7.9 cm) less the margin
    assert f"less a {GRASP_WIDTH_MARGIN * 100:.0f} cm margin allows at most 6.9 cm" in message


def test_the_scene_refuses_an_object_larger_than_a_segment():
    register_object("test_plank", lambda name: BoxObject(name=name, size=[0.2, 0.02, 0.02]), overwrite=True)
    # 40 x 4 cm: neither way round does it fit a 24 cm segment (turned, it is 40 cm along y)
    with pytest.raises(ValueError, match=r"'test_plank' does not fit.*4\.0 x 40\.0 cm.*24\.0 x 24\.0 cm"):
        _scene(TaskSpec("plank_scene", objects=("test_plank",)))


def test_a_long_narrow_object_fits_beside_another_by_its_oriented_footprint():
    # robosuite's cereal box is 10 x 3 cm seen from above: its 10.4 cm disc beside a 4.5 cm box does not fit an
    # 18 cm segment (10.4 + 1 + 6.4), its oriented footprint does (10 + 1 + 4.5 along the row)
    spec = TaskSpec("cereal_and_box", segments=3, objects=("cereal", "box"))
    env = _scene(spec)
    try:
        env.set_start(None, 1, object_segments=(2, 2))
        env.reset()
        info = env.skill_info()
        xy = np.asarray(info["objects_pos"])[:, :2]
        center, half = info["segment_centers"][1, :2], info["segment_half_sizes"][1]
        cereal = type_geometry("cereal", env.task_config)
        # both inside segment 2, side by side along x, their footprints 1 cm (object_clearance) apart or more
        assert np.all(np.abs(xy[0] - center) + cereal.half_size[:2] <= half + 1e-6)
        assert xy[1, 0] - xy[0, 0] >= cereal.upper[0] + 0.01 + 0.0225 - 1e-6
        assert xy[1, 0] + 0.0225 <= center[0] + half[0] + 1e-6
    finally:
        env.close()
    # two cereal boxes fit too, one turned with its narrow side along the row; five breads do not, said with sizes
    env = _scene(TaskSpec("two_cereals", segments=3, objects=("cereal", "cereal")))
    env.close()
    with pytest.raises(ValueError, match=r"5 objects \(bread, bread, bread, bread, bread\) do not fit.*20\.0 x 12\.8 cm"
                                         r".*18\.0 x 18\.0 cm"):
        _scene(TaskSpec("five_breads", segments=3, objects=("bread",) * 5))


def test_object_table_refuses_unknown_types_and_settings_with_one_line_and_exit_2(capsys):
    from tableclean_suite.bench import object_table

    for argv, what in ((["--objects", "banana"], "unknown object type 'banana'"),
                       (["--settings", "upside_down"], "unknown 'upside_down'; allowed: alone, mixed"),
                       (["--episodes", "0"], "expected a positive integer")):
        with pytest.raises(SystemExit) as stop:
            object_table.main(argv, prog="objects")
        err = capsys.readouterr().err
        assert stop.value.code == 2 and what in err and len(err.strip().splitlines()) == 1


@pytest.mark.slow
def test_object_table_measures_each_skill_and_writes_its_csv(tmp_path, capsys):
    import csv

    from tableclean_suite.bench import object_table

    assert object_table.main(["--objects", "milk", "--settings", "alone", "--episodes", "1", "--out", str(tmp_path),
                              "--quiet"], prog="objects") == 0
    rows = list(csv.DictReader((tmp_path / object_table.TABLE_CSV).open()))
    assert {row["skill"] for row in rows} >= {"pick", "place", "clean"}
    assert all(row["object"] == "milk" and int(row["executions"]) >= 1 for row in rows)
    assert "| milk | alone | " in capsys.readouterr().out
