"""The skills on other arms: per-robot configs, gripper settling, robot checks.

Unit tests (no physics): the registry and its validation, the config flow into skills, the
three gripper-settling rules on a kinematic env whose fingers jitter, bad robot names in every
entry point.  ``slow`` tests: the optimal plan of ``paper`` from layout (1, 1) reaches the terminal
state on every supported robot with the compiled control path, and that path reproduces
robosuite's ``env.step`` on another arm.
"""

from __future__ import annotations


import numpy as np
import pytest

from kinematic_env import KinematicEnv, fake_robot
from tableclean_suite.controllers import MoveSkill, SkillController, make_skill_env
from tableclean_suite.controllers import robot_configs
from tableclean_suite.environments import robot_registry
from tableclean_suite.controllers.osc import skill_controller_config
from tableclean_suite.controllers.robot_configs import (
    RobotSkillConfig,
    check_robot,
    register_robot_config,
    skill_overrides,
    supported_robots,
)
from tableclean_suite.task import Action, Outcome, TaskModel, start_layout

#: The arms besides the Panda that the skills support.
OTHER_ARMS = ("Sawyer", "UR5e", "Kinova3")
#: An arm robosuite ships whose gripper the scene cannot use (no finger-pad geoms).
UNSUPPORTED = "XArm7"
#: Finger jitter amplitude (joint units per step) of the kinematic env: the Robotiq 85's measured ~0.01 rad.
JITTER = 0.01
#: Steady finger speed (joint units per step) of a gripper still closing (the Robotiq 85's ~0.08 rad/step).
CLOSING_SPEED = 0.08
#: Settling rule of the jittering tests: windows of 4 steps, 3e-3 per step of drift, timeout after 30 steps.
WINDOW, DRIFT, TIMEOUT = 4, 0.003, 30
#: Largest state difference (rad, m) between the fast path and robosuite's env.step on the short run.
STATE_ATOL = 1e-9
#: Control steps of the short fixed-command run, and the grip-site offset (m) it commands.
SHORT_RUN_STEPS = 24
TARGET_OFFSET = np.array([0.05, -0.04, -0.03])


# ---------------------------------------------------------------------------------------------
# registry
# ---------------------------------------------------------------------------------------------
def test_panda_and_three_other_arms_are_supported():
    assert {"Panda", *OTHER_ARMS} <= set(supported_robots())
    assert UNSUPPORTED not in supported_robots()
    assert check_robot(["UR5e"]) == "UR5e"


def test_unknown_robot_is_refused_naming_the_supported_ones():
    with pytest.raises(ValueError, match=r"robot 'XArm7' is not supported.*supported robots: .*Panda.*Sawyer"):
        check_robot(UNSUPPORTED)
    with pytest.raises(ValueError, match=r"robots must name one robot.*\['Panda', 'Panda'\]"):
        check_robot(["Panda", "Panda"])


def test_registration_checks_its_keys_and_can_be_replaced():
    with pytest.raises(ValueError, match=r"keys \['wipe_speed'\] under '\*' are not BASE_CONFIG keys"):
        register_robot_config(RobotSkillConfig("Test", skills={"*": {"wipe_speed": 0.1}}))
    with pytest.raises(ValueError, match=r"OSC keys \['input_type'\]"):
        register_robot_config(RobotSkillConfig("Test", osc={"input_type": "delta"}))
    with pytest.raises(ValueError, match="already has a skill config"):
        register_robot_config(RobotSkillConfig("Panda"))
    with pytest.raises(TypeError):
        register_robot_config({"robot": "Test"})
    assert "Test" not in supported_robots()


def test_the_shipped_configs_pass_the_registration_checks(monkeypatch):
    monkeypatch.setattr(robot_registry, "ROBOT_CONFIGS", dict(robot_registry.ROBOT_CONFIGS))
    for config in list(robot_registry.ROBOT_CONFIGS.values()):
        assert register_robot_config(config, replace=True) == config
    with pytest.raises(ValueError, match="Kinova3"):
        register_robot_config(RobotSkillConfig("Kinova3", skills={"clean": {"hover_still_speed": -1.0}}), replace=True)


