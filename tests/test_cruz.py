"""Cruz et al.'s assisted learners run on this task: affordances (given, learned) and a simulated advisor."""

import math

import numpy as np
import pytest

from tableclean_suite import analysis, asymptotes
from tableclean_suite.learners import get_learner, train
from tableclean_suite.learners.assist import (
    NO_ADVICE,
    advice_action,
    advisor_policy,
    afforded_epsilon_greedy,
    given_affordances,
)
from tableclean_suite.learners.rng import LANE_ADVICE, lane_key, run_key
from tableclean_suite.rewards import get_reward_pattern
from tableclean_suite.task import Outcome, TaskModel
from learner_oracle import oracle_train

IMPROPER = int(Outcome.IMPROPER)
ASSISTED = ("affordance_q_learning", "learned_affordance_q_learning", "interactive_q_learning")
RECORDS = ("rewards", "outcomes", "states", "actions", "episode_end", "q", "first_learned_at", "learned_at")
#: Binomial tolerance in standard deviations (a false alarm about once in 10^6 checks).
SIGMAS = 5.0


def same_records(a, b) -> bool:
    return all(np.array_equal(getattr(a, name), getattr(b, name)) for name in RECORDS)


def within_binomial(count: int, trials: int, probability: float) -> bool:
    """``count`` successes of ``trials`` agree with ``probability`` within SIGMAS standard deviations."""
    spread = math.sqrt(trials * probability * (1.0 - probability))
    return abs(count - trials * probability) <= SIGMAS * max(spread, 1.0)


@pytest.mark.parametrize("name", ASSISTED)
@pytest.mark.parametrize("exploration", [None, "softmax", "linear_decay"])
def test_compiled_loop_equals_plain_loop(name, exploration):
    kwargs = dict(runs=4, iterations=600, seed=5, exploration=exploration)
    assert same_records(train(name, **kwargs), oracle_train(name, **kwargs))


def test_combined_assistance_on_sarsa_equals_plain_loop():
    options = {"affordance": "learned", "advice_probability": 0.3, "advice_consistency": 0.4}
    kwargs = dict(runs=4, iterations=600, seed=2, learner_options=options)
    assert same_records(train("sarsa", **kwargs), oracle_train("sarsa", **kwargs))


def test_no_assistance_leaves_the_main_lane_unchanged():
    kwargs = dict(runs=8, iterations=800, seed=1)
    plain = train("q_learning", **kwargs)
    silent = train("interactive_q_learning", learner_options={"advice_probability": 0.0}, **kwargs)
    unafforded = train("affordance_q_learning", learner_options={"affordance": "none"}, **kwargs)
    assert same_records(plain, silent) and same_records(plain, unafforded)


@pytest.mark.parametrize("exploration", [None, "softmax"])
def test_given_affordances_never_take_an_improper_action(exploration):
    result = train("affordance_q_learning", runs=400, iterations=3000, epsilon=1.0, exploration=exploration, seed=3)
    assert not np.any(result.outcomes == IMPROPER)
    assert result.episodes()["success"].mean() > 0  # it does finish episodes


def test_learned_affordances_take_each_improper_pair_at_most_once_per_run():
    model = TaskModel()
    result = train("learned_affordance_q_learning", runs=300, iterations=3000, epsilon=0.5, seed=4)
    improper = result.outcomes == IMPROPER
    assert improper.any()  # before it has seen a pair fail, the pair is allowed
    for run in range(result.runs):
        codes = result.states[run][improper[run]].astype(np.int64) * model.n_actions + result.actions[run][improper[run]]
        assert len(codes) == len(set(codes.tolist())), f"run {run} repeated an improper pair"


def test_plain_q_learning_repeats_improper_pairs():
    """The check above can fail: without learned affordances improper pairs recur."""
    result = train("q_learning", runs=50, iterations=3000, epsilon=0.5, seed=4)
    improper = result.outcomes == IMPROPER
    codes = result.states[0][improper[0]].astype(np.int64) * 4 + result.actions[0][improper[0]]
    assert len(codes) > len(set(codes.tolist()))


@pytest.mark.parametrize("probability, consistency", [(0.5, 1.0), (0.3, 0.6), (1.0, 0.0)])
def test_advisor_follows_l_and_c_in_distribution(probability, consistency):
    model = TaskModel()
    advisor = advisor_policy(model)
    parameters = np.array([probability, consistency])
    key = lane_key(np.uint64(run_key(7, 0)), LANE_ADVICE)
    state, trials = int(model.start_states()[0].index), 20_000
    advice = np.array([advice_action(advisor, parameters, key, t, state, model.n_actions) for t in range(trials)])
    advised = advice != NO_ADVICE
    assert within_binomial(int(advised.sum()), trials, probability)
    own = consistency + (1.0 - consistency) / model.n_actions
    assert within_binomial(int((advice[advised] == advisor[state]).sum()), int(advised.sum()), own)


