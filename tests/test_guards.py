"""Guards on what a user can hand the library: spec sizes, unlearnable tasks, costly learners and
plugin actions, failing plugin effects, values that overflow, duplicate JSON keys."""

from __future__ import annotations

import json
import time

import pytest

from tableclean_suite import resources
from tableclean_suite.backends import TrainingJob
from tableclean_suite.backends.tabular import check_job_resources
from tableclean_suite.learners import get_learner, rng, train
from tableclean_suite.rewards import RewardPattern, get_reward_pattern
from tableclean_suite.task import ActionRule, Outcome, TaskModel, TaskSpec, load_task_spec, register_action
from tableclean_suite.task.spec import MAX_STATE_CODES


@pytest.mark.parametrize("sizes", [dict(segments=10**30), dict(segments=10**6), dict(objects=10**7),
                                   dict(objects=10**12)])
def test_a_spec_too_large_is_refused_before_its_size_is_computed(sizes):
    started = time.perf_counter()
    with pytest.raises(ValueError, match=f"{max(sizes.values())}.*{MAX_STATE_CODES}"):
        TaskSpec("huge", **sizes)
    assert time.perf_counter() - started < 1


def _register(name, effect):
    register_action(ActionRule(name, effect, "test action"), overwrite=True)
    return name


@pytest.mark.parametrize("actions", [("pick", "place", "clean"), ("clean",)])
def test_a_task_whose_terminal_state_cannot_be_reached_is_refused(actions):
    spec = TaskSpec("no_way_out", actions=actions)
    with pytest.raises(resources.ResourceError, match="no_way_out.*unclean"):
        train(task=spec, runs=1, iterations=10)


def test_describe_refuses_a_task_whose_terminal_state_cannot_be_reached():
    from tableclean_suite.bench.describe import describe

    with pytest.raises(resources.ResourceError, match="no_way_out.*unclean"):
        describe(TaskModel(spec=TaskSpec("no_way_out", actions=("pick", "place", "clean"))))


def _job(learner, runs, iterations):
    return TrainingJob(learner=learner, reward=get_reward_pattern("r4"), model=TaskModel(), runs=runs,
                       iterations=iterations, alpha=0.3, gamma=0.3, epsilon=0.1, max_itr=500, seed=0)


def test_the_time_guard_counts_dyna_planning_updates(monkeypatch):
    monkeypatch.delenv(resources.OVERRIDE_ENV, raising=False)
    monkeypatch.setattr(resources, "MAX_TRAINING_SECONDS", 60)
    dyna = get_learner("dyna_q").configured({"planning_steps": 10000}, None, None)
    check_job_resources(_job(get_learner("q_learning"), 10, 10**5), measured=False)  # 0.02 s
    with pytest.raises(resources.TooMuchWorkError, match="10000 planning"):
        check_job_resources(_job(dyna, 10, 10**5), measured=False)  # 1e10 updates


def test_a_slow_plugin_action_is_refused_after_timing_its_first_calls(monkeypatch):
    monkeypatch.delenv(resources.OVERRIDE_ENV, raising=False)
    calls = []

    def slow(state):
        calls.append(state)
        if len(calls) > 50:
            raise AssertionError("the guard let the table build go on")
        time.sleep(0.01)
        return state, Outcome.INEFFECTIVE

    spec = TaskSpec("slow_plugin", segments=10, actions=("move", "pick", "place", "clean", _register("test_slow", slow)))
    with pytest.raises(resources.TooMuchWorkError, match="slow_plugin.*about"):
        TaskModel(spec=spec).transition_arrays()


class _Abort(BaseException):
    pass


def _raise_effect_error(state):
    from tableclean_suite.task import ActionEffectError

    raise ActionEffectError("cannot")


def _raise_abort(state):
    raise _Abort()


@pytest.mark.parametrize("effect", [lambda state: 1 / 0, lambda state: None, _raise_effect_error, _raise_abort])
def test_a_failing_plugin_effect_is_a_refusal_naming_the_action_and_the_state(effect):
    spec = TaskSpec("failing_plugin", actions=("move", "pick", "place", "clean", _register("test_failing", effect)))
    with pytest.raises(resources.ResourceError, match="test_failing.*unclean"):
        TaskModel(spec=spec).transition_arrays()


