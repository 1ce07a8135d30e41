"""Closed-loop skills: a retryable failure re-measures the scene and starts the failed part again, within the
config's ``retries``; the count reaches SkillResult and the fidelity tables; grasp heights clear a ledge.

Unit tests run on the kinematic stand-in; the ``slow`` ones run MuJoCo (a user's spray can after a history,
and a forced re-grasp through the pick and a composed skill).
"""

from __future__ import annotations

import numpy as np
import pytest

from kinematic_env import KinematicEnv
from tableclean_suite.bench.fidelity import skill_table
from tableclean_suite.controllers import MoveSkill, SkillController
from tableclean_suite.controllers.configs import PickConfig
from tableclean_suite.controllers.primitives import Grasp, Reach, holding_z, ledges
from tableclean_suite.controllers.skill import SkillFailure
from tableclean_suite.environments.object_geometry import ObjectGeometry
from tableclean_suite.task import Action, TaskModel


class _FlakyTravel(Reach):
    """The move's TRAVEL, whose goal check fails the first ``fails`` times (``redo``: None not retryable, 0 start
    TRAVEL again, 1 start LIFT again)."""

    def __init__(self, fails: int, redo: int | None = 0):
        super().__init__("TRAVEL", lambda skill, info: skill.hover_point(info, skill.segment_center(info, 1)[:2]),
                         -1.0)
        self.fails, self.redo, self.starts = fails, redo, 0

    def start(self, skill, info):
        self.starts += 1

    def next(self, skill, info, phase):
        if self.fails > 0:
            self.fails -= 1
            raise SkillFailure("not there", redo=self.redo)
        return None


def _flaky_move(fails: int, redo: int | None = 0):
    travel = _FlakyTravel(fails, redo)

    class FlakyMove(MoveSkill):
        def build(self, info):
            return [("", Reach("LIFT", lambda skill, info: np.asarray(info["eef_pos"], dtype=float), -1.0)),
                    ("", travel)]
    return FlakyMove, travel


@pytest.mark.parametrize("fails, budget, success, retries", [
    (0, 2, True, 0), (1, 2, True, 1), (2, 2, True, 2), (3, 2, False, 2), (1, 0, False, 0)])
def test_a_retryable_failure_starts_the_part_again_within_the_budget(fails, budget, success, retries):
    skill_class, travel = _flaky_move(fails)
    controller = SkillController(KinematicEnv(), registry={Action.MOVE: skill_class},
                                 skill_configs={Action.MOVE: {"retries": budget}})
    result = controller.execute(Action.MOVE)
    assert (result.success, result.retries, travel.starts) == (success, retries, 1 + retries)
    assert result.reason == ("ok" if success else "TRAVEL: not there")


def test_a_failure_that_is_not_retryable_ends_the_skill_at_once():
    skill_class, travel = _flaky_move(1, redo=None)
    result = SkillController(KinematicEnv(), registry={Action.MOVE: skill_class}).execute(Action.MOVE)
    assert (result.success, result.retries, travel.starts, result.reason) == (False, 0, 1, "TRAVEL: not there")


def test_redo_starts_again_from_an_earlier_primitive():
    skill_class, travel = _flaky_move(1, redo=1)
    env = KinematicEnv()
    skill = skill_class(env)
    skill.reset(env.symbolic_state())
    seen = []
    while (command := skill.step()) is not None:
        env.step(command)
        seen.append(skill.phase.name)
    assert skill.succeeded and skill.retries == 1
    assert seen.index("TRAVEL") < len(seen) - 1 - seen[::-1].index("LIFT")  # LIFT ran again after TRAVEL failed


class _StalledTravel(Reach):
    """The move's TRAVEL in a phase that may stall (``STALLS``): the hand is held (a frozen stand-in) until the
    primitive starts again."""

    STALLS = ("TRAVEL",)

    def __init__(self):
        super().__init__("TRAVEL", lambda skill, info: skill.hover_point(info, skill.segment_center(info, 1)[:2]), -1.0)
        self.starts = 0

    def start(self, skill, info):
        self.starts += 1
        skill.env.frozen = self.starts == 1


@pytest.mark.parametrize("stalls, budget, success, retries", [(True, 1, True, 1), (True, 0, False, 0),
                                                              (False, 1, False, 0)])