def test_overrides_flow_into_the_skills_and_the_osc(monkeypatch):
    monkeypatch.setitem(robot_registry.ROBOT_CONFIGS, "Test", RobotSkillConfig(
        "Test", skills={"*": {"speed": 0.2}, "move": {"max_steps": 77}}, osc={"kp": 123}))
    assert skill_overrides("Test", "move") == {"speed": 0.2, "max_steps": 77}
    assert skill_overrides("Test", "pick") == {"speed": 0.2}
    assert skill_overrides("NotRegistered", "move") == {}
    controller = SkillController(_JitterEnv(robot="Test"), skill_configs={"move": {"speed": 0.3}})
    assert controller.skill_config("move") == {"speed": 0.3, "max_steps": 77}  # the caller's value wins
    assert skill_controller_config("UR5e")["body_parts"]["right"]["kp"] == 300
    assert skill_controller_config("Kinova3")["body_parts"]["right"]["kp"] == robot_configs.ROBOT_CONFIGS["Kinova3"].osc["kp"]


# ---------------------------------------------------------------------------------------------
# gripper settling
# ---------------------------------------------------------------------------------------------
class _JitterEnv(KinematicEnv):
    """Kinematic env: the grip site jumps to each command; the fingers jitter, close steadily, or rest."""

    def __init__(self, fingers: str = "jitter", robot: str = "Panda"):
        super().__init__(robot=fake_robot(robot=robot))
        self.fingers = fingers

    def finger_position(self) -> float:
        if self.fingers == "jitter":
            return JITTER * (-1) ** self.steps
        if self.fingers == "closing":
            return CLOSING_SPEED * self.steps
        return 0.0


def _run_move(fingers: str, config: dict) -> MoveSkill:
    env = _JitterEnv(fingers)
    skill = MoveSkill(env, config)
    skill.reset(env.symbolic_state())
    while (command := skill.step()) is not None:
        env.step(command)
    return skill


def test_fingers_that_come_to_rest_settle_by_the_per_step_rule():
    assert _run_move("still", {}).succeeded


def test_jittering_fingers_never_settle_by_the_per_step_rule_alone():
    skill = _run_move("jitter", {"max_steps": 100})
    assert not skill.succeeded and "budget" in skill.failure


def test_windowed_drift_settles_jittering_fingers_but_not_closing_ones():
    window = {"gripper_window": WINDOW, "gripper_drift": DRIFT}
    jitter = _run_move("jitter", window)
    assert jitter.succeeded, jitter.failure
    closing = _run_move("closing", {**window, "max_steps": 100})
    assert not closing.succeeded and "budget" in closing.failure


def test_timeout_settles_fingers_that_never_stop():
    skill = _run_move("closing", {"gripper_timeout": TIMEOUT, "max_steps": 4 * TIMEOUT})
    assert skill.succeeded, skill.failure
    assert all(steps >= TIMEOUT for steps in skill.phase_steps.values())


def test_bad_window_is_refused():
    with pytest.raises(ValueError, match="gripper_window must be None or an int >= 1"):
        MoveSkill(_JitterEnv(), {"gripper_window": 0})


@pytest.mark.parametrize("config, message", [
    ({"gripper_timeout": 0}, "gripper_timeout must be None or an int >= 1"),
    ({"gripper_timeout": "5"}, "gripper_timeout must be None or an int >= 1"),
    ({"gripper_drift": -0.1}, "gripper_drift must be a number >= 0"),
    ({"gripper_drift": float("nan")}, "gripper_drift must be a number >= 0"),
])
def test_bad_timeout_and_drift_are_refused(config, message):
    with pytest.raises(ValueError, match=message):
        MoveSkill(_JitterEnv(), config)


