"""train()'s arguments: typed records for the hyper-parameters and run options, every keyword still accepted."""

import inspect

import numpy as np
import pytest

from tableclean_suite.learners import LearnerSettings, RunOptions, train
from tableclean_suite.task import TaskModel

RECORDS = ("rewards", "outcomes", "states", "actions", "episode_end", "q", "first_learned_at", "learned_at")


def same(a, b):
    return all(np.array_equal(getattr(a, name), getattr(b, name)) for name in RECORDS)


def test_train_has_at_most_twelve_parameters_and_keeps_the_first_four_positional():
    parameters = list(inspect.signature(train).parameters.values())
    assert len(parameters) <= 12
    assert [p.name for p in parameters[:4]] == ["learner", "reward", "runs", "iterations"]
    with pytest.raises(TypeError):
        train("q_learning", "r4", 2, 10, 0.5)  # alpha is not positional: no silent reading as the seed


def test_keywords_and_records_give_the_same_run():
    loose = train("sarsa", "r3", runs=4, iterations=200, seed=2, alpha=0.5, gamma=0.9, epsilon=0.2, max_itr=30,
                  q_init=0.25, ties="random", first_run=3, checkpoint=50)
    typed = train("sarsa", "r3", runs=4, iterations=200, seed=2,
                  settings=LearnerSettings(alpha=0.5, gamma=0.9, epsilon=0.2, max_itr=30, q_init=0.25, ties="random"),
                  options=RunOptions(first_run=3, checkpoint=50))
    assert same(loose, typed) and np.array_equal(loose.info["checkpoint_q"], typed.info["checkpoint_q"])
    assert loose.config == typed.config
    assert not same(loose, train("sarsa", "r3", runs=4, iterations=200, seed=2))  # the settings did something


def test_a_keyword_overrides_its_records_field():
    result = train(runs=2, iterations=20, settings=LearnerSettings(alpha=0.9, gamma=0.5), alpha=0.4)
    assert (result.config["alpha"], result.config["gamma"]) == (0.4, 0.5)


def test_an_unknown_keyword_names_itself_and_the_allowed_ones():
    with pytest.raises(TypeError, match=r"alpah.*allowed: .*\balpha\b.*\bworkers\b"):
        train(runs=2, iterations=10, alpah=0.5)


@pytest.mark.parametrize("make, message", [
    (lambda: LearnerSettings(alpha=0.0), r"alpha must be in \(0, 1\]"),
    (lambda: LearnerSettings(max_itr=0), r"max_itr must be in \[1"),
    (lambda: LearnerSettings(learner_options=[1]), "learner_options must be a dict"),
    (lambda: RunOptions(engine="fast"), "unknown engine 'fast'; allowed: compiled, reference"),
    (lambda: RunOptions(first_run=-1), r"first_run must be in \[0"),
])
def test_records_refuse_bad_values_naming_them(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_model_is_a_deprecated_name_of_task():
    model = TaskModel(start_state=7)
    with pytest.warns(DeprecationWarning, match="task="):
        old = train(runs=2, iterations=50, seed=1, model=model)
    assert same(old, train(runs=2, iterations=50, seed=1, task=model))
    with pytest.raises(ValueError, match="not both"), pytest.warns(DeprecationWarning):
        train(runs=2, iterations=50, model=model, task=model)
