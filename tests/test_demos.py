"""Demonstration datasets: robomimic's layout, replay of the recorded states, the command line."""

import json
import subprocess
import sys
from pathlib import Path

import h5py  # the dev extra installs it: these tests run wherever the README's set-up ran
import numpy as np
import pytest

from tableclean_suite.bench import collect_demos
from tableclean_suite.demos import (
    ACTION_DIM, NO_TASK_STATE, Demo, demo_keys, read_demo, read_env_args, split_keys, write_dataset,
)

ROOT = Path(__file__).resolve().parents[1]
#: Demos recorded by the physics fixture (two: a train and a valid one).
EPISODES = 2
#: Keys of robomimic's ``env_args`` and the env_kwargs that rebuild the scene.
ENV_ARGS_KEYS = {"env_name", "type", "env_kwargs"}
REBUILD_KWARGS = {"robots", "controller_configs", "task", "task_config", "control_freq"}
#: Observables every demo of the paper spec has (one object).
PAPER_OBS = {"robot0_eef_pos", "robot0_eef_quat", "robot0_gripper_qpos", "object_pos", "object_quat", "sponge_pos",
             "dirt_fraction", "symbolic_state_index"}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("demos") / "paper.hdf5"
    code = collect_demos.main(["--task", "paper", "--episodes", str(EPISODES), "--seed", "3", "--out", str(out)])
    assert code == 0 and out.exists()
    assert not list(out.parent.glob(".*.tmp"))  # the temporary file was renamed
    return out


@pytest.mark.slow
def test_layout_is_robomimics(dataset):
    with h5py.File(dataset, "r") as f:
        assert set(f) == {"data", "mask"}
        data = f["data"]
        env_args = json.loads(data.attrs["env_args"])
        assert ENV_ARGS_KEYS <= set(env_args) and env_args["env_name"] == "TableClean" and env_args["type"] == 1
        assert REBUILD_KWARGS <= set(env_args["env_kwargs"]) and env_args["env_kwargs"]["task"] == "paper"
        assert json.loads(data.attrs["env_info"])["env_name"] == data.attrs["env"] == "TableClean"
        action_names = json.loads(data.attrs["action_names"])
        assert action_names == ["move", "pick", "place", "clean"]
        keys = sorted(data.keys())
        assert keys == [f"demo_{k}" for k in range(EPISODES)]
        total = 0
        for key in keys:
            demo = data[key]
            n = int(demo.attrs["num_samples"])
            total += n
            assert n > 0
            states = demo["states"]
            assert states.ndim == 2 and states.shape[0] == n and demo["final_state"].shape == states.shape[1:]
            assert demo["actions"].shape == (n, ACTION_DIM)
            assert demo["rewards"].shape == demo["dones"].shape == (n,)
            assert demo["dones"][()].tolist() == [0] * (n - 1) + [1]
            assert demo["rewards"][-1] == 1.0 and set(np.unique(demo["rewards"][()])) <= {0.0, 1.0}
            assert set(demo["obs"]) == set(demo["next_obs"]) == PAPER_OBS
            for name in PAPER_OBS:
                assert demo["obs"][name].shape[0] == demo["next_obs"][name].shape[0] == n
                np.testing.assert_array_equal(demo["obs"][name][1:], demo["next_obs"][name][:-1])
            for name in ("symbolic_states", "skill_index", "skill_action"):
                assert demo[name].shape == (n,)
            # skill boundaries: consecutive, covering every sample, matching skill_index/skill_action and the plan
            plan = json.loads(demo.attrs["plan"])
            bounds = demo["skill_bounds"][()]
            assert bounds.shape == (len(plan), 2) and bounds[0, 0] == 0 and bounds[-1, 1] == n
            assert (bounds[1:, 0] == bounds[:-1, 1]).all()
            for index, (first, end) in enumerate(bounds):
                assert (demo["skill_index"][first:end] == index).all()
                assert (demo["skill_action"][first:end] == action_names.index(plan[index])).all()
            assert demo.attrs["success"] and isinstance(demo.attrs["model_file"], str)
            assert json.loads(demo.attrs["ep_meta"])["task_spec"]["name"] == "paper"
        assert data.attrs["total"] == total
        train = [k.decode() for k in f["mask/train"][()]]
        valid = [k.decode() for k in f["mask/valid"][()]]
        assert sorted(train + valid) == keys and len(valid) == 1


