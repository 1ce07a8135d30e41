"""Physics backend: fault policy (no physics), option checks, snapshots, and a short training run in MuJoCo."""

from types import SimpleNamespace

import numpy as np
import pytest

from tableclean_suite import physics_backend
from tableclean_suite.controllers.osc import ACTION_DIM
from tableclean_suite.learners import train
from tableclean_suite.physics_backend import PhysicsFaultError, PhysicsStepEnv, start_of
from tableclean_suite.task import HELD, Action, Outcome, TaskModel, TaskState, decode

MODEL = TaskModel()


def test_start_of_stages_a_paper_state():
    assert start_of(decode(0)) == ((1,), 1, (1, 2), ())
    held = TaskState((False, True), (HELD,), 1)
    assert start_of(held) == ((2,), 2, (1,), ())  # reset with the object under the arm, then pick


def test_bad_options_and_workers_raise_before_any_physics():
    with pytest.raises(ValueError, match="unknown physics_options key"):
        train(backend="physics", runs=1, iterations=1, physics_options={"speed": 2})
    with pytest.raises(ValueError, match="workers"):
        train(backend="physics", runs=1, iterations=1, workers=0)


class _Result:
    def __init__(self, after, outcome, reason="ok", success=True):
        self.state_after, self.outcome, self.reason, self.success = after, outcome, reason, success
        self.improper, self.steps, self.wall_time = False, 10, 0.01


class _Controller:
    """Scripted SkillController: returns the queued results in order."""

    def __init__(self, results):
        self.results = list(results)
        self.calls = 0

    def execute(self, action):
        self.calls += 1
        return self.results.pop(0)


class _Env:
    """An env the SkillController accepts (absolute world-frame OSC_POSE arm) that reads state 0."""

    action_dim = ACTION_DIM
    robots = [SimpleNamespace(arms=["right"], part_controllers={"right": SimpleNamespace(
        name="OSC_POSE", input_type="absolute", input_ref_frame="world")})]

    def __init__(self):
        self.restored = []

    def symbolic_state(self):
        return decode(0)

    def get_scene_state(self):
        return "saved"

    def set_scene_state(self, state):
        self.restored.append(state)


def _step_env(results, **kwargs):
    env = PhysicsStepEnv(env=_Env(), **kwargs)
    env.controller = _Controller(results)
    return env, env.env.restored


def test_fault_is_retried_from_the_restored_state_and_counted():
    fault = _Result(None, None, "fault: object_between_segments: dropped", success=False)
    env, restored = _step_env([fault, _Result(decode(1), Outcome.ROUTINE)])
    assert env.step(0, Action.MOVE, 0.5) == (1, int(Outcome.ROUTINE))
    assert restored == ["saved"] and env.controller.calls == 2
    assert env.stats["faults"] == 1 and env.stats["fault_reasons"] == {"object_between_segments": 1}


def test_persistent_fault_raises_instead_of_mapping_to_a_state():
    fault = _Result(None, None, "fault: unstable: qvel", success=False)
    env, _ = _step_env([fault] * 3, max_retries=2)
    with pytest.raises(PhysicsFaultError, match="fault on every attempt"):
        env.step(0, Action.MOVE, 0.5)
    env, _ = _step_env([fault], fault_policy="raise")
    with pytest.raises(PhysicsFaultError):
        env.step(0, Action.MOVE, 0.5)
    with pytest.raises(ValueError, match="fault_policy"):
        PhysicsStepEnv(env=_Env(), fault_policy="ignore")


def test_skill_failure_with_a_readable_state_is_what_the_learner_sees():
    # a clean that left the segment dirty: observed, classified, counted, not retried
    env, restored = _step_env([_Result(decode(1), Outcome.IRRELEVANT_CLEAN, "dirt left", success=False)])
    assert env.step(0, Action.CLEAN, 0.5) == (1, int(Outcome.IRRELEVANT_CLEAN))
    assert env.stats["skill_failures"] == 1 and restored == []


@pytest.mark.slow
def test_snapshot_restore_keeps_a_grasp_and_the_dirt():
    env = PhysicsStepEnv()
    try:
        held = TaskState((False, True), (HELD,), 0)  # segment 2 clean
        physics_backend.stage(env.env, env.controller, held, seed=1)
        saved = env.env.get_scene_state()
        dirt = env.env.dirt_fraction()
        assert env.step(held.index, Action.PLACE, 0.0)[0] == held.with_object(0, 0).index
        env.env.set_scene_state(saved)
        assert env.env.symbolic_state() == held and np.array_equal(env.env.dirt_fraction(), dirt)
        # the restored grasp holds through a move (the gripper's integrated command is restored too)
        assert env.step(held.index, Action.MOVE, 0.0)[0] == MODEL.step(held, Action.MOVE)[0].index
    finally:
        env.env.close()