def test_per_action_keys_are_stored_as_registered_action_names(monkeypatch):
    monkeypatch.setattr(robot_registry, "ROBOT_CONFIGS", dict(robot_registry.ROBOT_CONFIGS))
    register_robot_config(RobotSkillConfig("Test", skills={Action.CLEAN: {"press_force": 6.0}, "Pick": {"max_steps": 9}}))
    assert robot_configs.skill_overrides("Test", "clean") == {"press_force": 6.0}
    assert robot_configs.skill_overrides("Test", "pick") == {"max_steps": 9}
    with pytest.raises(ValueError, match="both name 'clean'"):
        register_robot_config(RobotSkillConfig("Other", skills={"Clean": {}, Action.CLEAN: {}}))
    with pytest.raises(ValueError, match="unknown action 'fly'"):
        register_robot_config(RobotSkillConfig("Other", skills={"fly": {}}))


# ---------------------------------------------------------------------------------------------
# bad robot names at every entry point (before anything is built)
# ---------------------------------------------------------------------------------------------
def test_environment_and_make_skill_env_refuse_an_unsupported_arm():
    import robosuite

    import tableclean_suite  # noqa: F401  (registers TableClean)

    with pytest.raises(ValueError, match=r"'XArm7' is not supported.*Kinova3, Panda, Sawyer, UR5e"):
        robosuite.make("TableClean", robots=UNSUPPORTED, has_renderer=False, has_offscreen_renderer=False,
                       use_camera_obs=False)
    with pytest.raises(ValueError, match=r"'XArm7' is not supported"):
        make_skill_env(robots=UNSUPPORTED)


def test_physics_options_and_gym_refuse_an_unsupported_arm():
    import gymnasium

    import tableclean_suite.gym_envs  # noqa: F401  (registers the Gym ids)
    from tableclean_suite.learners import train

    with pytest.raises(ValueError, match=r"'Jaco' is not supported"):
        train(backend="physics", runs=1, iterations=1, physics_options={"env_kwargs": {"robots": "Jaco"}})
    with pytest.raises(ValueError, match=r"'XArm7' is not supported"):
        gymnasium.make("TableCleanSkills-v0", robots=UNSUPPORTED)
    with pytest.raises(ValueError, match="disagree"):
        gymnasium.make("TableCleanSkills-v0", robots="UR5e", env_kwargs={"robots": "Sawyer"})
    # a name and a one-name list agree: the refusal is the robot's, not a disagreement
    with pytest.raises(ValueError, match=r"'XArm7' is not supported"):
        gymnasium.make("TableCleanSkills-v0", robots=UNSUPPORTED, env_kwargs={"robots": [UNSUPPORTED]})
    with pytest.raises(TypeError, match="env_kwargs must be a dict"):
        gymnasium.make("TableCleanSkills-v0", robots="Panda", env_kwargs=["robots", "Panda"])


@pytest.mark.parametrize("module", ["fidelity", "rollout", "robot_table"])
def test_clis_exit_2_naming_the_supported_robots(module, capsys):
    import importlib

    main = importlib.import_module(f"tableclean_suite.bench.{module}").main
    argv = {"fidelity": ["--robots", UNSUPPORTED, "--trials", "1"],
            "rollout": ["--robots", UNSUPPORTED, "--task", "paper", "--video", "x.mp4"],
            "robot_table": ["--robots", f"Panda,{UNSUPPORTED}"]}[module]
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    assert "'XArm7' is not supported" in capsys.readouterr().err


# ---------------------------------------------------------------------------------------------
# physics
# ---------------------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("robot", ["Panda", *OTHER_ARMS])
def test_optimal_paper_plan_reaches_the_terminal_state(robot):
    from tableclean_suite.controllers.fast_control import fast_stepper_of

    model = TaskModel()
    env = make_skill_env(1, 1, robots=robot, seed=0)
    try:
        assert fast_stepper_of(env) is not None  # the compiled control path
        assert env.robots[0].name == robot
        env.reset()
        start = env.symbolic_state()
        assert start == start_layout(1, 1)
        plan = model.shortest_plan(start)
        results = SkillController(env, model).execute_plan(plan)
        assert [r.action for r in results] == [model.action_name(a) for a in plan]
        assert all(r.success for r in results), [f"{r.action}: {r.reason}" for r in results if not r.success]
        assert results[-1].outcome == Outcome.TERMINAL and env.symbolic_state().is_terminal
    finally:
        env.close()


