"""The fast control path against robosuite's ``env.step`` path.

- torques: from simulation states recorded on robosuite's path (every substep of a MOVE and a
  CLEAN), :meth:`FastSkillStepper.arm_torques` equals the torques robosuite's OSC computed;
- trajectories: the optimal plan from each start layout ends in the same symbolic states on
  both paths, with grip-site positions per control step within :data:`TRAJECTORY_TOLERANCE`;
- the native loop (MuJoCo's C API from numba) and the Python loop give the same states;
- the compiled control loop (fixed-waypoint and wipe phases in one compiled call) and the per-step path
  give bit-identical episodes: control steps per phase, states, logged per-step states, clock;
- switching from the fast path back to ``env.step`` continues as robosuite would;
- envs whose controllers the fast path does not reproduce are refused;
- robosuite / MuJoCo versions outside the adapter's checked set refuse the stepper (naming them),
  and a skill env then runs on robosuite's own ``env.step`` path, warned once, with the right outcomes.
"""

from __future__ import annotations

import re
import warnings

import mujoco
import numpy as np
import pytest
import robosuite
from scipy.spatial.transform import Rotation

from tableclean_suite.controllers import SkillController, make_skill_env
from tableclean_suite.controllers.fast_control import (
    LOG_FIELDS,
    ROTVEC_SMALL_ANGLE,
    ControlStepLog,
    FastSkillStepper,
    fast_stepper_of,
    native_available,
    rotvec_matrix,
)
from tableclean_suite.controllers import fast_control
from tableclean_suite import robosuite_adapter
from tableclean_suite.task import START_LAYOUTS, TaskModel, start_layout

MODEL = TaskModel()
#: Largest |torque difference| allowed, relative to the largest |torque| of the state.
TORQUE_RTOL = 1e-9
#: Largest grip-site distance (m) between the two paths at any control step.
TRAJECTORY_TOLERANCE = 1e-3
#: Control steps of the short fixed-command runs below (enough to open, close and move the gripper).
SHORT_RUN_STEPS = 24
#: Largest state difference (rad, m) accepted between runs that should agree to rounding.
STATE_ATOL = 1e-9
#: Largest actuator control difference (N m for the arm) accepted between such runs.
CTRL_ATOL = 1e-6
#: Grip-site offset (m) of the short runs' commanded target from the start position.
TARGET_OFFSET = np.array([0.05, -0.04, -0.03])


def _eef_pos(env) -> np.ndarray:
    return np.array(env.skill_info()["eef_pos"])


def _command_sequence(env) -> list[np.ndarray]:
    """(7,) absolute commands: hold orientation, move towards an offset, close then open the gripper."""
    info = env.skill_info()
    start = np.array(info["eef_pos"])
    rotvec = Rotation.from_quat(info["eef_quat"]).as_rotvec()  # xyzw, as skill_info
    commands = []
    for k in range(SHORT_RUN_STEPS):
        fraction = min(1.0, (k + 1) / (SHORT_RUN_STEPS / 2))
        gripper = 1.0 if k < SHORT_RUN_STEPS // 2 else -1.0
        commands.append(np.concatenate([start + fraction * TARGET_OFFSET, rotvec, [gripper]]))
    return commands


@pytest.fixture(scope="module")
def recorded():
    """States and robosuite's torques at every substep of the plan's first MOVE and CLEAN (robosuite's path)."""
    env = make_skill_env(1, 1, seed=3, fast_control=False)
    env.reset()
    robot = env.robots[0]
    osc = robot.part_controllers[robot.arms[0]]
    data = robosuite_adapter.mj_data(env.sim)
    records = []
    original = robot.control

    def control(action, policy_step=False):
        stale = not osc.new_update  # robosuite reuses its reset-time state (checked separately)
        state = (data.qpos.copy(), data.qvel.copy(), data.act.copy())
        original(action, policy_step)
        if not stale:
            records.append((state, np.array(action), np.array(osc.torques)))

    robot.control = control
    plan = MODEL.shortest_plan(env.symbolic_state())[:2]
    results = SkillController(env).execute_plan(plan)
    robot.control = original
    assert [r.success for r in results] == [True, True], [r.reason for r in results]
    yield env, records
    env.close()


def test_torques_equal_robosuites_on_recorded_states(recorded):
    env, records = recorded
    stepper = FastSkillStepper(env)
    data = robosuite_adapter.mj_data(env.sim)
    assert len(records) > 1000  # every substep of a MOVE and a CLEAN
    worst = 0.0
    for (qpos, qvel, act), action, torques in records:
        data.qpos[:], data.qvel[:], data.act[:] = qpos, qvel, act
        mujoco.mj_forward(robosuite_adapter.mj_model(env.sim), data)
        mine = stepper.arm_torques(*stepper.goal(action))
        worst = max(worst, float(np.max(np.abs(mine - torques)) / np.max(np.abs(torques))))
    print(f"max relative torque error over {len(records)} substeps: {worst:.2e}")
    assert worst <= TORQUE_RTOL


