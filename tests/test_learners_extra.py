"""Double Q-learning, Q(lambda), SARSA(lambda), Dyna-Q, explorations and optimistic starts.

Hand-computed updates, the dense definition of traces, compiled == plain loop for every learner
and exploration, schedules and softmax by formula, clear errors, the paper's numbers untouched,
batching independence, and the exact analysis of an exploration's final policy.
"""

import math

import numba
import numpy as np
import pytest

from tableclean_suite import analysis, metrics
from tableclean_suite.backends import tabular
from tableclean_suite.learners import (
    LinearDecay,
    Softmax,
    TabularLearner,
    as_exploration,
    code_digest,
    exploration_names,
    get_learner,
    learner_names,
    parse_exploration,
    softmax_probabilities,
    train,
)
from tableclean_suite.learners.exploration import exploration_parameter, softmax_action
from tableclean_suite.learners.rng import (
    LANE_LEARNER,
    LANE_PLANNING,
    STREAM_DOUBLE_TABLE,
    STREAM_EXPLORE,
    STREAM_RANDOM_ACTION,
    lane_key_py,
    run_key,
)
from tableclean_suite.learners.rules import METHOD_TRACES, softmax_expected_sarsa_target
from tableclean_suite.task import Action, Outcome, TaskModel
from learner_oracle import _schedule, oracle_train, uniform_at_py, uniform_py

RECORDS = ("rewards", "outcomes", "states", "actions", "episode_end", "q", "first_learned_at", "learned_at")
NEW_LEARNERS = ("double_q_learning", "q_lambda", "sarsa_lambda", "dyna_q")
ALL_LEARNERS = ("q_learning", "sarsa", "expected_sarsa", *NEW_LEARNERS)
ALPHA = GAMMA = 0.3
MOVE, PICK = int(Action.MOVE), int(Action.PICK)


def assert_same(a, b):
    for name in RECORDS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def test_registered_names():
    assert set(NEW_LEARNERS) <= set(learner_names())
    assert exploration_names() == ["epsilon_greedy", "linear_decay", "exponential_decay", "visit_decay", "softmax"]


# -- hand-computed updates -------------------------------------------------------------------------
# With epsilon = 0 and Q = 0 the paper's task starts 0 -move-> 1 -move-> 0 -move-> 1 (ties go to MOVE);
# r4 gives +0.01 then the looping penalty -0.01 twice.  max_itr = 3 makes that one 3-step episode.
THREE_STEPS = dict(runs=1, iterations=3, epsilon=0.0, max_itr=3)


@pytest.mark.parametrize("learner", ["sarsa_lambda", "q_lambda"])
@pytest.mark.parametrize("trace", ["replacing", "accumulating"])
def test_traces_over_a_three_step_episode_hand_computed(learner, trace):
    lam = 0.5
    result = train(learner, "r4", **THREE_STEPS, learner_options={"lambda_": lam, "trace": trace})
    assert result.states[0].tolist() == [0, 1, 0] and result.actions[0].tolist() == [MOVE] * 3
    assert result.rewards[0].tolist() == [0.01, -0.01, -0.01]
    decay = GAMMA * lam
    # step 1: (0, move) -> 1; delta = 0.01; e(0, move) = 1
    q0m = ALPHA * 0.01
    e0m = decay
    # step 2: (1, move) -> 0, next action move (greedy: Q(0, move) > 0); delta uses Q(0, move)
    delta = -0.01 + GAMMA * q0m - 0.0
    q0m += ALPHA * delta * e0m
    q1m = ALPHA * delta * 1.0
    e0m, e1m = e0m * decay, decay
    # step 3: (0, move) -> 1 again; next action in 1: pick (Q(1, move) < 0 = Q(1, pick)), greedy
    assert q1m < 0
    delta = -0.01 + GAMMA * 0.0 - q0m
    e0m = e0m + 1.0 if trace == "accumulating" else 1.0
    q0m += ALPHA * delta * e0m
    q1m += ALPHA * delta * e1m
    assert result.q[0, 0, MOVE] == pytest.approx(q0m, rel=1e-12)
    assert result.q[0, 1, MOVE] == pytest.approx(q1m, rel=1e-12)
    one_step = train("sarsa", "r4", **THREE_STEPS)
    assert result.q[0, 1, MOVE] != one_step.q[0, 1, MOVE]  # the trace reached back one step


