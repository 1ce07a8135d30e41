"""``python -m benchmarks.tune`` on a tiny budget: the study is stored, resumed, and reported."""

import json

import numpy as np
import optuna  # the dev extra installs it: the tune tests run wherever the README's set-up ran
import pytest

from tableclean_suite.bench import tune

TINY = ["--runs", "8", "--iterations", "300", "--learner", "q_learning", "--reward", "r4", "--seed", "1"]


def test_tune_writes_its_study_and_a_second_call_resumes_it(tmp_path):
    out = tmp_path / "tune"
    assert tune.main([*TINY, "--trials", "2", "--out", str(out)]) == 0
    storage = f"sqlite:///{(out / 'study.db').as_posix()}"
    assert (out / "study.db").stat().st_size > 0
    name = "q_learning-r4-paper-8x300"
    study = optuna.load_study(study_name=name, storage=storage)
    assert len(study.trials) == 2
    assert study.user_attrs[tune.REFERENCE_ATTR]["success_asymptote"] > 0  # the paper's configuration, stored
    best = json.loads((out / "best.json").read_text())
    assert best["trials"] == 2 and best["best"]["settings"]["alpha"] > 0
    assert best["best"]["objective"] == min(t.value for t in study.trials if t.value is not None)
    assert best["paper"]["settings"] == tune.PAPER_SETTINGS
    assert (out / "trials.csv").read_text().count("\n") == 1 + 2

    assert tune.main([*TINY, "--trials", "1", "--out", str(out)]) == 0
    assert len(optuna.load_study(study_name=name, storage=storage).trials) == 3
    assert json.loads((out / "best.json").read_text())["trials"] == 3


def test_objective_is_the_restricted_mean_learning_time_and_penalises_a_low_asymptote():
    iterations, reference = 1000, 0.87
    fast_but_worse = {"learning_time_rmst": 50.0, "success_asymptote": 0.80}
    slower_and_good = {"learning_time_rmst": 400.0, "success_asymptote": 0.865}
    never = {"learning_time_rmst": 1000.0, "success_asymptote": 0.9}
    assert tune.objective_value(slower_and_good, reference, iterations, 0.01) == 400
    assert tune.objective_value(fast_but_worse, reference, iterations, 0.01) == pytest.approx(1000 * 1.07)
    assert tune.objective_value(never, reference, iterations, 0.01) == iterations
    assert tune.objective_value(fast_but_worse, reference, iterations, 0.1) == 50  # within a loose tolerance


def test_a_trials_objective_is_the_mean_of_its_runs_learning_times_censored_at_the_budget(tmp_path):
    from tableclean_suite.learners import train

    args = tune.parse_args([*TINY, "--ties", "first", "--out", str(tmp_path)])
    evaluation = tune.Evaluation(args, dict(tune.PAPER_SETTINGS))
    for _ in evaluation.stages():
        pass
    result = evaluation.result()
    direct = train("q_learning", "r4", runs=8, iterations=300, seed=1, task=args.model, ties="first")
    times = np.where(direct.learned_at < 0, 300, direct.learned_at)
    assert result["learning_time_rmst"] == pytest.approx(times.mean())
    assert result["censored_share"] == pytest.approx(np.mean(direct.learned_at < 0))
    assert tune.objective_value(result, None, 300, 0.0) == pytest.approx(times.mean())
    randomly = tune.parse_args([*TINY, "--out", str(tmp_path)])
    assert randomly.ties == "random"  # the default tie rule


def test_the_ablation_crosses_alpha_gamma_with_the_exploration():
    tuned = {"alpha": 0.9, "gamma": 0.8, "epsilon": 0.02, "exploration": "linear_decay", "epsilon_min": 0.01,
             "decay_fraction": 0.5}
    crossed = {(a, e): settings for a, e, settings in tune.ablation_settings(tuned)}
    assert set(crossed) == {("paper", "paper"), ("paper", "tuned"), ("tuned", "paper"), ("tuned", "tuned")}
    assert crossed["paper", "paper"] == tune.PAPER_SETTINGS
    assert crossed["tuned", "tuned"] == tuned
    assert crossed["paper", "tuned"] == {**tuned, "alpha": 0.3, "gamma": 0.3}
    assert crossed["tuned", "paper"] == {**tune.PAPER_SETTINGS, "alpha": 0.9, "gamma": 0.8}


