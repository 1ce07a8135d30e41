"""The harness's learner settings: --exploration, --q-init, --learner-options, and the cell key that records them."""

import json

import pytest

from tableclean_suite.bench import experiments, run
from tableclean_suite.bench.config import ConfigError, RunConfig, parse_learner_options
from tableclean_suite.learners import LinearDecay

SMALL = dict(runs=40, iterations=400, sweeps=False, literature=False, rewards=("r4",), bootstrap_samples=10)


def key_of(config: RunConfig, learner: str) -> dict:
    cell = experiments.Cell(learner, "r4", config.alpha, config.gamma)
    model = config.task_model()
    return experiments.cell_config(experiments.CellRun(cell, config, model), "code", "task")


def summary_of(config: RunConfig, learner: str):
    cell = experiments.Cell(learner, "r4", config.alpha, config.gamma)
    summary, _, _, _ = experiments.train_cell(experiments.CellRun(cell, config, config.task_model()))
    return summary


def test_learner_options_parse_as_json_or_key_value():
    assert parse_learner_options('{"planning_steps": 20}') == {"planning_steps": 20}
    assert parse_learner_options("lambda_=0.8, trace=accumulating") == {"lambda_": 0.8, "trace": "accumulating"}
    assert parse_learner_options(None) == parse_learner_options(" ") == {}
    config = RunConfig(learners=("dyna_q", "q_lambda"), learner_options="planning_steps=20,lambda_=0.5")
    assert json.loads(config.learner_options) == {"lambda_": 0.5, "planning_steps": 20}
    assert config.learner("dyna_q").planning_steps == 20 and config.learner("q_lambda").lambda_ == 0.5
    assert config.learner("affordance_q_learning").settings() == RunConfig().learner("affordance_q_learning").settings()


@pytest.mark.parametrize("changes, field, named", [
    (dict(exploration="annealing"), "exploration", "epsilon_greedy"),
    (dict(exploration="linear_decay:epsilon_min=0.5"), "exploration", "must be <= epsilon"),
    (dict(learner_options="planning_steps"), "learner_options", "key=value"),
    (dict(learner_options="{not json"), "learner_options", "not valid JSON"),
    (dict(learner_options="planning_steps=3"), "learner_options", "no learner of this run takes"),
    (dict(learners=("dyna_q",), learner_options="planning_steps=-1"), "learner_options", "planning_steps must be in"),
    (dict(q_init="high"), "q_init", "not a number"),
])
def test_bad_learner_settings_name_the_field(changes, field, named):
    with pytest.raises(ConfigError) as caught:
        RunConfig(**changes)
    assert caught.value.field == field and named in str(caught.value)


def test_flags_reach_the_config():
    args = run.parse_args(["--learners", "dyna_q", "--exploration", "linear_decay:epsilon_min=0.01,horizon=500",
                           "--q-init", "0.25", "--learner-options", "planning_steps=7", "--no-literature"])
    config = args.config
    assert config.learner("dyna_q").exploration == LinearDecay(0.01, 500)
    assert config.learner("dyna_q").q_init == 0.25 and config.learner("dyna_q").planning_steps == 7
    assert not config.literature and config.trained_learners() == ("dyna_q", "q_learning")


def test_cell_key_records_the_learner_settings():
    """Cells trained with other learner settings must not share a key (they did when the key held
    only the learner's name, on-policy flag and target)."""
    five, twenty = (RunConfig(learners=("dyna_q",), learner_options=f"planning_steps={n}") for n in (5, 20))
    assert key_of(five, "dyna_q")["learner"]["settings"]["planning_steps"] == 5
    assert experiments.config_hash(key_of(five, "dyna_q")) != experiments.config_hash(key_of(twenty, "dyna_q"))
    plain, decayed = RunConfig(), RunConfig(exploration="linear_decay")
    assert key_of(decayed, "q_learning")["learner"]["settings"]["exploration"]["name"] == "linear_decay"
    assert experiments.config_hash(key_of(plain, "q_learning")) != experiments.config_hash(key_of(decayed, "q_learning"))
    optimistic = RunConfig(q_init=1.0)
    assert experiments.config_hash(key_of(plain, "q_learning")) != experiments.config_hash(key_of(optimistic, "q_learning"))


def test_train_cell_trains_with_the_options():
    """Dyna-Q with 0 planning steps is Q-learning: same numbers, so the option reached train()."""
    dyna = summary_of(RunConfig(learners=("dyna_q",), learner_options="planning_steps=0", **SMALL), "dyna_q")
    q_learning = summary_of(RunConfig(**SMALL), "q_learning")
    assert dyna.scalars() == q_learning.scalars()
    planned = summary_of(RunConfig(learners=("dyna_q",), learner_options="planning_steps=20", **SMALL), "dyna_q")
    assert planned.scalars() != q_learning.scalars()


def test_plateau_is_the_final_behaviours_asymptote():
    """An exploration that ends at epsilon 0 plateaus at the greedy policies' success (~100 %)."""
    greedy_end = summary_of(RunConfig(exploration="linear_decay:epsilon_min=0.0,horizon=200", **SMALL), "q_learning")
    constant = summary_of(RunConfig(**SMALL), "q_learning")
    assert constant.success_plateau < 0.9 < greedy_end.success_plateau