def test_a_phase_that_runs_out_of_budget_where_it_stalls_starts_again_with_a_fresh_budget(stalls, budget, success,
                                                                                        retries):
    travel = _StalledTravel()
    if not stalls:
        travel.STALLS = ()

    class StallingMove(MoveSkill):
        def build(self, info):
            return [("", travel)]
    controller = SkillController(KinematicEnv(), registry={Action.MOVE: StallingMove},
                                 skill_configs={Action.MOVE: {"retries": budget, "max_steps": 60}})
    result = controller.execute(Action.MOVE)
    assert (result.success, result.retries, travel.starts) == (success, retries, 1 + retries)
    if success:
        assert result.steps > 60  # the retry ran on a budget of its own
    else:
        assert result.reason == "step budget of 60 exhausted in phase TRAVEL" and result.steps == 60


class _SnaggingGrasp(Grasp):
    """A grasp of a box on segment 2, carried 1 cm below the grip site once closed, whose lift is held (a frozen
    stand-in) the first time it runs."""

    def __init__(self):
        from tableclean_suite.controllers.primitives import Body

        centre = np.array([0.0, 0.14, 0.82])
        super().__init__(Body(pos=lambda info: centre if self.closed_at is None else info["eef_pos"] - [0, 0, 0.01],
                              quat=lambda info: np.array([0.0, 0.0, 0.0, 1.0]),
                              half_size=lambda info: np.full(3, 0.02), grasped=lambda info: True, grasp_depth=0.0))
        self.starts = self.lifts = 0

    def start(self, skill, info):
        super().start(skill, info)
        self.starts, self.lifting = self.starts + 1, False
        skill.env.frozen = False

    def update(self, skill, info, phase):
        super().update(skill, info, phase)
        if phase == "LIFT" and not self.lifting:
            self.lifts, self.lifting = self.lifts + 1, True
            skill.env.frozen = self.lifts == 1


@pytest.mark.parametrize("budget, done, retries", [(1, True, 1), (0, False, 0)])
def test_a_pick_whose_lift_runs_out_of_budget_grasps_again_from_hover_with_a_fresh_budget(budget, done, retries):
    from tableclean_suite.controllers import PickSkill

    grasp = _SnaggingGrasp()

    class SnaggingPick(PickSkill):
        def build(self, info):
            return [("", grasp)]
    controller = SkillController(KinematicEnv(arm_segment=1), registry={Action.PICK: SnaggingPick},
                                 skill_configs={Action.PICK: {"retries": budget, "max_steps": 120}})
    result = controller.execute(Action.PICK)  # (the stand-in's state never reads the box held: judge the motion)
    assert (result.final_phase == "DONE", result.retries, grasp.starts, grasp.lifts) == (
        done, retries, 1 + retries, 1 + retries)
    if done:
        assert result.steps > 120 and result.phase_steps["HOVER"] > 0  # from HOVER, on a budget of its own
    else:
        assert result.reason == "step budget of 120 exhausted in phase LIFT" and result.steps == 120


def test_a_lift_holds_its_height_while_the_pads_lose_the_body_and_a_lost_body_is_grasped_again():
    """A carried body out of the pads' contact counts as lying: its top would raise the travel height with it."""
    import dataclasses
    from types import SimpleNamespace

    grasp = _SnaggingGrasp()
    held = {"now": True}
    grasp.body = dataclasses.replace(grasp.body, grasped=lambda info: held["now"])
    skill = SimpleNamespace(config=PickConfig().as_dict(), yaw=0.0, _yaw_setpoint=0.0, setpoint=np.zeros(3),
                            hover_z=lambda info: info["hover_z"], env=SimpleNamespace())
    info = {"eef_pos": np.array([0.01, 0.14, 0.83]), "eef_quat": np.array([0.70710678, 0.70710678, 0.0, 0.0]),
            "gripper_qpos": np.zeros(2)}
    grasp.start(skill, info)
    assert grasp.next(skill, info, "CLOSE") == "LIFT"
    heights = []
    for now, hover_z in ((True, 0.9), (False, 0.95), (False, 1.0), (True, 0.91)):
        held["now"] = now
        target = grasp.waypoint(skill, {**info, "hover_z": hover_z}, "LIFT").pos
        assert target[:2].tolist() == [0.01, 0.14]
        heights.append(float(target[2]))
    assert heights == [0.9, 0.9, 0.9, 0.91]
    held["now"] = False
    with pytest.raises(SkillFailure, match="lost while lifting") as failure:
        grasp.next(skill, info, "LIFT")
    assert failure.value.redo == 0