def _table_draw(seed, run, t):
    return uniform_py(lane_key_py(run_key(seed, run), LANE_LEARNER), t, STREAM_DOUBLE_TABLE)


@pytest.mark.parametrize("seed", range(6))
def test_double_q_updates_the_drawn_table_evaluated_by_the_other(seed):
    result = train("double_q_learning", "r4", runs=1, iterations=2, epsilon=0.0, seed=seed)
    tables = result.info["double_q_tables"][0]  # (2, S, A)
    first, second = (0 if _table_draw(seed, 0, t) < 0.5 else 1 for t in range(2))
    expected = np.zeros((2, 24, 4))
    expected[first, 0, MOVE] = ALPHA * 0.01  # step 1: (0, move) -> 1, r = 0.01, Q(1) = 0
    # step 2: (1, move) -> 0, r = -0.01: the updated table picks argmax over Q(0); the other values it
    select, evaluate = expected[second, 0], expected[1 - second, 0]
    expected[second, 1, MOVE] = ALPHA * (-0.01 + GAMMA * evaluate[int(np.argmax(select))])
    np.testing.assert_array_equal(tables, expected)
    np.testing.assert_array_equal(result.q[0], (tables[0] + tables[1]) * 0.5)


def test_double_q_draws_pick_both_tables():
    draws = [_table_draw(seed, 0, t) < 0.5 for seed in range(6) for t in range(2)]
    assert any(draws) and not all(draws)  # the parametrised test above sees both cases


def test_dyna_planning_step_hand_computed():
    # one real step (0, move) -> 1, r = 0.01; then one planning update on the only observed pair
    result = train("dyna_q", "r4", runs=1, iterations=1, epsilon=0.0, learner_options={"planning_steps": 1})
    q0m = ALPHA * 0.01
    q0m += ALPHA * (0.01 + GAMMA * 0.0 - q0m)
    assert result.q[0, 0, MOVE] == q0m
    # two real steps and two planning updates each: the planning lane's draws pick among observed pairs
    steps = 2
    result = train("dyna_q", "r4", runs=1, iterations=2, epsilon=0.0, learner_options={"planning_steps": steps})
    key = lane_key_py(run_key(0, 0), LANE_PLANNING)
    q = np.zeros((24, 4))
    model = {}
    for t, (s, r, s_next) in enumerate([(0, 0.01, 1), (1, -0.01, 0)]):
        q[s, MOVE] += ALPHA * (r + GAMMA * q[s_next].max() - q[s, MOVE])
        model[s] = (s_next, r)
        observed = sorted(model)
        for j in range(steps):
            ps = observed[int(uniform_at_py(key, t * steps + j) * len(observed))]
            pn, pr = model[ps]
            q[ps, MOVE] += ALPHA * (pr + GAMMA * q[pn].max() - q[ps, MOVE])
    np.testing.assert_array_equal(result.q[0], q)


# -- traces equal their dense definition, replayed from the records ---------------------------------
def _epsilon_greedy_action(q_row, epsilon, key, t):
    if uniform_py(key, t, STREAM_EXPLORE) < epsilon:
        return min(int(uniform_py(key, t, STREAM_RANDOM_ACTION) * len(q_row)), len(q_row) - 1)
    return int(np.argmax(q_row))


@pytest.mark.parametrize("learner,trace", [("q_lambda", "replacing"), ("q_lambda", "accumulating"),
                                           ("sarsa_lambda", "replacing"), ("sarsa_lambda", "accumulating")])
def test_traces_equal_the_dense_sweep_replayed_from_records(learner, trace):
    lam, epsilon, iterations = 0.8, 0.3, 400
    result = train(learner, "r4", runs=1, iterations=iterations, epsilon=epsilon, seed=9, max_itr=40,
                   learner_options={"lambda_": lam, "trace": trace})
    states, actions, rewards = result.states[0], result.actions[0], result.rewards[0]
    outcomes, ends = result.outcomes[0], result.episode_end[0]
    key = run_key(9, 0)
    q, e = np.zeros((24, 4)), np.zeros((24, 4))
    cuts = 0
    for t in range(iterations):
        if t == 0 or ends[t - 1] != 0:
            e[:] = 0.0
        s, a, r = states[t], actions[t], rewards[t]
        terminal = outcomes[t] == Outcome.TERMINAL
        s_next = s if terminal else (states[t + 1] if t + 1 < iterations and ends[t] == 0 else None)
        if s_next is None:  # truncated or last step: recompute the next state from the model
            s_next = TaskModel().step(int(s), int(a))[0].index
        a_next = None if terminal else _epsilon_greedy_action(q[s_next], epsilon, key, t + 1)
        if a_next is not None and t + 1 < iterations and ends[t] == 0:
            assert a_next == actions[t + 1]
        if terminal:
            target = r
        elif learner == "q_lambda":
            target = r + GAMMA * q[s_next].max()
        else:
            target = r + GAMMA * q[s_next, a_next]
        exploratory = a_next is not None and q[s_next, a_next] < q[s_next].max()
        e[s, a] = e[s, a] + 1.0 if trace == "accumulating" else 1.0
        q += (ALPHA * (target - q[s, a])) * e
        if learner == "q_lambda" and exploratory:
            e[:] = 0.0
            cuts += 1
        else:
            e *= GAMMA * lam
    assert cuts > 0 or learner == "sarsa_lambda"
    np.testing.assert_array_equal(result.q[0], q)