def test_first_substep_after_reset_uses_robosuites_cached_state():
    env = make_skill_env(2, 1, seed=5, fast_control=False)
    try:
        env.reset()
        stepper = FastSkillStepper(env)
        robot = env.robots[0]
        osc = robot.part_controllers[robot.arms[0]]
        action = _command_sequence(env)[-1]
        assert not osc.new_update  # robosuite will not re-read the simulation on this substep
        mujoco.mj_step1(robosuite_adapter.mj_model(env.sim), robosuite_adapter.mj_data(env.sim))
        cached = stepper.cached_arm_torques(*stepper.goal(action)).copy()
        fresh = stepper.arm_torques(*stepper.goal(action)).copy()
        robot.control(action, policy_step=True)
        np.testing.assert_allclose(cached, osc.torques, rtol=0, atol=TORQUE_RTOL * np.max(np.abs(osc.torques)))
        assert np.max(np.abs(fresh - osc.torques)) > TORQUE_RTOL * np.max(np.abs(osc.torques))  # the quirk matters
    finally:
        env.close()


def _run_plan(layout, fast_control: bool):
    env = make_skill_env(*layout, seed=sum(layout), fast_control=fast_control)
    env.reset()
    trajectory = []
    controller = SkillController(env, MODEL, on_step=lambda: trajectory.append(_eef_pos(env)))
    results = controller.execute_plan(MODEL.shortest_plan(start_layout(*layout)))
    record = dict(
        states=[r.state_after for r in results],
        steps=[r.steps for r in results],
        trajectory=np.array(trajectory),
        markers=env.dirt.present().reshape(env.n_segments, -1).copy(),
    )
    env.close()
    return record


@pytest.mark.slow
@pytest.mark.parametrize("layout", START_LAYOUTS)
def test_optimal_plan_matches_robosuites_path(layout):
    slow, fast = _run_plan(layout, fast_control=False), _run_plan(layout, fast_control=True)
    assert slow["states"][-1].is_terminal
    assert fast["states"] == slow["states"]
    assert fast["steps"] == slow["steps"]
    np.testing.assert_array_equal(fast["markers"], slow["markers"])
    deviation = np.linalg.norm(fast["trajectory"] - slow["trajectory"], axis=1)
    print(f"layout {layout}: {len(deviation)} control steps, max grip-site deviation {deviation.max():.2e} m")
    assert deviation.max() <= TRAJECTORY_TOLERANCE