def _short_run(robot: str, fast: bool) -> np.ndarray:
    """qpos after :data:`SHORT_RUN_STEPS` fixed commands (move by TARGET_OFFSET, close, then open)."""
    from scipy.spatial.transform import Rotation

    env = make_skill_env(1, 2, robots=robot, seed=7, fast_control=fast)
    try:
        env.reset()
        info = env.skill_info()
        start, rotvec = np.array(info["eef_pos"]), Rotation.from_quat(info["eef_quat"]).as_rotvec()
        step = env.fast_stepper.step if fast else env.step
        for k in range(SHORT_RUN_STEPS):
            fraction = min(1.0, (k + 1) / (SHORT_RUN_STEPS / 2))
            gripper = 1.0 if k < SHORT_RUN_STEPS // 2 else -1.0
            step(np.concatenate([start + fraction * TARGET_OFFSET, rotvec, [gripper]]))
        return np.array(env.sim.data.qpos)
    finally:
        env.close()


@pytest.mark.slow
def test_fast_path_reproduces_robosuite_on_another_arm():
    robot = "Kinova3"  # its own OSC stiffness from the robot config, and another arm's kinematics
    np.testing.assert_allclose(_short_run(robot, fast=True), _short_run(robot, fast=False), rtol=0, atol=STATE_ATOL)


def test_robot_table_appends_cells_of_other_runs(tmp_path):
    from tableclean_suite.bench.robot_table import COLUMNS, markdown, merge_rows, table_row
    from tableclean_suite.bench.trial_store import write_rows

    path = tmp_path / "robot_table.csv"
    eps = {"episodes": 4, "successes": 3, "seconds": 8.0}
    write_rows(path, [table_row("Panda", "paper", None, eps), table_row("UR5e", "paper", None, eps)], COLUMNS)
    again = table_row("UR5e", "paper", {"trials": 72, "rounds": 1, "agreement": 1.0, "faults": 0}, None)
    rows = merge_rows(path, [again, table_row("Sawyer", "paper", None, eps)])
    assert [(r["robot"], r["fidelity_trials"]) for r in rows] == [("Panda", ""), ("UR5e", 72), ("Sawyer", "")]
    assert set(rows[0]) == set(COLUMNS) and rows[0]["episode_success_rate"] == "0.75"  # read back as text
    text = markdown(rows)
    # one-sided 95 % Clopper-Pearson lower bounds: 3 of 4 -> 0.2486, 72 of 72 -> 0.05 ** (1 / 72) = 0.9592
    assert ("| Panda | - | paper | nominal | - | - | - | 3/4 = 75.00 % | 24.8 % | 2.00 |" in text
            and "| UR5e | - | paper | nominal | 72/72 = 100.00 % | 95.9 % | 0 | - | - | - |" in text)
    # a randomised cell is another cell: it does not replace the nominal one
    rows = merge_rows(path, [table_row("Panda", "paper", None, eps, "randomized")])
    assert [(r["robot"], r["dynamics"]) for r in rows] == [("Panda", "nominal"), ("UR5e", "nominal"),
                                                          ("Panda", "randomized")]


def test_robot_table_refuses_nothing_to_measure_and_measures_a_repeated_name_once(capsys):
    from tableclean_suite.bench.robot_table import build_parser, main

    with pytest.raises(SystemExit) as stop:
        main(["--robots", "Panda", "--tasks", "paper", "--episodes", "0", "--fidelity-trials", "0"])
    assert stop.value.code == 2 and "nothing to measure" in capsys.readouterr().err
    assert build_parser().parse_args(["--tasks", "paper, three_segments,paper,"]).tasks == ("paper", "three_segments")