def test_lambda_zero_and_no_planning_reduce_to_the_one_step_learners():
    kwargs = dict(runs=5, iterations=600, seed=3, epsilon=0.2)
    assert_same(train("sarsa_lambda", "r4", learner_options={"lambda_": 0.0}, **kwargs), train("sarsa", "r4", **kwargs))
    assert_same(train("dyna_q", "r4", learner_options={"planning_steps": 0}, **kwargs),
                train("q_learning", "r4", **kwargs))


def test_a_user_target_with_the_trace_rule_gets_the_same_numbers():
    @numba.njit
    def my_sarsa(q_next, next_action, reward, gamma, epsilon, terminal):
        return reward if terminal else reward + gamma * q_next[next_action]

    mine = TabularLearner("my_sarsa_lambda", my_sarsa, on_policy=True, method=METHOD_TRACES, lambda_=0.9)
    kwargs = dict(runs=3, iterations=500, seed=2, task="three_segments_two_objects")
    assert_same(train(mine, "r2", **kwargs), train("sarsa_lambda", "r2", **kwargs))


# -- compiled == plain loop ------------------------------------------------------------------------
EXPLORATIONS = ["epsilon_greedy", "linear_decay", "exponential_decay", "visit_decay", "softmax",
                {"name": "softmax", "temperature": 0.5, "rate": 0.01}]


#: Explorations whose compiled loop on a wider state code (a multi-object task) no other quick test
#: trains: their cases compile it (tens of seconds from an empty cache) and are marked ``jit``.
ONLY_HERE = ("linear_decay", "exponential_decay")


@pytest.mark.parametrize("exploration,task", [
    pytest.param(exploration, task, id=f"{exploration if isinstance(exploration, str) else 'softmax_decaying'}-{task}",
                 marks=[pytest.mark.jit] if task != "paper" and exploration in ONLY_HERE else [])
    for task in ("paper", "three_segments_two_objects") for exploration in EXPLORATIONS])
@pytest.mark.parametrize("learner", ALL_LEARNERS)
def test_compiled_equals_plain_loop_for_every_learner_and_exploration(learner, exploration, task):
    kwargs = dict(runs=2, iterations=200, seed=7, epsilon=0.3, max_itr=60, task=task, exploration=exploration)
    compiled, plain = train(learner, "r4", **kwargs), oracle_train(learner, "r4", **kwargs)
    assert_same(compiled, plain)
    if learner == "double_q_learning":
        np.testing.assert_array_equal(compiled.info["double_q_tables"], plain.info["double_q_tables"])


@pytest.mark.parametrize("learner", NEW_LEARNERS)
def test_compiled_equals_plain_loop_with_options_and_optimistic_start(learner):
    options = {"q_lambda": {"lambda_": 0.6, "trace": "accumulating"}, "sarsa_lambda": {"lambda_": 1.0},
               "dyna_q": {"planning_steps": 7}}.get(learner, {})
    kwargs = dict(runs=2, iterations=300, seed=1, task="three_segments_two_objects", q_init=1.5,
                  learner_options=options, exploration="visit_decay")
    compiled = train(learner, "r1", **kwargs)
    assert_same(compiled, oracle_train(learner, "r1", **kwargs))
    assert compiled.config["learner_settings"]["q_init"] == 1.5
    assert np.any(compiled.q == 1.5)  # untouched entries keep the optimistic value


