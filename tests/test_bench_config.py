"""RunConfig is the one source of a run's settings; the command line is built from it."""

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import pytest

from tableclean_suite.bench import run
from tableclean_suite.bench.config import ConfigError, RunConfig, defaults, field_docs

ROOT = Path(__file__).resolve().parents[1]

#: The paper's settings (Sec. 3): written once, in RunConfig.
PAPER_DEFAULTS = dict(alpha=0.3, gamma=0.3, epsilon=0.1, max_itr=500, runs=1000, iterations=4000, seed=0,
                      task="paper")


def test_defaults_are_the_papers():
    config = RunConfig()
    for name, value in PAPER_DEFAULTS.items():
        assert getattr(config, name) == value, name
    assert config.learners == ("q_learning", "sarsa") and config.rewards == ("r1", "r2", "r3", "r4")
    assert config.start is None and config.ineffective is None  # as the task spec says


def test_command_line_defaults_are_the_configs():
    assert run.parse_args([]).config == RunConfig()
    assert vars(run.parse_args([]).config) == defaults()


def test_every_field_has_a_docstring_and_a_flag():
    docs = field_docs()
    names = [f.name for f in dataclasses.fields(RunConfig)]
    assert sorted(docs) == sorted(names)
    assert all(len(text) > 10 for text in docs.values())
    help_text = run.build_parser().format_help()
    for name in names:
        assert run.flag_of(name) in help_text, name


def test_config_is_frozen_and_feeds_train_and_the_cell_key():
    config = RunConfig(runs=7, iterations=50, workers=2, out="x")
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.runs = 8
    from tableclean_suite.bench.experiments import Cell, CellRun

    run = CellRun(Cell("q_learning", "r4", 0.3, 0.3), config, None)
    assert run.train == dict(iterations=50, epsilon=0.1, max_itr=500, seed=0, backend="symbolic", workers=2)
    settings = config.cell_settings()
    assert settings["runs"] == 7 and settings["iterations"] == 50
    assert not set(settings) & set(RunConfig.NOT_IN_CELL_KEY)
    assert json.loads(json.dumps(config.to_json()))["learners"] == ["q_learning", "sarsa"]


@pytest.mark.parametrize(
    "changes, field, named",
    [
        (dict(alpha=0.0), "alpha", "alpha"),
        (dict(runs=0), "runs", "runs"),
        (dict(gamma_sweep=(0.5, 1.5)), "gamma_sweep", "1.5"),
        (dict(learners=("dqn",)), "learners", "q_learning, sarsa"),
        (dict(rewards=()), "rewards", "at least one"),
        (dict(sweep_reward="r9"), "sweep_reward", "r9"),
        (dict(threshold=1.5), "threshold", "(0, 1]"),
        (dict(start="random"), "start", "uniform_unclean"),
        (dict(task="kitchen"), "task", "three_segments"),
        (dict(backend="gpu"), "backend", "symbolic"),
        (dict(backend="calibrated"), "transitions", "calibrated"),
        (dict(workers=0), "workers", ">= 1"),
    ],
)
def test_bad_values_name_the_field_and_what_is_allowed(changes, field, named):
    with pytest.raises(ConfigError) as caught:
        RunConfig(**changes)
    assert caught.value.field == field
    assert named in str(caught.value)


def test_list_flags_take_spaces_or_commas():
    spaced = run.parse_args(["--rewards", "r2", "r4", "--learners", "sarsa", "--alpha-sweep", "0.5", "0.7"]).config
    commas = run.parse_args(["--rewards", "r2,r4", "--learners", "sarsa", "--alpha-sweep", "0.5,0.7"]).config
    mixed = run.parse_args(["--rewards", "r2,", "r4", "--learners", "sarsa", "--alpha-sweep", "0.5", "0.7,0.5"]).config
    assert spaced == commas == mixed
    assert spaced.rewards == ("r2", "r4") and spaced.alpha_sweep == (0.5, 0.7) and spaced.learners == ("sarsa",)
    assert run.parse_args(["--gamma-sweep", "0.3", "0.9", "--no-sweeps"]).config.gamma_sweep == (0.3, 0.9)


def test_start_and_ineffective_override_the_task_spec():
    config = run.parse_args(["--task", "three_segments", "--start", "uniform_unclean"]).config
    model = config.task_model()
    assert model.n_segments == 3 and model.start.value == "uniform_unclean"
    assert model.ineffective.value == "ineffective"  # as the spec says
    assert RunConfig(ineffective="improper").task_model().ineffective.value == "improper"


def test_task_from_a_json_file(tmp_path):
    path = tmp_path / "wide.json"
    path.write_text(json.dumps({"name": "wide", "segments": 4, "objects": 1, "start": "uniform_unclean"}))
    model = run.parse_args(["--task", str(path)]).config.task_model()
    assert model.n_segments == 4 and model.start.value == "uniform_unclean"
    assert RunConfig(task=str(path), start="fixed").task_model().start.value == "fixed"


def cli(*args):
    return subprocess.run([sys.executable, "-m", "benchmarks.run", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=300)


def test_help_lists_the_allowed_names():
    result = cli("--help")
    assert result.returncode == 0
    text = " ".join(result.stdout.split())
    for names in ("q_learning, sarsa, expected_sarsa", "r1, r2, r3, r4", "paper, three_segments"):
        assert names in text, names
    assert "(default: q_learning sarsa)" in text and "(default: 4000)" in text


@pytest.mark.parametrize(
    "args, named",
    [
        (["--task", "kitchen"], ["'kitchen'", "paper, three_segments"]),
        (["--task", "missing.json"], ["missing.json", "does not exist"]),
        (["--rewards", "r2", "r9"], ["'r9'", "r1, r2, r3, r4"]),
        (["--learners", "sarsa,dqn"], ["'dqn'", "q_learning, sarsa"]),
        (["--alpha-sweep", "0.3", "x"], ["--alpha-sweep", "'x'"]),
        (["--start", "random"], ["--start", "uniform_unclean"]),
    ],
)
def test_bad_names_exit_2_with_the_allowed_ones(args, named, tmp_path):
    result = cli(*args, "--out", str(tmp_path / "never"))
    assert result.returncode == 2, result.stderr
    for text in named:
        assert text in result.stderr
    assert "Traceback" not in result.stderr
    assert not (tmp_path / "never").exists()