def test_a_grasp_tried_again_lowers_its_fingertips_to_the_retry_clearance():
    from types import SimpleNamespace

    from tableclean_suite.controllers.clean import turned_quat
    from tableclean_suite.controllers.primitives import RETRY_TIP_CLEARANCE, Body

    config = PickConfig().as_dict()
    lying = _stack((0.011, 0.022))  # 2.2 cm high: as a thin cylinder lying on its side
    body = Body(pos=lambda info: np.zeros(3), quat=lambda info: np.array([0.0, 0.0, 0.0, 1.0]),
                half_size=lambda info: np.array([0.011, 0.011, 0.011]), grasped=lambda info: False,
                geometry=lambda info: lying)
    info = {"eef_quat": turned_quat(np.array([0.70710678, 0.70710678, 0.0, 0.0]), 0.0), "gripper_palm_height": 0.031,
            "gripper_qpos": np.zeros(2)}
    skill = SimpleNamespace(config=config, yaw=0.0, _yaw_setpoint=0.0, setpoint=np.zeros(3))
    grasp = Grasp(body)
    grasp.start(skill, info)
    first = grasp.grasp_target(skill, info)[2]
    assert first == pytest.approx(config["fingertip_depth"] + config["tip_clearance"])  # above the body's top
    grasp.restart(skill, info)
    assert grasp.grasp_target(skill, info)[2] == pytest.approx(config["fingertip_depth"] + RETRY_TIP_CLEARANCE)


def _stack(*parts) -> ObjectGeometry:
    """Points of upright cylinders stacked from z = 0: each ``(radius, height)`` [m], as MuJoCo's rims."""
    angles = np.linspace(0.0, 2.0 * np.pi, 32, endpoint=False)
    points, bottom = [], 0.0
    for radius, height in parts:
        for z in (bottom, bottom + height):
            points.append(np.column_stack([radius * np.cos(angles), radius * np.sin(angles), np.full(32, z)]))
        bottom += height
    return ObjectGeometry(np.vstack(points))


def test_the_grasp_of_a_capped_can_keeps_the_fingertips_above_its_shoulder_and_a_lip_is_held_by_the_pads():
    config, palm = PickConfig().as_dict(), 0.031  # the Panda hand's palm height [m]
    can = _stack((0.022, 0.13), (0.012, 0.035))  # the user's spray can: 13 cm body, 3.5 cm cap
    assert [step[:2] for step in ledges(can)] == [(0.13, 0.165)] and all(ledges(can)[0][2])
    assert ledges(can, under=True) == ()
    z = holding_z(np.zeros(3), np.eye(3), can, config, palm)
    assert z - config["fingertip_depth"] >= 0.13 + config["tip_clearance"] - 1e-12  # fingertips above the shoulder
    assert z - config["fingertip_depth"] <= 0.165 - config["tip_clearance"]  # the pads still reach the cap
    lipped = _stack((0.015, 0.07), (0.02, 0.005))  # a 5 mm lip, 5 mm wider a side, on a 7 cm body
    assert [step[:2] for step in ledges(lipped, under=True)] == [(0.07, 0.075)]
    assert holding_z(np.zeros(3), np.eye(3), lipped, config, palm) == pytest.approx(0.0725)  # the pads on the lip
    # a lip over a handle (wider along y below it): fingers closing along x meet the lip, along y the handle
    handle = np.array([[0.0, y, z] for y in (0.0, 0.035) for z in (0.01, 0.06)])
    handled = ObjectGeometry(np.vstack([lipped.points, handle]))
    assert holding_z(np.zeros(3), np.eye(3), handled, config, palm, closing=0.0) == pytest.approx(0.0725)
    assert holding_z(np.zeros(3), np.eye(3), handled, config, palm) == holding_z(
        np.zeros(3), np.eye(3), handled, config, palm, closing=0.5 * np.pi) < 0.0725
    # a plain cylinder and a ledge above the fingers keep the rule as it was
    for shape in (_stack((0.022, 0.15)), _stack((0.022, 0.14), (0.012, 0.005))):
        low, top = 0.0, float(shape.upper[2])
        expected = max(0.5 * (low + top), top - (palm - config["palm_clearance"]),
                       low + config["fingertip_depth"] + config["tip_clearance"])
        assert holding_z(np.zeros(3), np.eye(3), shape, config, palm) == expected


def test_the_fidelity_skill_table_counts_retries():
    model = TaskModel()
    row = {"state": model.unclean_layouts()[0].index, "action": "pick", "agree": 1, "observed_outcome": "routine",
           "steps": 30, "wall_time": 0.1, "reason": "ok"}
    rows = [{**row, "success": 1, "retries": 0}, {**row, "success": 1, "retries": 1},
            {**row, "success": 0, "retries": 2, "agree": 0}]
    pick = next(r for r in skill_table(rows, model) if r["skill"] == "pick")
    assert (pick["executions"], pick["successes"], pick["retries"], pick["saved_by_retry"]) == (3, 2, 3, 1)