def test_optimistic_values_change_the_numbers_and_default_is_zero():
    kwargs = dict(runs=3, iterations=300, seed=4)
    assert_same(train("q_learning", "r2", q_init=0.0, **kwargs), train("q_learning", "r2", **kwargs))
    optimistic = train("q_learning", "r2", q_init=2.0, **kwargs)
    assert not np.array_equal(optimistic.actions, train("q_learning", "r2", **kwargs).actions)


# -- explorations ----------------------------------------------------------------------------------
@pytest.mark.parametrize("exploration,epsilon,cases", [
    (LinearDecay(epsilon_min=0.02, horizon=100), 0.1, [(0, 0, 0.1), (50, 0, 0.06), (100, 0, 0.02), (10**6, 0, 0.02)]),
    (as_exploration("exponential_decay", epsilon_min=0.01, rate=0.01), 0.1,
     [(0, 0, 0.1), (100, 0, 0.1 * math.exp(-1.0)), (1000, 0, 0.01)]),
    (as_exploration("visit_decay", scale=0.5), 0.1, [(7, 0, 0.1), (7, 2, 0.05), (0, 18, 0.01)]),
    (as_exploration("epsilon_greedy"), 0.25, [(0, 0, 0.25), (10**6, 10**6, 0.25)]),
    (Softmax(temperature=1.0, temperature_min=0.1, rate=math.log(2.0)), 0.1, [(0, 0, 1.0), (1, 0, 0.5), (50, 0, 0.1)]),
])
def test_schedules_at_given_steps(exploration, epsilon, cases):
    parameters = exploration.kernel_parameters(epsilon)
    for iteration, visits, expected in cases:
        assert exploration.parameter_at(epsilon, iteration, visits) == pytest.approx(expected, rel=1e-12)
        compiled = exploration_parameter(exploration.code, parameters, iteration, visits)
        assert compiled == _schedule(exploration, epsilon, iteration, visits)


def test_the_kernel_follows_the_schedule():
    # epsilon 1 -> 0 over 100 iterations: explore exactly when the explore draw is below epsilon_t
    horizon, iterations, seed = 100, 300, 5
    result = train("q_learning", "r1", runs=1, iterations=iterations, seed=seed, epsilon=1.0, max_itr=1000,
                   exploration=LinearDecay(epsilon_min=0.0, horizon=horizon))
    key = run_key(seed, 0)
    explored = 0
    for t in range(iterations):
        if uniform_py(key, t, STREAM_EXPLORE) < max(0.0, 1.0 - t / horizon):
            assert result.actions[0, t] == min(int(uniform_py(key, t, STREAM_RANDOM_ACTION) * 4), 3)
            explored += 1
    assert 30 < explored < 70  # about half of the first 100 steps, none after
    constant = train("q_learning", "r1", runs=1, iterations=iterations, seed=seed, epsilon=1.0, max_itr=1000)
    assert not np.array_equal(constant.actions, result.actions)


def test_softmax_probabilities_of_a_q_row():
    row = np.array([1.0, 2.0, 0.0, 2.0])
    weights = np.array([math.exp(-2.0), 1.0, math.exp(-4.0), 1.0])
    np.testing.assert_allclose(softmax_probabilities(row, 0.5), weights / weights.sum(), rtol=1e-14)
    np.testing.assert_allclose(softmax_probabilities(row, 1e-6), [0, 0.5, 0, 0.5])
    np.testing.assert_allclose(softmax_probabilities(row, 1e6), [0.25] * 4, rtol=1e-5)
    # the sampler: the share of a fine grid of draws that picks each action is its probability
    grid = (np.arange(20000) + 0.5) / 20000
    picks = np.bincount([softmax_action(row, 0.5, u) for u in grid], minlength=4) / grid.size
    np.testing.assert_allclose(picks, weights / weights.sum(), atol=1e-4)
    # expected SARSA under softmax uses these probabilities
    expected = float(weights @ row / weights.sum())
    assert softmax_expected_sarsa_target(row, 0.5, 0.9, 0.5, False) == pytest.approx(0.5 + 0.9 * expected)
    assert softmax_expected_sarsa_target(row, 0.5, 0.9, 0.5, True) == 0.5


def test_expected_sarsa_uses_the_behaviour_policy_of_the_step():
    kwargs = dict(runs=3, iterations=400, seed=8, epsilon=0.5)
    constant = train("expected_sarsa", "r2", **kwargs)
    # the same actions would follow as long as Q is the same; a decayed epsilon in the target changes Q
    decayed = train("expected_sarsa", "r2", exploration=LinearDecay(epsilon_min=0.0, horizon=50), **kwargs)
    assert not np.array_equal(constant.q, decayed.q)
    softmax = train("expected_sarsa", "r2", exploration="softmax", **kwargs)
    plain = oracle_train("expected_sarsa", "r2", exploration="softmax", **kwargs)
    assert_same(softmax, plain)