@pytest.mark.slow
def test_short_physics_training_run_end_to_end():
    result = train("q_learning", "r4", runs=2, iterations=6, epsilon=0.3, seed=1, backend="physics", workers=2)
    assert result.rewards.shape == (2, 6) and result.rewards.dtype == np.float64
    for name in ("outcomes", "states", "actions", "episode_end"):
        assert getattr(result, name).shape == (2, 6) and getattr(result, name).dtype == np.int8
    assert result.q.shape == (2, 24, 4) and result.q.dtype == np.float64
    assert (result.states[:, 0] == 0).all()  # the paper's start, Table 1 state 4
    for run in range(2):
        for t in range(5):
            if result.episode_end[run, t]:
                continue
            state, action, nxt = int(result.states[run, t]), int(result.actions[run, t]), int(result.states[run, t + 1])
            # what physics did is a transition the model can classify, with the recorded outcome
            assert result.outcomes[run, t] == MODEL.classify(state, action, nxt)
    assert np.abs(result.q).sum() > 0
    stats = result.info["physics"]
    assert stats["workers"] == 2 and stats["steps"] == 12 and stats["executions"] >= 12
    assert result.config["backend"] == "physics"
    # where physics did exactly what the model predicts, the learner must have walked the symbolic path
    agreed = all(
        MODEL.step(int(result.states[run, t]), int(result.actions[run, t]))[0].index == int(result.states[run, t + 1])
        for run in range(2) for t in range(5) if not result.episode_end[run, t]
    )
    if agreed:
        symbolic = train("q_learning", "r4", runs=2, iterations=6, epsilon=0.3, seed=1)
        for name in ("rewards", "outcomes", "states", "actions", "episode_end", "q"):
            assert np.array_equal(getattr(result, name), getattr(symbolic, name)), name


@pytest.mark.slow
def test_physics_runs_on_ray_equal_the_runs_in_this_process():
    """Each run is an executor task with its own seeds: a local Ray (loopback) gives this process's records."""
    pytest.importorskip("ray", reason="Ray is not installed: pip install -e '.[dev]' (or '.[cluster]')")
    from tableclean_suite.executors import RayExecutor

    kwargs = dict(learner="q_learning", reward="r4", runs=2, iterations=5, epsilon=0.3, seed=4, backend="physics")
    here = train(workers=1, **kwargs)
    with RayExecutor(workers=2) as executor:
        on_ray = train(executor=executor, **kwargs)
    for name in ("rewards", "outcomes", "states", "actions", "episode_end", "q"):
        np.testing.assert_array_equal(getattr(on_ray, name), getattr(here, name))
    assert on_ray.info["physics"]["steps"] == here.info["physics"]["steps"] == 10


class _TableStand(physics_backend.PhysicsStepEnv):
    """The physics step environment's interface on the task model's rules (no MuJoCo)."""

    def __init__(self, model=None, **options):
        from tableclean_suite.learners.stepper import TableStepEnv
        from tableclean_suite.learners.transitions import TransitionTable

        self.model = model
        self.rules = TableStepEnv(model, TransitionTable.from_model(model))

    def seed(self, seed):
        pass

    def reset(self, draw):
        return self.rules.reset(draw)

    def step(self, state, action, draw):
        return self.rules.step(state, action, draw)

    def close(self):
        pass


def test_physics_keeps_the_checkpoint_q_tables(monkeypatch):
    """backend="physics" honours checkpoint=: the Q-tables after k iterations, in this process and in a worker's body."""
    from tableclean_suite.backends import CHECKPOINT_Q, TrainingJob
    from tableclean_suite.learners import get_learner
    from tableclean_suite.rewards import get_reward_pattern

    monkeypatch.setattr(physics_backend, "PhysicsStepEnv", _TableStand)

    def job(iterations, checkpoint=0):
        return TrainingJob(learner=get_learner("q_learning"), reward=get_reward_pattern("r4"), model=MODEL, runs=2,
                           iterations=iterations, alpha=0.3, gamma=0.3, epsilon=0.1, max_itr=40, seed=5, workers=1,
                           options={"physics_options": {}}, checkpoint=checkpoint)

    full = physics_backend.PHYSICS.train(job(90, checkpoint=60))
    assert full.info[CHECKPOINT_Q].shape == full.q.shape
    assert np.array_equal(full.info[CHECKPOINT_Q], physics_backend.PHYSICS.train(job(60)).q)
    assert not np.array_equal(full.info[CHECKPOINT_Q], full.q)
    assert CHECKPOINT_Q not in physics_backend.PHYSICS.train(job(90)).info
    symbolic = train("q_learning", "r4", runs=2, iterations=90, max_itr=40, seed=5, task=MODEL)
    assert np.array_equal(full.q, symbolic.q) and np.array_equal(full.rewards, symbolic.rewards)
    import json

    from tableclean_suite.learners.stepper import CHECKPOINT_Q as RUN_CHECKPOINT_Q

    hyper = tuple(sorted(dict(alpha=0.3, gamma=0.3, epsilon=0.1, max_itr=40).items()))
    task = physics_backend.PhysicsRun(get_learner("q_learning"), get_reward_pattern("r4"),
                                      json.dumps(MODEL.spec.to_dict(), sort_keys=True), 1, 90, 5, 0, (), hyper,
                                      checkpoint=60)
    try:
        index, record, _ = physics_backend.run_physics_task(task)  # an executor worker's body
    finally:
        physics_backend.close_sessions()
    assert index == 1 and np.array_equal(record[RUN_CHECKPOINT_Q], full.info[CHECKPOINT_Q][1])