def _short_run(native: bool | None, fast_steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(qpos, ctrl, gripper command) after the command sequence: ``fast_steps`` fast steps, then ``env.step``."""
    env = make_skill_env(1, 2, seed=7, fast_control=False)
    try:
        env.reset()
        stepper = FastSkillStepper(env, native=native) if native is not None else None
        for k, command in enumerate(_command_sequence(env)):
            if stepper is not None and k < fast_steps:
                stepper.step(command)
            else:
                env.step(command)
        data = env.sim.data
        gripper = env.robots[0].gripper[env.robots[0].arms[0]]
        return np.array(data.qpos), np.array(data.ctrl), np.array(gripper.current_action)
    finally:
        env.close()


@pytest.fixture(scope="module")
def robosuite_short_run():
    return _short_run(native=None, fast_steps=0)


@pytest.mark.parametrize("native", [False, pytest.param(True, marks=pytest.mark.skipif(
    not native_available(), reason="MuJoCo's shared library not found"))])
def test_fast_steps_then_env_step_continue_as_robosuite(robosuite_short_run, native):
    qpos, ctrl, gripper = _short_run(native=native, fast_steps=SHORT_RUN_STEPS // 2)
    expected_qpos, expected_ctrl, expected_gripper = robosuite_short_run
    np.testing.assert_allclose(qpos, expected_qpos, rtol=0, atol=STATE_ATOL)
    np.testing.assert_allclose(ctrl, expected_ctrl, rtol=0, atol=CTRL_ATOL)
    np.testing.assert_array_equal(gripper, expected_gripper)


@pytest.mark.skipif(not native_available(), reason="MuJoCo's shared library not found")
def test_native_and_python_loops_agree():
    native = _short_run(native=True, fast_steps=SHORT_RUN_STEPS)
    python = _short_run(native=False, fast_steps=SHORT_RUN_STEPS)
    for a, b, atol in zip(native, python, (STATE_ATOL, CTRL_ATOL, 0.0)):
        np.testing.assert_allclose(a, b, rtol=0, atol=atol)


def test_make_skill_env_attaches_the_stepper_only_when_asked():
    fast = make_skill_env(1, 1)
    plain = make_skill_env(1, 1, fast_control=False)
    try:
        assert isinstance(fast_stepper_of(fast), FastSkillStepper)
        assert fast_stepper_of(plain) is None
    finally:
        fast.close()
        plain.close()


def test_unsupported_controllers_are_refused():
    env = robosuite.make("TableClean", robots="Panda", has_renderer=False, has_offscreen_renderer=False,
                         use_camera_obs=False)  # robosuite's default: delta commands in the base frame
    try:
        with pytest.raises(NotImplementedError, match="absolute input.*world-frame input"):
            FastSkillStepper(env)
    finally:
        env.close()


def test_step_refuses_a_wrong_action_size():
    env = make_skill_env(1, 1)
    try:
        env.reset()
        with pytest.raises(ValueError, match=r"shape \(7,\)"):
            fast_stepper_of(env).step(np.zeros(6))
    finally:
        env.close()


def test_step_follows_new_gains_and_controllers():
    """step() keeps the OSC gains while robosuite's kp/kd arrays stay the same objects and its controllers
    while the composite controller does: a new kp array, or a reset's new controllers, are picked up."""
    env = make_skill_env(1, 1, seed=2)
    try:
        env.reset()
        stepper = fast_stepper_of(env)
        action = np.concatenate([_eef_pos(env), [np.pi, 0.0, 0.0], [-1.0]])
        stepper.step(action)
        osc = stepper.osc
        np.testing.assert_array_equal(stepper._plant.gains, np.stack([osc.kp, osc.kd]))
        osc.kp = osc.kp * 0.5  # as the randomization does: a new array
        stepper.step(action)
        np.testing.assert_array_equal(stepper._plant.gains[0], osc.kp)
        env.reset()
        new_osc = env.robots[0].composite_controller.part_controllers[env.robots[0].arms[0]]
        assert new_osc is not osc
        stepper.step(action)
        assert stepper.osc is new_osc and stepper._plant_key[1] is new_osc.kp
        assert new_osc.goal_pos is not None and new_osc.new_update
    finally:
        env.close()


#: A MuJoCo version outside the adapter's checked set (the release that changed ``mj_fullM``).
UNCHECKED_MUJOCO = "3.10.0"


def test_the_installed_versions_are_the_checked_ones():
    assert robosuite_adapter.unchecked_versions() == []
    assert robosuite_adapter.unchecked_versions({"robosuite": "1.5.2", "mujoco": UNCHECKED_MUJOCO}) == [
        f"mujoco {UNCHECKED_MUJOCO} (checked: {', '.join(robosuite_adapter.CHECKED_VERSIONS['mujoco'])})"
    ]


def test_an_unchecked_version_refuses_the_stepper_naming_it(monkeypatch):
    monkeypatch.setattr(mujoco, "__version__", UNCHECKED_MUJOCO)
    with pytest.raises(robosuite_adapter.UncheckedVersionError, match=rf"mujoco {re.escape(UNCHECKED_MUJOCO)} \(checked: "):
        FastSkillStepper(object())  # refused before the env is looked at


def test_an_unchecked_version_falls_back_to_env_step_said_once(monkeypatch):
    monkeypatch.setattr(mujoco, "__version__", UNCHECKED_MUJOCO)
    monkeypatch.setattr(robosuite_adapter, "_warned", set())
    with pytest.warns(RuntimeWarning, match=rf"mujoco {re.escape(UNCHECKED_MUJOCO)}.*robosuite's own env.step path"):
        env = make_skill_env(1, 1, seed=3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a second env is not warned about again
        make_skill_env(1, 1, seed=3).close()
    try:
        assert fast_stepper_of(env) is None
        calls = []
        original = env.step
        env.step = lambda action: (calls.append(1), original(action))[1]
        env.reset()
        start = env.symbolic_state()
        plan = MODEL.shortest_plan(start)[:2]
        results = SkillController(env, MODEL).execute_plan(plan)
        assert [r.success for r in results] == [True, True], [r.reason for r in results]
        assert [r.state_after for r in results] == MODEL.rollout(start, plan)[1:]
        assert len(calls) == sum(r.steps for r in results) > 0  # every control step went through env.step
    finally:
        env.close()


#: Random rotation vectors compared with scipy, their norms spread over 1e-5..3 rad (both Taylor and sine branches).
ROTVEC_SAMPLES = 2000


def test_goal_rotation_is_scipys_bit_for_bit():
    rng = np.random.default_rng(0)
    out = np.empty((3, 3))
    rotvecs = rng.normal(size=(ROTVEC_SAMPLES, 3)) * 10.0 ** rng.uniform(-5, 0.5, size=(ROTVEC_SAMPLES, 1))
    assert (np.linalg.norm(rotvecs, axis=1) <= ROTVEC_SMALL_ANGLE).any()
    for rotvec in rotvecs:
        rotvec_matrix(rotvec, out)
        np.testing.assert_array_equal(out, Rotation.from_rotvec(rotvec).as_matrix())


def _episode(phase_loop: bool, layout=(1, 1), seed: int = 1) -> dict:
    """An optimal episode from ``layout`` (default the paper's) on the fast path, with or without the compiled
    phase and press loops."""
    env = make_skill_env(*layout, seed=seed, hard_reset=False)
    try:
        env.reset()
        stepper = fast_stepper_of(env)
        stepper.phase_loop = phase_loop
        stepper.state_log = ControlStepLog(stepper)
        in_loop, in_press_loop, statuses = [], [], []
        run_phase = stepper.run_phase

        def counted(skill, fingers, wipe=None, force=None):
            ran = run_phase(skill, fingers, wipe, force)
            (in_loop if wipe is None else in_press_loop).append(ran)
            if wipe is not None:
                statuses.append(stepper.last_status)
            return ran
        stepper.run_phase = counted
        results = SkillController(env, MODEL).execute_plan(MODEL.shortest_plan(env.symbolic_state()))
        data = robosuite_adapter.mj_data(env.sim)
        gripper = env.robots[0].gripper[env.robots[0].arms[0]]
        return dict(
            states=[r.state_after for r in results], phase_steps=[r.phase_steps for r in results],
            steps=sum(r.steps for r in results), in_loop=sum(in_loop), in_press_loop=sum(in_press_loop),
            env_time=sum(r.env_time for r in results), callbacks=stepper.callback_seconds, statuses=statuses,
            final={f: getattr(data, f).copy() for f in LOG_FIELDS}, log=stepper.state_log,
            clock=(env.timestep, env.cur_time), gripper=np.array(gripper.current_action),
        )
    finally:
        env.close()


@pytest.mark.slow
@pytest.mark.skipif(not native_available(), reason="MuJoCo's shared library not found")
# (1, 2) seed 0: a stroke whose sponge lifts off the table (the press loop hands three WIPE steps to the skill)
@pytest.mark.parametrize("layout, seed, handoff", [((1, 1), 1, False), ((1, 2), 0, True)])
def test_phase_loop_matches_the_per_step_path(layout, seed, handoff):
    per_step, compiled = _episode(False, layout, seed), _episode(True, layout, seed)
    assert (fast_control.PHASE_HANDOFF in compiled["statuses"]) == handoff
    assert per_step["in_loop"] == per_step["in_press_loop"] == 0
    assert compiled["in_loop"] > 0  # the fixed-waypoint phases (close, release) ran in the compiled loop
    # the clean's press, strokes and shifts ran in the compiled press loop (most of their steps)
    wipe_steps = sum(steps.get(phase, 0) for steps in compiled["phase_steps"] for phase in ("PRESS", "WIPE", "SHIFT"))
    assert compiled["in_press_loop"] > wipe_steps // 2
    assert per_step["callbacks"] == 0.0 < compiled["callbacks"] < compiled["env_time"]
    print(f"{compiled['in_loop']} + {compiled['in_press_loop']} of {compiled['steps']} control steps in the compiled "
          "phase and press loops")
    assert compiled["states"] == per_step["states"] and compiled["states"][-1].is_terminal
    assert compiled["phase_steps"] == per_step["phase_steps"]
    assert compiled["clock"] == per_step["clock"]
    np.testing.assert_array_equal(compiled["gripper"], per_step["gripper"])
    for field in LOG_FIELDS:  # bit for bit, at the end and at the start of every control step
        np.testing.assert_array_equal(compiled["final"][field], per_step["final"][field])
    assert compiled["log"].rows == per_step["log"].rows == compiled["steps"]
    for mine, theirs in zip(compiled["log"].states(), per_step["log"].states()):
        for field in LOG_FIELDS:
            np.testing.assert_array_equal(mine[field], theirs[field])


def test_a_loop_record_needs_every_field_by_name():
    from tableclean_suite.controllers.loop_state import SKILL_STATE, loop_record

    fields = {name: 0 for name in SKILL_STATE.names}
    record = loop_record(SKILL_STATE, **{**fields, "setpoint": [1.0, 2.0, 3.0], "steps": 7})
    assert record.shape == (1,) and record["steps"][0] == 7 and list(record["setpoint"][0]) == [1.0, 2.0, 3.0]
    with pytest.raises(ValueError, match=r"missing \['yaw'\], unknown \['yaw_rate'\]"):
        loop_record(SKILL_STATE, **{k: v for k, v in fields.items() if k != "yaw"}, yaw_rate=1.0)