@pytest.mark.slow
def test_skill_info_before_reset_raises():
    from tableclean_suite.controllers import make_skill_env

    env = make_skill_env(1, 1, seed=2)
    try:
        with pytest.raises(RuntimeError, match="reset"):
            env.skill_info()
        env.reset()
        assert env.skill_info()["object_pos"].any()
    finally:
        env.close()


def test_reward_magnitudes_and_q_init_are_bounded():
    with pytest.raises(ValueError, match="terminal.*1e[+]308"):
        RewardPattern("huge", terminal=1e308, relevant_clean=1, irrelevant_clean=0, routine=0, improper=-1)
    with pytest.raises(ValueError, match="q_init.*1e[+]308"):
        train(runs=1, iterations=10, q_init=1e308)


def test_duplicate_json_keys_in_a_spec_file_are_refused(tmp_path):
    path = tmp_path / "twice.json"
    path.write_text('{"name": "twice", "segments": 2, "segments": 3}')
    with pytest.raises(ValueError, match="segments"):
        load_task_spec(path)
    path.write_text(json.dumps({"name": "once", "segments": 3}))
    assert load_task_spec(path).segments == 3


def test_the_simulation_lane_is_in_the_lane_table():
    lanes = [rng.LANE_LEARNER, rng.LANE_PLANNING, rng.LANE_ADVICE, rng.LANE_TIES, rng.LANE_SIMULATION]
    assert len(set(lanes)) == len(lanes)


@pytest.mark.parametrize("actions, plugin", [(["pick", "place", "clean"], ""),
                                             (["move", "pick", "place", "clean", "test_cli_boom"],
                                              "def boom(state):\n    raise ValueError('boom')\n\n"
                                              "register_action(ActionRule('test_cli_boom', boom, 'raises'), "
                                              "overwrite=True)\n")])
def test_run_refuses_an_unlearnable_task_or_a_failing_effect_in_one_line(actions, plugin, capsys, tmp_path):
    from tableclean_suite.bench import commands

    (tmp_path / "plugin.py").write_text("from tableclean_suite.task import ActionRule, register_action\n" + plugin)
    (tmp_path / "spec.json").write_text(json.dumps({"name": "cli_guard", "actions": actions}))
    code = commands.main(["run", "--plugins", str(tmp_path / "plugin.py"), "--task", str(tmp_path / "spec.json"),
                          "--runs", "2", "--iterations", "50", "--no-figures", "--out", str(tmp_path / "out")])
    stderr = capsys.readouterr().err
    err = [line for line in stderr.splitlines() if "error:" in line]
    assert code == 2 and len(err) == 1 and "Traceback" not in stderr
    assert "cli_guard" in err[0] if not plugin else "test_cli_boom" in err[0]


@pytest.mark.parametrize("text", ['{"lambda_": 0.5, "lambda_": 0.9}', "lambda_=0.5,lambda_=0.9"])
def test_a_learner_option_given_twice_is_refused(text):
    from tableclean_suite.bench.config import ConfigError, parse_learner_options

    with pytest.raises(ConfigError, match="'lambda_' is given twice"):
        parse_learner_options(text)


def test_q_init_beyond_the_reward_bound_is_refused_by_the_learner_itself():
    with pytest.raises(ValueError, match=r"q_init must be in \[-1000000, 1000000\], got 1e\+308"):
        get_learner("q_learning").configured({}, 1e308, None)


def test_coverage_refuses_an_unlearnable_task_before_printing_its_plan(capsys, tmp_path):
    from tableclean_suite.bench import commands

    (tmp_path / "spec.json").write_text(json.dumps({"name": "no_clean", "actions": ["move", "pick", "place"]}))
    code = commands.main(["coverage", "--task", str(tmp_path / "spec.json"), "--replications", "2",
                          "--reference-runs", "2", "--runs", "2", "--iterations", "60", "--out", str(tmp_path / "o")])
    captured = capsys.readouterr()
    assert code == 2 and captured.out == "" and len(captured.err.strip().splitlines()) == 1
    assert "no_clean" in captured.err