def test_exploration_forms_and_parsing():
    assert as_exploration(None).name == "epsilon_greedy"
    assert as_exploration({"name": "linear_decay", "horizon": 5}) == LinearDecay(horizon=5)
    assert parse_exploration("linear_decay:horizon=2000,epsilon_min=0.01") == LinearDecay(0.01, 2000)
    assert as_exploration(LinearDecay(horizon=7).to_dict()) == LinearDecay(horizon=7)
    result = train(runs=1, iterations=10, exploration={"name": "softmax", "temperature": 0.2})
    assert result.config["learner_settings"]["exploration"] == {"name": "softmax", "temperature": 0.2,
                                                                "temperature_min": 0.01, "rate": 0.0}


# -- errors ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs,message", [
    ({"learner": "q_lambda", "learner_options": {"lambda_": 1.5}}, r"learner 'q_lambda': lambda_ must be in \[0, 1\], got 1.5"),
    ({"learner": "q_lambda", "learner_options": {"trace": "dutch"}}, "trace must be one of replacing, accumulating, got 'dutch'"),
    ({"learner": "q_lambda", "learner_options": {"lamda": 0.5}}, r"takes lambda_, trace, affordance, advice_probability, advice_consistency, ties; got \['lamda'\]"),
    ({"learner": "q_learning", "learner_options": {"lambda_": 0.5}},
     r"takes affordance, advice_probability, advice_consistency, ties; got \[.lambda_.\]"),
    ({"learner": "dyna_q", "learner_options": {"planning_steps": -1}}, r"planning_steps must be in \[0, 10000\], got -1"),
    ({"learner": "dyna_q", "learner_options": {"planning_steps": 2.5}}, "planning_steps must be an integer"),
    ({"learner_options": [("lambda_", 1)]}, "learner_options must be a dict"),
    ({"q_init": float("nan")}, "q_init must be a finite number"),
    ({"q_init": "high"}, "q_init must be a number"),
    ({"exploration": "greedy_ish"}, "unknown exploration 'greedy_ish'; allowed: epsilon_greedy, linear_decay"),
    ({"exploration": {"name": "linear_decay", "horizon": 0}}, r"'linear_decay': horizon must be in \[1, "),
    ({"exploration": {"name": "linear_decay", "epsilon_min": 0.5}}, "epsilon_min 0.5 must be <= epsilon 0.1"),
    ({"exploration": {"name": "exponential_decay", "rate": -1}}, r"'exponential_decay': rate must be in \[0, "),
    ({"exploration": {"name": "visit_decay", "c": 1}}, r"unknown parameter\(s\) \['c'\]; allowed: scale"),
    ({"exploration": {"name": "softmax", "temperature": 0}}, r"temperature must be in \(0, "),
    ({"exploration": {"name": "softmax", "temperature": 0.1, "temperature_min": 0.5}}, "temperature_min must be in"),
    ({"exploration": {"horizon": 3}}, "needs a 'name'"),
])
def test_bad_parameters_raise_clear_errors(kwargs, message):
    with pytest.raises(ValueError, match=message):
        train(**{"runs": 1, "iterations": 5, **kwargs})


def test_update_rules_that_need_the_max_target_refuse_others():
    with pytest.raises(ValueError, match="needs the built-in Q-learning target"):
        TabularLearner("bad_dyna", get_learner("sarsa").td_target, True, target_code=1, method=3)
    with pytest.raises(ValueError, match="unknown method 9"):
        TabularLearner("bad_method", get_learner("sarsa").td_target, method=9)


# -- reproducibility ------------------------------------------------------------------------------
@pytest.mark.parametrize("learner", NEW_LEARNERS)
def test_results_do_not_depend_on_batching(learner):
    """Runs 245-259 trained alone (one chunk) equal the same runs of a 260-run training, where they
    straddle the boundary between its chunks of ``RUNS_PER_CHUNK`` runs."""
    kwargs = dict(iterations=300, seed=5, exploration="softmax" if learner == "double_q_learning" else "visit_decay")
    runs, first = 260, 245
    assert first < tabular.RUNS_PER_CHUNK < runs
    whole = train(learner, "r3", runs=runs, **kwargs)
    tail = train(learner, "r3", runs=runs - first, first_run=first, **kwargs)
    for name in RECORDS:
        np.testing.assert_array_equal(getattr(whole, name)[first:], getattr(tail, name))


