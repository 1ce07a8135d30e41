"""Each arm's own gripper: which grippers the skills drive, the refusals by name, the robot table's gripper
column, the control-frequency bounds, and (``slow``) the Sawyer with its Rethink gripper from a random start."""

from __future__ import annotations

import pytest
import robosuite

from tableclean_suite.bench import robot_table, trial_store
from tableclean_suite.environments.arguments import check_episode_settings
from tableclean_suite.environments.grippers import REFUSED, SUPPORTED, check_gripper


def test_supported_grippers_pass_and_the_others_are_refused_by_name_and_defect():
    assert {check_gripper(name, "UR5e") for name in SUPPORTED} == set(SUPPORTED)
    for name, why in REFUSED.items():
        with pytest.raises(ValueError, match=rf"^gripper '{name}' on UR5e is not supported .*\({why}\); supported"):
            check_gripper(name, "UR5e")
    with pytest.raises(ValueError, match=r"'BDGripper' on Panda .*not a two-finger gripper"):
        check_gripper("BDGripper", "Panda")
    with pytest.raises(ValueError, match=r"'PandaGriper' on Panda .*not a gripper robosuite knows"):
        check_gripper("PandaGriper", "Panda")


def test_a_users_registered_gripper_is_left_to_the_scene_to_measure():
    from robosuite.models.grippers import GRIPPER_MAPPING, PandaGripper

    mine = type("TestGripperOfMine", (PandaGripper,), {"__module__": "my_grippers"})
    GRIPPER_MAPPING[mine.__name__] = mine
    try:
        assert check_gripper("TestGripperOfMine", "Panda") == "TestGripperOfMine"
    finally:
        del GRIPPER_MAPPING[mine.__name__]


def test_the_scene_refuses_a_three_finger_hand_naming_why_before_building():
    with pytest.raises(ValueError) as refused:
        robosuite.make("TableClean", robots="Kinova3", gripper_types="JacoThreeFingerGripper")
    message = str(refused.value)
    assert "\n" not in message and "'JacoThreeFingerGripper' on Kinova3" in message and "three-finger" in message


@pytest.mark.parametrize("freq, ok", [(1, True), (20, True), (500.0, True), (0.5, False), (501, False),
                                      (float("nan"), False)])
def test_control_freq_is_bounded_by_one_hertz_and_the_physics_step(freq, ok):
    if ok:
        check_episode_settings(10, freq)
    else:
        with pytest.raises(ValueError, match=r"control_freq must be a number from 1 to 500 Hz .*got"):
            check_episode_settings(10, freq)


def test_robot_table_has_a_gripper_column_and_refuses_a_hand_before_any_work(tmp_path, capsys):
    assert robot_table.gripper_name("Panda", "default") == "PandaGripper"
    assert robot_table.gripper_name("Sawyer", "default") == "PandaGripper"  # the config's swap
    assert robot_table.gripper_name("UR5e", "RethinkGripper") == "RethinkGripper"
    eps = {"episodes": 2, "successes": 2, "seconds": 4.0}
    rows = [robot_table.table_row("Sawyer", "paper", None, eps, gripper="RethinkGripper"),
            robot_table.table_row("Sawyer", "paper", None, eps, gripper="PandaGripper")]
    path = tmp_path / robot_table.TABLE_CSV
    trial_store.write_rows(path, rows, robot_table.COLUMNS)
    assert [r["gripper"] for r in robot_table.merge_rows(path, [])] == ["RethinkGripper", "PandaGripper"]
    assert "| Sawyer | RethinkGripper | paper | nominal | - |" in robot_table.markdown(rows)
    with pytest.raises(SystemExit) as stop:
        robot_table.main(["--robots", "UR5e", "--grippers", "default,RobotiqThreeFingerGripper", "--tasks", "paper",
                          "--out", str(tmp_path / "out")])
    assert stop.value.code == 2 and "three-finger hand" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_sawyer_with_its_rethink_gripper_completes_a_random_start():
    from tableclean_suite.controllers import SkillController, make_skill_env

    env = make_skill_env(None, None, robots="Sawyer", gripper_types="RethinkGripper", task="paper", seed=0)
    try:
        # the pads' geometry read from the Rethink model, not the Panda hand's
        assert env.robots[0].gripper["right"].__class__.__name__ == "RethinkGripper"
        assert env.gripper_geometry.palm_height == pytest.approx(0.040, abs=1e-3)
        controller = SkillController(env)
        env.reset()  # seed 0's first layout: robosuite's Rethink lost the sponge there before the still hover
        results = controller.execute_plan(controller.model.shortest_plan(env.symbolic_state()))
        assert all(r.success for r in results), [r.reason for r in results]
        assert env.symbolic_state().is_terminal
    finally:
        env.close()