@pytest.mark.slow
def test_replayed_states_read_the_recorded_symbolic_states(dataset):
    import robosuite

    import tableclean_suite  # noqa: F401  (registers TableClean)
    from tableclean_suite.environments.abstraction import AbstractionError

    env_args = read_env_args(dataset)
    env = robosuite.make(env_args["env_name"], **env_args["env_kwargs"])  # as robomimic rebuilds it
    try:
        demo = read_demo(dataset, demo_keys(dataset)[0])
        model = env.task_model
        codes = []
        for t, state in enumerate(demo.states):
            env.sim.set_state_from_flattened(state)
            env.sim.forward()
            try:
                codes.append(env.symbolic_state(check_sponge=False).index)
            except AbstractionError:
                codes.append(NO_TASK_STATE)
            if t % 50 == 0:
                np.testing.assert_allclose(env.skill_info()["eef_pos"], demo.obs["robot0_eef_pos"][t])
        assert codes == demo.symbolic_states.tolist()
        assert codes[0] == demo.attrs["start_state"] and not model.decode(codes[0]).is_terminal
        # dirt lives in the state: the demo starts all dirty and the restored states read the cleaning
        assert demo.obs["dirt_fraction"][0].tolist() == [1.0, 1.0]
        cleaned = [model.decode(c).clean for c in codes if c != NO_TASK_STATE]
        assert (True, False) in cleaned or (False, True) in cleaned
        env.sim.set_state_from_flattened(demo.final_state)
        env.sim.forward()
        final = env.symbolic_state()
        assert final.is_terminal and final.index == demo.attrs["final_symbolic_state"] and env._check_success()
        assert env.dirt_fraction().max() < 1.0
    finally:
        env.close()


def _tiny_demo(n: int = 3, state_dim: int = 5, plan=("move", "clean")) -> Demo:
    return Demo(
        states=np.arange(n * state_dim, dtype=float).reshape(n, state_dim),
        actions=np.ones((n, ACTION_DIM)),
        rewards=np.array([0.0] * (n - 1) + [1.0]),
        dones=np.array([0] * (n - 1) + [1]),
        obs={"robot0_eef_pos": np.zeros((n, 3))},
        next_obs={"robot0_eef_pos": np.ones((n, 3))},
        symbolic_states=np.array([0] * n),
        skill_index=np.array([0] + [1] * (n - 1)),
        skill_action=np.array([0] + [3] * (n - 1)),
        skill_bounds=np.array([[0, 1], [1, n]]),
        final_state=np.full(state_dim, 7.0),
        attrs={"plan": list(plan), "success": True, "start_state": 0},
    )


ENV_ARGS = {"env_name": "TableClean", "type": 1, "env_kwargs": {"robots": "Panda", "controller_configs": {},
                                                                 "task": "paper", "task_config": {}}}


def test_write_read_roundtrip_and_split(tmp_path):
    path = write_dataset(tmp_path / "tiny.hdf5", [_tiny_demo(), _tiny_demo(4)], ENV_ARGS, {"action_names": ["move"]})
    assert demo_keys(path) == ["demo_0", "demo_1"] and read_env_args(path) == ENV_ARGS
    demo = read_demo(path, "demo_1")
    assert demo.num_samples == 4 and demo.attrs["plan"] == ["move", "clean"] and demo.attrs["num_samples"] == 4
    np.testing.assert_array_equal(demo.states, _tiny_demo(4).states)
    with h5py.File(path, "r") as f:
        assert f["data"].attrs["total"] == 7
    with pytest.raises(KeyError, match="demo_0, demo_1"):
        read_demo(path, "demo_9")
    train, valid = split_keys([f"demo_{k}" for k in range(20)], 0.1, seed=0)
    assert len(valid) == 2 and len(train) == 18 and not set(train) & set(valid)
    assert split_keys(["demo_0"], 0.1) == (["demo_0"], [])
    with pytest.raises(ValueError, match=r"\[0, 1\)"):
        split_keys(["demo_0"], 1.0)


def test_write_is_atomic_and_checks_shapes(tmp_path):
    path = write_dataset(tmp_path / "keep.hdf5", [_tiny_demo()], ENV_ARGS)
    before = path.read_bytes()
    bad = _tiny_demo()
    bad.attrs["unstorable"] = object()  # h5py fails in the middle of writing
    with pytest.raises(TypeError):
        write_dataset(path, [_tiny_demo(), bad], ENV_ARGS)
    assert path.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == ["keep.hdf5"]
    wrong = _tiny_demo()
    wrong.rewards = np.zeros(2)
    with pytest.raises(ValueError, match="demo 0: rewards has 2 rows, expected num_samples = 3"):
        write_dataset(tmp_path / "wrong.hdf5", [wrong], ENV_ARGS)
    assert not (tmp_path / "wrong.hdf5").exists()