def test_a_fully_advised_learner_acts_as_the_advisor():
    model = TaskModel()
    result = train("interactive_q_learning", runs=20, iterations=500,
                   learner_options={"advice_probability": 1.0, "advice_consistency": 1.0})
    np.testing.assert_array_equal(result.actions, advisor_policy(model)[result.states.astype(np.int64)])
    assert result.episodes()["success"].all()


def test_advisor_policy_is_the_shortest_plan():
    model = TaskModel()
    advisor = advisor_policy(model)
    for start in model.start_states():
        state, taken = start, []
        while not state.is_terminal:
            taken.append(int(advisor[state.index]))
            state, _ = model.step(state, taken[-1])
        assert taken == [int(a) for a in model.shortest_plan(start)]


def test_given_affordances_are_the_action_mask():
    model = TaskModel()
    given = given_affordances(model)
    for state in model.reachable_states():
        if not state.is_terminal:
            np.testing.assert_array_equal(given[state.index], model.action_mask(state))


def test_afforded_exploration_is_uniform_over_afforded_actions():
    mask = np.array([1, 0, 1, 0], dtype=np.int8)
    q_row = np.zeros(4)
    picks = [afforded_epsilon_greedy(q_row, mask, 1.0, 0.0, (k + 0.5) / 100) for k in range(100)]
    assert picks.count(0) == picks.count(2) == 50


@pytest.mark.parametrize("name", ("q_learning", *ASSISTED))
def test_final_asymptotes_match_the_measured_late_success(name):
    model = TaskModel()
    result = train(name, runs=300, iterations=3000, seed=9)
    chain = asymptotes.EpisodeChain.build(model, get_reward_pattern("r4"))
    plateau = analysis.final_asymptotes(result, chain, 500, model).success.mean()
    episodes = result.episodes()
    late = episodes[episodes.first_iteration > 2000]["success"]
    assert abs(late.mean() - plateau) < SIGMAS * math.sqrt(plateau * (1 - plateau) / len(late)) + 2e-3


def test_assisted_plateaus_rank_as_expected():
    model = TaskModel()
    chain = asymptotes.EpisodeChain.build(model, get_reward_pattern("r4"))
    plateau = {name: analysis.final_asymptotes(train(name, runs=100, iterations=3000), chain, 500, model).success.mean()
               for name in ("q_learning", *ASSISTED)}
    assert plateau["affordance_q_learning"] > 0.999
    assert plateau["q_learning"] < plateau["interactive_q_learning"] < plateau["learned_affordance_q_learning"]


def test_afforded_and_advised_probabilities_by_hand():
    q = np.array([[[0.0, 2.0, 1.0]]])
    probabilities = analysis.afforded_probabilities(q, np.array([[True, False, True]]), 0.2)
    np.testing.assert_allclose(probabilities, [[[0.1, 0.0, 0.9]]])
    mixed = analysis.advised_probabilities(probabilities[0], np.array([1]), 0.5, 0.4)
    np.testing.assert_allclose(mixed, [[0.5 * 0.2 + 0.05, 0.5 * (0.4 + 0.2), 0.5 * 0.2 + 0.45]])


@pytest.mark.parametrize("options, message", [
    ({"affordance": "oracle"}, "affordance must be one of none, given, learned"),
    ({"advice_probability": 1.5}, r"advice_probability must be in \[0, 1\]"),
    ({"advice_consistency": -0.1}, r"advice_consistency must be in \[0, 1\]"),
])
def test_bad_assistance_options_fail_clearly(options, message):
    with pytest.raises(ValueError, match=message):
        train("q_learning", runs=1, iterations=1, learner_options=options)


def test_affordances_need_a_one_step_q_learning_or_sarsa_target():
    with pytest.raises(ValueError, match="needs the one_step update rule"):
        get_learner("q_lambda").configured({"affordance": "given"})


def test_settings_record_the_assistance():
    assert get_learner("affordance_q_learning").settings()["affordance"] == "given"
    settings = get_learner("interactive_q_learning").settings()
    assert (settings["advice_probability"], settings["advice_consistency"]) == (0.5, 1.0)
    assert "affordance" not in get_learner("q_learning").settings()