def test_ablation_writes_four_rows_and_names_the_tie_rule(tmp_path, capsys):
    import pandas as pd

    out = tmp_path / "tune"
    assert tune.main([*TINY, "--trials", "2", "--ablation", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    frame = pd.read_csv(out / "ablation.csv")
    assert len(frame) == 4 and set(frame["ties"]) == {"random"}
    assert "greedy ties: random" in printed and "ablation" in printed
    best = json.loads((out / "best.json").read_text())
    assert best["ties"] == "random"
    tuned = frame[(frame["alpha_gamma"] == "tuned") & (frame["exploration_from"] == "tuned")].iloc[0]
    assert tuned["learning_time_rmst"] == pytest.approx(best["best"]["objective"])  # same runs, same settings
    paper = frame[(frame["alpha_gamma"] == "paper") & (frame["exploration_from"] == "paper")].iloc[0]
    assert paper["learning_time_rmst"] == pytest.approx(best["paper"]["learning_time_rmst"])


def test_ablation_without_a_completed_trial_is_one_line_exit_2(tmp_path, capsys):
    code = tune.main([*TINY, "--trials", "0", "--ablation", "--out", str(tmp_path / "tune")])
    error = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(error) == 1 and "--ablation" in error[0], error


def test_decay_schedules_report_their_final_epsilon():
    _, constant = tune.exploration_of({"exploration": "epsilon_greedy", "epsilon": 0.1}, 1000)
    spec, linear = tune.exploration_of({"exploration": "linear_decay", "epsilon": 0.2, "epsilon_min": 0.05,
                                        "decay_fraction": 0.5}, 1000)
    assert constant == 0.1 and spec["horizon"] == 500 and linear == pytest.approx(0.05)


@pytest.mark.parametrize("flag, value", [("--reward", "r9"), ("--learner", "dqn"), ("--max-itr", "0")])
def test_bad_arguments_exit_2_naming_the_flag(capsys, flag, value):
    with pytest.raises(SystemExit) as exit_info:
        tune.parse_args([flag, value])
    assert exit_info.value.code == 2
    assert capsys.readouterr().err.startswith(f"tableclean-bench tune: error: {flag}")


@pytest.mark.parametrize("change", [["--reward", "r2"], ["--seed", "2"], ["--tolerance", "0.2"],
                                    ["--iterations", "250"], ["--ties", "first"]])
def test_a_study_name_is_bound_to_its_configuration(tmp_path, capsys, change):
    out = tmp_path / "tune"
    assert tune.main([*TINY, "--trials", "1", "--out", str(out), "--study-name", "shared"]) == 0
    best = (out / "best.json").read_text()
    flag, value = change
    changed = list(TINY)
    if flag in changed:
        changed[changed.index(flag) + 1] = value
    else:
        changed += [flag, value]
    capsys.readouterr()
    assert tune.main([*changed, "--trials", "1", "--out", str(out), "--study-name", "shared"]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    key = {"--reward": "reward", "--seed": "seed", "--tolerance": "tolerance", "--iterations": "iterations",
           "--ties": "ties"}[flag]
    assert len(error) == 1 and "shared" in error[0] and f"{key}=" in error[0] and "--study-name" in error[0], error
    assert (out / "best.json").read_text() == best  # nothing ranked or rewritten
    study = optuna.load_study(study_name="shared", storage=f"sqlite:///{(out / 'study.db').as_posix()}")
    assert len(study.trials) == 1


@pytest.mark.parametrize("storage", ["foo://x", "not a url", "sqlite:////nonexistent-faults-dir/x/study.db",
                                     "mysql://user@127.0.0.1:1/db", "redis://localhost"])
def test_a_bad_storage_url_is_one_line_and_exit_2(tmp_path, capsys, storage):
    code = tune.main([*TINY, "--trials", "1", "--out", str(tmp_path / "tune"), "--storage", storage])
    error = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(error) == 1 and "--storage" in error[0] and repr(storage) in error[0], error


def test_a_study_that_cannot_fit_is_refused_before_its_tables_are_built(tmp_path, monkeypatch):
    from tableclean_suite import resources
    from tableclean_suite.task import TaskModel

    monkeypatch.delenv(resources.OVERRIDE_ENV, raising=False)
    runs, iterations = 10**7, 10**6  # a stage's records alone: tebibytes, more than the machine has

    def never(self):
        raise AssertionError("the transition table was built")

    monkeypatch.setattr(TaskModel, "transition_arrays", never)
    with pytest.raises(resources.InsufficientMemoryError, match="a tuning stage") as refused:
        tune.main(["--runs", str(runs), "--iterations", str(iterations), "--trials", "1",
                   "--out", str(tmp_path / "tune")])
    assert f"{runs // tune.STAGES} runs x {iterations} iterations" in str(refused.value)  # the sizes it was given
    assert not (tmp_path / "tune" / "study.db").exists()


def test_a_double_q_study_is_sized_by_its_own_tables_and_refused_before_any_trial(tmp_path, monkeypatch, capsys):
    """The old estimate (one Q-table per run, whatever the learner) let double Q-learning's five
    tables per run through; the learner's own estimate refuses it, one line, exit 2, nothing trained."""
    from tableclean_suite import resources
    from tableclean_suite.bench import commands
    from tableclean_suite.asymptotes import EXACT_BYTES_PER_ENTRY
    from tableclean_suite.learners import get_learner
    from tableclean_suite.task import TaskModel, TaskSpec

    model = TaskModel(spec=TaskSpec("faults_tune_big", segments=10, objects=2))  # 1.24 M codes x 4 actions
    spec_path = tmp_path / "big.json"
    spec_path.write_text(json.dumps(model.spec.to_dict()))
    runs, iterations = 40, 10
    stage_runs = -(-runs // tune.STAGES)
    analysis = resources.MemoryEstimate({"asymptote analysis": model.n_states * model.n_actions * EXACT_BYTES_PER_ENTRY})
    old = resources.training_memory(model.n_states, model.n_actions, stage_runs, iterations,
                                    code_bytes=model.record_dtype.itemsize) + analysis
    from tableclean_suite.learners.memory import learner_training_memory

    real = learner_training_memory(model, get_learner("double_q_learning"),
                                   stage_runs, iterations) + analysis
    available = (old.total + real.total) / 2 / resources.USABLE_FRACTION  # the old estimate fits, the real one not
    assert old.total < resources.USABLE_FRACTION * available < real.total

    monkeypatch.delenv(resources.OVERRIDE_ENV, raising=False)
    monkeypatch.setattr(resources, "available_bytes", lambda: int(available))

    def never(*args, **kwargs):
        raise AssertionError("a trial was trained")

    monkeypatch.setattr(tune.Evaluation, "stages", never)
    monkeypatch.setattr(TaskModel, "transition_arrays", never)
    out = tmp_path / "tune"
    code = commands.main(["tune", "--task", str(spec_path), "--learner", "double_q_learning", "--reward", "r4",
                          "--runs", str(runs), "--iterations", str(iterations), "--trials", "1", "--out", str(out)],
                         prog="tableclean-bench")
    error = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(error) == 1, error
    assert "double_q_learning" in error[0] and "Q-tables" in error[0] and resources.OVERRIDE_ENV in error[0], error
    assert not (out / "study.db").exists()


def test_a_study_that_would_run_too_long_is_refused_before_any_trial(tmp_path, monkeypatch):
    from tableclean_suite import resources

    monkeypatch.delenv(resources.OVERRIDE_ENV, raising=False)
    monkeypatch.setattr(tune.Evaluation, "stages", lambda self: pytest.fail("a trial was trained"))
    rate = resources.steps_per_second(resources.DEFAULT_ENGINE)
    runs, iterations = 100, 1000
    trials = int(2 * resources.MAX_TRAINING_SECONDS * rate) // (runs * iterations)  # two days of steps
    with pytest.raises(resources.TooMuchWorkError, match="learner updates at"):
        tune.main([*TINY[4:], "--runs", str(runs), "--iterations", str(iterations), "--trials", str(trials),
                   "--out", str(tmp_path / "tune")])
    assert not (tmp_path / "tune" / "study.db").exists()