def test_default_settings_keep_the_paper_numbers():
    """Explicit defaults (exploration, q_init, no options) change nothing; see PAPER_PINS in test_learners_spec."""
    from test_learners_spec import PAPER_PINS, records_digest

    for learner, reward, options, pin in PAPER_PINS:
        result = train(learner, reward, runs=40, iterations=1500, seed=11, task=TaskModel(**options),
                       exploration="epsilon_greedy", q_init=0.0, learner_options={})
        assert records_digest(result) == pin


def test_code_digest_follows_the_learner_settings():
    q_lambda = get_learner("q_lambda")
    assert code_digest(q_lambda) != code_digest(q_lambda.configured({"lambda_": 0.5}))
    assert code_digest(q_lambda) != code_digest(q_lambda.configured(exploration=as_exploration("softmax")))
    assert code_digest(q_lambda) == code_digest(get_learner("q_lambda"))


# -- exact analysis of the final behaviour policy -------------------------------------------------
def test_exact_analysis_of_final_distributions():
    model = TaskModel()
    q = np.random.default_rng(0).normal(size=(3, 24, 4))
    greedy = analysis.greedy_policy(q)
    base = analysis.exact_success_probability(greedy, 0.1, 500)
    same = analysis.exact_success_probability(None, 0.1, 500, exploration="epsilon_greedy", q=q)
    np.testing.assert_array_equal(base, same)
    # a linear schedule past its horizon is constant epsilon_min
    decayed = analysis.exact_success_probability(greedy, 0.1, 500, exploration=LinearDecay(0.02, 100), iteration=400)
    np.testing.assert_array_equal(decayed, analysis.exact_success_probability(greedy, 0.02, 500))
    # visit decay: every state visited 9 times with scale 1/9 halves epsilon
    halved = analysis.exact_success_probability(greedy, 0.1, 500, exploration={"name": "visit_decay", "scale": 1 / 9},
                                                visits=np.full(24, 9))
    np.testing.assert_allclose(halved, analysis.exact_success_probability(greedy, 0.05, 500), rtol=1e-12)
    # softmax: cold is greedy, hot is uniformly random
    cold = analysis.exact_success_probability(None, 0.1, 500, exploration=Softmax(1e-9, 1e-9), q=q, iteration=0)
    np.testing.assert_allclose(cold, analysis.exact_success_probability(greedy, 0.0, 500), atol=1e-12)
    hot = analysis.exact_success_probability(None, 0.1, 500, exploration=Softmax(1e6, 1.0), q=q, iteration=0)
    np.testing.assert_allclose(hot, analysis.exact_success_probability(greedy, 1.0, 500), rtol=1e-4)
    with pytest.raises(ValueError, match="needs iteration="):
        analysis.exact_success_probability(greedy, 0.1, 500, exploration="linear_decay", model=model)
    with pytest.raises(ValueError, match="needs the final Q-tables"):
        analysis.exact_success_probability(greedy, 0.1, 500, exploration="softmax", iteration=3)
    with pytest.raises(ValueError, match="needs visits="):
        analysis.exact_success_probability(greedy, 0.1, 500, exploration="visit_decay")


def test_measured_plateau_equals_the_exact_value_of_the_final_policy():
    """With epsilon decayed to its floor, the last window's success rate is the DP value of the final policy."""
    exploration = {"name": "exponential_decay", "epsilon_min": 0.05, "rate": 0.01}
    result = train("q_learning", "r4", runs=600, iterations=3000, seed=13, epsilon=0.3, exploration=exploration)
    exact = analysis.exact_success_probability(None, 0.3, 500, **analysis.final_behaviour(result))
    constant = analysis.exact_success_probability(analysis.greedy_policy(result.q), 0.3, 500)
    assert exact.mean() > constant.mean() + 0.1  # the final policy explores far less than epsilon = 0.3
    plateau = metrics.summarize(result).success_plateau
    episodes = (result.episode_end[:, -1000:] != 0).sum()
    standard_error = math.sqrt(exact.mean() * (1 - exact.mean()) / episodes)
    assert abs(plateau - exact.mean()) < 4 * standard_error + 1e-3