@pytest.mark.parametrize("argv, expected", [
    (["--policy", "greedy"], "choose from optimal, learned"),
    (["--robots", "XArm7"], "supported robots: Kinova3, Panda, Sawyer, UR5e"),
    (["--task", "nosuch"], "allowed: paper"),
    (["--task", "paper", "--out", "demos.txt"], "--out: must end in .hdf5 or .h5, got 'demos.txt'"),
    (["--episodes", "0"], "expected a positive integer, got '0'"),
    (["--valid-fraction", "1.5"], "--valid-fraction: expected a fraction in [0, 1), got '1.5'"),
    (["--workers", "0"], "argument --workers: expected a positive integer, got '0'"),
    (["--executor", "spark"], "choose from local, ray"),
    (["--ray-address", "127.0.0.1:6379"], "--ray-address is only used with --executor ray"),
])
def test_bad_flags_exit_2_with_one_line(argv, expected, capsys):
    with pytest.raises(SystemExit) as exit_info:
        collect_demos.main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    # robosuite logs its own warnings to stderr when --task first imports it; ours is one line
    (err,) = [line for line in err.splitlines() if not line.startswith("[robosuite")]
    assert expected in err.replace("'", "") if "choose" in expected else expected in err  # argparse may quote choices


def test_bad_flag_from_the_command_line_has_no_traceback(tmp_path):
    done = subprocess.run([sys.executable, "-m", "benchmarks.collect_demos", "--policy", "best"], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert line.startswith("python -m benchmarks.collect_demos: error: argument --policy: invalid choice")
    assert "best" in line and "optimal" in line and "learned" in line


def test_recorder_refuses_a_recording_that_missed_control_steps():
    from tableclean_suite.demos import EpisodeRecorder

    recorder = EpisodeRecorder(env=None)
    recorder.on_step()  # the controller made a step the recorder never saw
    with pytest.raises(RuntimeError, match="bypassed the recorder"):
        recorder.finish()


@pytest.mark.slow
@pytest.mark.parametrize("fast_control", [True, False])
def test_recording_sees_every_control_step_on_both_control_paths(fast_control):
    from tableclean_suite.controllers import make_skill_env
    from tableclean_suite.demos import EpisodeRecorder, recording_controller
    from tableclean_suite.task import Action, TaskModel

    env = make_skill_env(task="paper", fast_control=fast_control)
    try:
        env.reset()
        model = TaskModel()
        recorder = EpisodeRecorder(env)
        controller = recording_controller(env, model, recorder)
        recorder.begin("move", model.action_index("move"))
        result = controller.execute(Action.MOVE)
        assert result.success and result.steps > 0
        demo = recorder.finish({"start_state": 0})
        assert demo.num_samples == result.steps == recorder.hook_steps
        assert demo.skill_bounds.tolist() == [[0, result.steps]]
        assert demo.symbolic_states[0] == 0 and demo.attrs["final_symbolic_state"] == 1
        assert not demo.attrs["success"]  # nothing cleaned yet
    finally:
        env.close()


# --- attempts as executor tasks -------------------------------------------------------------------


def test_attempts_draw_their_start_and_placement_from_seed_and_index_alone():
    from tableclean_suite.task import TaskModel

    model = TaskModel(start="uniform_unclean")
    draws = [collect_demos.attempt_draws(model, 5, k) for k in range(12)]
    assert draws == [collect_demos.attempt_draws(model, 5, k) for k in range(12)]  # no hidden stream
    assert all(start in model.start_states() for start, _ in draws)
    assert len({placement for _, placement in draws}) == 12 and len({start for start, _ in draws}) > 1
    assert collect_demos.attempt_draws(model, 6, 0) != draws[0]
    assert all(0 <= placement < collect_demos.PLACEMENT_SEED_BOUND for _, placement in draws)


#: Attempts the stand-in recorder fails, and the tasks it was given (in this process).
FAILING_ATTEMPTS = {1, 2, 4}
SEEN_TASKS: list = []


def _stand_in_record_attempt(task):
    """record_attempt without physics: fails the attempts in FAILING_ATTEMPTS, else a tiny demo naming its attempt."""
    SEEN_TASKS.append(task)
    if task.attempt in FAILING_ATTEMPTS:
        return collect_demos.AttemptResult(task.attempt, "S", None, "failed on purpose", {"env_name": "TableClean"})
    demo = _tiny_demo()
    demo.attrs["attempt"] = task.attempt
    return collect_demos.AttemptResult(task.attempt, "S", demo, None, {"env_name": "TableClean"})


def test_failed_attempts_are_replaced_in_waves_and_demos_keep_attempt_order(monkeypatch):
    from tableclean_suite.task import TaskModel

    monkeypatch.setattr(collect_demos, "record_attempt", _stand_in_record_attempt)
    SEEN_TASKS.clear()
    lines = []
    demos, env_args, attrs = collect_demos.collect("paper", 3, seed=9, log=lines.append)
    # 3 demos wanted: attempts 0-2 (1 and 2 fail), then 3-4 (4 fails), then 5
    assert [task.attempt for task in SEEN_TASKS] == [0, 1, 2, 3, 4, 5]
    assert {task.seed for task in SEEN_TASKS} == {9}
    assert SEEN_TASKS[0].policy == tuple(TaskModel().optimal_policy().tolist())  # its shortest plans
    assert [demo.attrs["attempt"] for demo in demos] == [0, 3, 5]
    assert attrs["discarded"] == 3 and env_args == {"env_name": "TableClean"}
    assert "attempt 1" in lines[1] and "discarded" in lines[1] and lines[-1].startswith("demo_2")

    SEEN_TASKS.clear()
    monkeypatch.setattr(sys.modules[__name__], "FAILING_ATTEMPTS", set(range(100)))  # every attempt fails
    demos, _, attrs = collect_demos.collect("paper", 2, seed=9, log=lines.append)
    assert demos == [] and attrs["discarded"] == 2 * collect_demos.MAX_ATTEMPTS_PER_EPISODE
    assert [task.attempt for task in SEEN_TASKS] == list(range(2 * collect_demos.MAX_ATTEMPTS_PER_EPISODE))


def test_an_attempt_that_raises_is_named(monkeypatch):
    from tableclean_suite.executors import TaskFailedError

    monkeypatch.setattr(collect_demos, "record_attempt", _raise_in_attempt)
    with pytest.raises(TaskFailedError, match="task demo attempt 0 failed after 1 attempt: RuntimeError: the scene"):
        collect_demos.collect("paper", 1, log=lambda line: None)


def _raise_in_attempt(task):
    raise RuntimeError("the scene exploded")


def test_dataset_differences_sees_every_dataset_and_attribute(tmp_path):
    from hdf5_differences import dataset_differences

    first = write_dataset(tmp_path / "a.hdf5", [_tiny_demo(), _tiny_demo(4)], ENV_ARGS, {"seed": 1})
    same = write_dataset(tmp_path / "b.hdf5", [_tiny_demo(), _tiny_demo(4)], ENV_ARGS, {"seed": 1})
    assert dataset_differences(first, same) == []  # the write date is not content
    assert dataset_differences(first, same, ignore_attrs=()) in ([], ["data@date differs"])
    changed = _tiny_demo(4)
    changed.states[2, 1] += 1e-12
    changed.attrs["success"] = False
    other = write_dataset(tmp_path / "c.hdf5", [_tiny_demo(), changed], ENV_ARGS, {"seed": 2})
    assert dataset_differences(first, other) == ["data/demo_1/states differs", "data/demo_1@success differs",
                                                 "data@seed differs"]
    shorter = write_dataset(tmp_path / "d.hdf5", [_tiny_demo()], ENV_ARGS, {"seed": 1})
    differences = dataset_differences(first, shorter)
    assert f"only in {first}: data/demo_1/states" in differences and "data@total differs" in differences
    as_float = _tiny_demo()
    as_float.dones = as_float.dones.astype(float)  # same numbers, another dtype
    assert "data/demo_0/dones differs" in dataset_differences(write_dataset(tmp_path / "e.hdf5", [as_float], ENV_ARGS),
                                                              write_dataset(tmp_path / "f.hdf5", [_tiny_demo()], ENV_ARGS))


@pytest.mark.slow
def test_two_workers_record_the_same_dataset_as_one(dataset, tmp_path, monkeypatch):
    """Each attempt is an executor task seeded by (seed, attempt): two processes write the fixture's data,
    also when they start with one BLAS thread (as Ray's workers do) and this process has more."""
    from hdf5_differences import dataset_differences

    monkeypatch.setenv("OMP_NUM_THREADS", "1")  # the spawned workers' OpenBLAS starts on one thread
    out = tmp_path / "two_workers.hdf5"
    code = collect_demos.main(["--task", "paper", "--episodes", str(EPISODES), "--seed", "3", "--out", str(out),
                               "--workers", "2"])
    assert code == 0
    assert dataset_differences(dataset, out) == []
    assert len(demo_keys(out)) == EPISODES