# ---------------------------------------------------------------------------------------------
# physics
# ---------------------------------------------------------------------------------------------
SPRAY_CAN = """<mujoco model="spray_can">
  <worldbody>
    <body>
      <body name="object">
        <geom type="cylinder" size="0.022 0.065" pos="0 0 -0.0175" group="0" density="600"/>
        <geom type="cylinder" size="0.012 0.0175" pos="0 0 0.065" group="0" density="600"/>
      </body>
      <site rgba="0 0 0 0" size="0.005" pos="0 0 -0.0825" name="bottom_site"/>
      <site rgba="0 0 0 0" size="0.005" pos="0 0 0.0825" name="top_site"/>
      <site rgba="0 0 0 0" size="0.005" pos="0.022 0.022 0" name="horizontal_radius_site"/>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.mark.slow
def test_a_users_capped_can_is_picked_after_a_history_at_the_first_try(tmp_path):
    """Was: the fingertips closed on the shoulder (not confirmed), the re-grasp rose half-closed and tipped it."""
    from tableclean_suite.controllers import make_skill_env
    from tableclean_suite.environments.objects import register_object
    from tableclean_suite.task import TaskSpec

    (tmp_path / "spray_can.xml").write_text(SPRAY_CAN)
    register_object("retry_spray_can", xml=str(tmp_path / "spray_can.xml"), overwrite=True)
    model = TaskModel(spec=TaskSpec("retry_spray_can_task", segments=3, objects=("box", "retry_spray_can")))
    env = make_skill_env(task=model.spec, seed=1)
    try:
        env.set_start(None, 3, None, object_segments=[3, 3])
        env.reset()
        controller = SkillController(env, model)
        history = ["move", "move", "clean", "move", "pick", "move", "place", "move", "clean", "move", "pick"]
        results = controller.execute_plan(history)
        assert [r.success for r in results] == [True] * len(history), results[-1].reason
        assert results[-1].retries == 0 and results[-1].state_after.held_object == 1
    finally:
        env.close()


@pytest.fixture
def first_close_fails(monkeypatch):
    """The first CLOSE of every grasp reads "not confirmed" (as a miss would); counts how often."""
    calls = {"forced": 0, "closes": 0}
    original = Grasp.next

    def next_phase(self, skill, info, phase):
        if phase == "CLOSE":
            calls["closes"] += 1
            if calls["closes"] == 1:
                calls["forced"] += 1
                raise SkillFailure("grasp not confirmed", redo=0)
        return original(self, skill, info, phase)
    monkeypatch.setattr(Grasp, "next", next_phase)
    return calls


@pytest.mark.slow
@pytest.mark.parametrize("composed", [False, True])
def test_a_missed_grasp_is_retried_from_the_measured_pose(first_close_fails, composed):
    from tableclean_suite.controllers import make_skill_env
    from tableclean_suite.controllers.authoring import compose_skill, grasp, lying_object

    env = make_skill_env(object_segment=1, arm_segment=1, seed=0)
    try:
        env.reset()
        registry = None
        if composed:  # a user's skill with one grasp step does the same
            take = compose_skill("pick", lambda state: TaskModel().step(state, "pick"), [grasp(lying_object())])
            registry = {Action.PICK: take}
        result = SkillController(env, registry=registry).execute(Action.PICK)
        assert result.success and result.retries == 1 and first_close_fails == {"forced": 1, "closes": 2}
        assert result.phase_steps[("GRASP1_" if composed else "") + "HOVER"] > 0
        info = env.skill_info()
        assert info["objects_grasped"][0] and info["eef_pos"][2] > info["objects_pos"][0][2]
    finally:
        env.close()


def test_a_state_that_cannot_be_staged_is_recorded_as_failed_trials_not_a_crashed_round(monkeypatch):
    from types import SimpleNamespace

    from tableclean_suite import physics_backend
    from tableclean_suite.bench import fidelity
    from tableclean_suite.skill_result import SkillResult

    model = TaskModel()
    starts = set(model.unclean_layouts())

    def stage(env, controller, state, seed=None):
        if state not in starts:
            raise physics_backend.StagingError(f"staging {state.name}: the pick failed")
        env.state = state

    def execute(action):  # every skill fails where it is: no state is reached by a plan
        return SkillResult(action, False, False, 5, "ran out", env.state, env.state, None)

    env = SimpleNamespace(state=None, get_scene_state=lambda: None, set_scene_state=lambda saved: None)
    monkeypatch.setattr(physics_backend, "stage", stage)
    rows = fidelity.run_round(SimpleNamespace(env=env, controller=SimpleNamespace(execute=execute), model=model), 0, 0)
    assert len(rows) == fidelity.trials_per_round(model, model.action_names)
    unstaged = [r for r in rows if r["reason"].startswith(fidelity.NOT_STAGED)]
    assert unstaged and all(r["observed_outcome"] == fidelity.FAULT and not r["agree"] for r in unstaged)
    executions = {s["skill"]: s["executions"] for s in skill_table(rows, model)}
    assert sum(executions.values()) + sum(s["refused"] for s in skill_table(rows, model)) == len(rows) - len(unstaged)


@pytest.mark.parametrize("hand_yaw, aimed", [(0.1, 0.0), (3.0, np.pi), (1.4, None)])
def test_a_grasp_yaw_tie_about_nominal_goes_the_hands_way(hand_yaw, aimed):
    """A box whose narrow side lies across the nominal yaw (pi/2): yaws 0 and pi are equally near it; the grasp
    turns to the one nearer the hand (no half turn of the wrist, which swung the hand into the box)."""
    from types import SimpleNamespace

    from tableclean_suite.controllers.clean import turned_quat
    from tableclean_suite.controllers.geometry import gripper_yaw
    from tableclean_suite.environments.object_geometry import wrap_angle
    from tableclean_suite.controllers.primitives import Body, box_geometry

    down = np.array([0.70710678, 0.70710678, 0.0, 0.0])  # the grip site pointing down at yaw pi/2
    info = {"eef_quat": turned_quat(down, hand_yaw - 0.5 * np.pi)}
    assert gripper_yaw(info["eef_quat"]) == pytest.approx(hand_yaw)
    box = Body(pos=lambda info: np.zeros(3), quat=lambda info: np.array([0.0, 0.0, 0.001, 1.0]),
               half_size=lambda info: np.array([0.01, 0.03, 0.03]), grasped=lambda info: False,
               geometry=lambda info: box_geometry([0.01, 0.03, 0.03]))
    skill = SimpleNamespace(config=PickConfig().as_dict(), yaw=0.0)
    Grasp(box)._aim(skill, info)
    ties = (abs(wrap_angle(skill.yaw - 0.002)), abs(wrap_angle(skill.yaw - 0.002 - np.pi)))
    assert min(ties) < 1e-9  # across the narrow side (x)
    if aimed is not None:
        assert abs(wrap_angle(skill.yaw - aimed)) < 0.01


def test_the_old_grasp_retries_key_still_sets_the_retry_budget():
    from tableclean_suite.controllers.configs import checked_skill_config

    defaults = {key: getattr(PickConfig(), key) for key in PickConfig.keys()}
    with pytest.warns(DeprecationWarning, match="'grasp_retries' is now 'retries'"):
        merged, settings = checked_skill_config("PickSkill", PickConfig, defaults, {"grasp_retries": 4})
    assert settings.retries == 4 and "grasp_retries" not in merged


@pytest.mark.slow
def test_retries_leave_the_papers_optimal_episode_unchanged_step_by_step():
    """The paper's optimal episode with the default retries and with none: the same MuJoCo state after every
    control step (a retry only ever follows what was a failure)."""
    from tableclean_suite import robosuite_adapter
    from tableclean_suite.controllers import make_skill_env
    from tableclean_suite.task.paper import PAPER_START

    def episode(retries):
        env = make_skill_env(1, 1, seed=1)
        try:
            env.reset()
            data, states = robosuite_adapter.mj_data(env.sim), []
            configs = None if retries is None else {action: {"retries": retries} for action in Action}
            controller = SkillController(env, TaskModel(), skill_configs=configs,
                                         on_step=lambda: states.append(np.concatenate([data.qpos, data.qvel])))
            results = controller.execute_plan(TaskModel().shortest_plan(PAPER_START))
            return results, np.array(states)
        finally:
            env.close()
    (default, stepped), (none, stepped_none) = episode(None), episode(0)
    assert [r.success for r in default] == [True] * len(default) and default[-1].state_after.is_terminal
    assert [r.retries for r in default] == [0] * len(default)
    assert stepped.shape == stepped_none.shape and np.array_equal(stepped, stepped_none)
