"""The expected-average-reward DP against a hand-computed chain, a Monte-Carlo estimate and analysis.py."""

import re

import numba
import numpy as np
import pytest

from tableclean_suite import analysis, asymptotes
from tableclean_suite.learners import TransitionTable, train
from tableclean_suite.rewards import get_reward_pattern
from tableclean_suite.task import Outcome, TaskModel

MODEL = TaskModel()


def _chain(pattern="r4"):
    return asymptotes.EpisodeChain.build(MODEL, pattern)


def test_hand_computed_two_state_chain():
    # pairs 0 -> 1 -> terminal; from pair 0: action 0 goes on (reward 0.5), action 1 is improper and stays (-1);
    # from pair 1 every action ends the episode (reward 1).  pi(action 0 | pair 0) = p.
    p = 0.75
    chain = asymptotes.EpisodeChain(
        pair_state=np.array([0, 1]), next_pair=np.array([[[1], [0]], [[-1], [-1]]]),
        probability=np.ones((2, 2, 1)),
        outcome=np.array([[[int(Outcome.ROUTINE)], [int(Outcome.IMPROPER)]], [[int(Outcome.TERMINAL)]] * 2]),
        reward=np.array([[[0.5], [-1.0]], [[1.0], [1.0]]]), start_pairs=np.array([0]))
    pi = np.array([[p, 1 - p], [0.5, 0.5]])
    # k improper steps first (probability (1-p)^k p), then length k + 2, return 1.5 - k
    k = np.arange(400)
    weights = (1 - p) ** k * p
    expected_ratio = float((weights * (1.5 - k) / (k + 2)).sum())
    stats = asymptotes.episode_statistics(pi, chain, max_itr=500)
    assert stats.terminal == pytest.approx(1.0)
    assert stats.success == pytest.approx(p)  # only k = 0 has no improper action
    assert stats.average_reward == pytest.approx(expected_ratio, rel=1e-10)
    assert stats.length == pytest.approx(float((weights * (k + 2)).sum()))
    truncated = asymptotes.episode_statistics(pi, chain, max_itr=2)  # k >= 1 is cut at 2 steps
    assert truncated.terminal == pytest.approx(p)
    assert truncated.average_reward == pytest.approx(p * 1.5 / 2 + (1 - p) * p * (-0.5) / 2 + (1 - p) ** 2 * -1.0)


def _monte_carlo(policy, pattern, epsilon, episodes, seed=0):
    rng, table = np.random.default_rng(seed), TransitionTable.from_model(MODEL)
    starts = [s.index for s in MODEL.start_states()]
    ratios, successes = [], []
    for _ in range(episodes):
        state, previous, total, length, clean = starts[rng.integers(len(starts))], -1, 0.0, 0, True
        while True:
            action = policy[state] if rng.random() >= epsilon else rng.integers(MODEL.n_actions)
            nxt, outcome = int(table.next_state[state, action, 0]), int(table.outcome[state, action, 0])
            total += pattern.reward(outcome, state, nxt, previous)
            length += 1
            clean &= outcome != Outcome.IMPROPER
            if outcome == Outcome.TERMINAL or length >= 500:
                break
            previous, state = state, nxt
        ratios.append(total / length)
        successes.append(clean and outcome == Outcome.TERMINAL)
    return np.mean(ratios), np.std(ratios) / np.sqrt(episodes), np.mean(successes)


@pytest.mark.parametrize("reward", ["r1", "r4"])
def test_average_reward_matches_monte_carlo_with_the_looping_penalty(reward):
    q = train("q_learning", reward, runs=1, iterations=2000, seed=3, task=MODEL).q
    stats = asymptotes.greedy_asymptotes(q, 0.2, _chain(reward), 500)
    mean, error, success = _monte_carlo(analysis.greedy_policy(q[0]), get_reward_pattern(reward), 0.2, 6000)
    assert abs(stats.average_reward[0] - mean) < 4 * error
    assert abs(stats.success[0] - success) < 4 * np.sqrt(0.25 / 6000)


def test_looping_penalty_changes_the_average_reward():
    # r3 and r4 differ only by the looping penalty: with exploration some steps loop, so r4 is lower
    q = np.zeros((1, MODEL.n_states, MODEL.n_actions))
    r3 = asymptotes.greedy_asymptotes(q, 0.5, _chain("r3"), 500).average_reward[0]
    r4 = asymptotes.greedy_asymptotes(q, 0.5, _chain("r4"), 500).average_reward[0]
    assert r4 < r3 - 1e-3


def test_success_equals_analysis_exact_success_probability():
    q = train("sarsa", "r2", runs=30, iterations=1500, seed=2, task=MODEL).q
    stats = asymptotes.greedy_asymptotes(q, 0.1, _chain("r2"), 500)
    exact = analysis.exact_success_probability(analysis.greedy_policy(q), 0.1, 500, MODEL)
    np.testing.assert_allclose(stats.success, exact, atol=1e-9)
    assert stats.success.shape == (30,) and (stats.terminal >= stats.success - 1e-12).all()


@numba.njit
def _one_policy(pi, pair_state, next_pair, probability, outcome, reward, start_pairs, max_itr, tolerance):
    """The plain forward DP of one policy ``pi`` ``(S, A)``, skipping zero masses: the reference the
    lockstep kernel must reproduce bit for bit.  Returns ``(success, terminal, E[R/L], E[L])``."""
    n_pairs = pair_state.shape[0]
    n_actions, n_successors = probability.shape[1], probability.shape[2]
    mass = np.zeros((2, n_pairs))  # [clean flag, pair]: P(inside the episode here), 1 = no improper yet
    gain = np.zeros((2, n_pairs))  # E[return so far ; inside the episode here]
    for i in range(start_pairs.shape[0]):
        mass[1, start_pairs[i]] += 1.0 / start_pairs.shape[0]
    success = terminal = ratio = length = 0.0
    for step in range(1, max_itr + 1):
        new_mass = np.zeros((2, n_pairs))
        new_gain = np.zeros((2, n_pairs))
        last = step == max_itr
        inside = 0.0
        for clean in range(2):
            for n in range(n_pairs):
                m = mass[clean, n]
                if m == 0.0:
                    continue
                g = gain[clean, n]
                s = pair_state[n]
                for a in range(n_actions):
                    w = pi[s, a]
                    if w == 0.0:
                        continue
                    for k in range(n_successors):
                        q = probability[s, a, k]
                        if q == 0.0:
                            continue
                        step_mass = m * w * q
                        step_gain = g * w * q + step_mass * reward[n, a, k]
                        still_clean = clean if outcome[s, a, k] != _IMPROPER else 0
                        if outcome[s, a, k] == _TERMINAL:
                            terminal += step_mass
                            if still_clean == 1:
                                success += step_mass
                            ratio += step_gain / step
                            length += step_mass * step
                        elif last:
                            ratio += step_gain / step
                            length += step_mass * step
                        else:
                            target = next_pair[s, a, k]
                            new_mass[still_clean, target] += step_mass
                            new_gain[still_clean, target] += step_gain
                            inside += step_mass
        mass = new_mass
        gain = new_gain
        if inside < tolerance:
            break
    return success, terminal, ratio, length


_TERMINAL, _IMPROPER = int(Outcome.TERMINAL), int(Outcome.IMPROPER)


@pytest.mark.parametrize("pattern", ["r1", "r4"])
@pytest.mark.parametrize("max_itr", [3, 40, 500])
def test_lockstep_dp_equals_the_per_policy_dp_bit_for_bit(pattern, max_itr):
    """The policies-in-lockstep kernel against the plain per-policy DP it replaced (exact equality):
    random, deterministic (probability-0 actions) and epsilon-greedy policies, so that policies
    retire at different steps, out of order, and some only at ``max_itr``."""
    chain = _chain(pattern)
    rng = np.random.default_rng(7)
    n_states, n_actions = chain.probability.shape[:2]
    random_policies = rng.dirichlet(np.ones(n_actions), size=(5, n_states))
    greedy = rng.integers(n_actions, size=(12, n_states))
    pi = np.concatenate([random_policies, analysis.action_probabilities(greedy, 0.0, n_actions),
                         analysis.action_probabilities(greedy, 0.1, n_actions)])
    expected = np.array([_one_policy(policy, chain.pair_state, chain.next_pair, chain.probability, chain.outcome,
                                     chain.reward, chain.start_pairs, max_itr, asymptotes.MASS_TOLERANCE)
                         for policy in pi])
    stats = asymptotes.episode_statistics(pi, chain, max_itr)
    actual = np.stack([stats.success, stats.terminal, stats.average_reward, stats.length], axis=1)
    assert np.array_equal(actual.view(np.int64), expected.view(np.int64))
    single = asymptotes.episode_statistics(pi[-1], chain, max_itr)
    assert single.average_reward.tobytes() == expected[-1, asymptotes.AVERAGE_REWARD].tobytes()


def test_final_run_facts_greedy_success_and_never_terminal():
    """Greedy success is the epsilon = 0 success (1 for a run that learned the plan, 0 for a fresh
    Q-table whose greedy action loops); never-terminal marks the runs with no terminal outcome."""
    chain = _chain("r3")
    learned = train("q_learning", reward="r3", runs=3, iterations=3000, seed=1, gamma=0.9, task=MODEL)
    facts = analysis.final_run_facts(learned, chain, 500, MODEL)
    assert set(facts) == {"success", "average_reward", "terminal", "greedy_success", "never_terminal"}
    exact = analysis.exact_success_probability(analysis.greedy_policy(learned.q), 0.0, 500, model=MODEL)
    np.testing.assert_allclose(facts["greedy_success"], exact, atol=1e-9)
    fresh = train("q_learning", reward="r3", runs=2, iterations=1, seed=1, task=MODEL)
    np.testing.assert_array_equal(analysis.never_terminal(fresh), [1.0, 1.0])
    episodes = learned.episodes()
    reached = episodes.groupby("run")["reached_terminal"].any().reindex(range(3), fill_value=False)
    np.testing.assert_array_equal(facts["never_terminal"], (~reached.to_numpy()).astype(float))
    assert facts["never_terminal"].sum() == 1  # seed 1: one run of three never finishes (the check is not vacuous)
    zero = analysis.final_run_facts(fresh, chain, 500, MODEL)["greedy_success"]
    np.testing.assert_array_equal(zero, [0.0, 0.0])  # ties go to the first action, which never finishes


def test_a_longer_looping_memory_leaves_the_average_reward_unknown_and_the_success_exact():
    q = train("q_learning", reward="r4", runs=2, iterations=800, seed=2, task=MODEL).q
    paper, cycle = (asymptotes.greedy_asymptotes(q, 0.1, _chain(name), 500) for name in ("r4", "r4_cycle"))
    np.testing.assert_allclose(paper.success, cycle.success, rtol=1e-12)  # pair chain vs state chain
    np.testing.assert_allclose(paper.length, cycle.length, rtol=1e-12)
    assert np.isnan(cycle.average_reward).all() and np.isfinite(paper.average_reward).all()


def _bellman_by_hand(model, pattern, q, gamma, epsilon=None):
    """max |Q - T Q| over reachable non-terminal states, T written out with model.step (no chain)."""
    reward = get_reward_pattern(pattern)
    worst = 0.0
    for state in model.reachable_states():
        if state.is_terminal:
            continue
        for action in range(model.n_actions):
            nxt, outcome = model.step(state, action)
            target = reward.reward(outcome, state.index, nxt.index)
            if outcome != Outcome.TERMINAL:
                row = q[nxt.index]
                if epsilon is None:
                    target += gamma * row.max()
                else:
                    pi = np.full(len(row), epsilon / len(row))
                    pi[np.argmax(row)] += 1 - epsilon
                    target += gamma * float(pi @ row)
            worst = max(worst, abs(q[state.index, action] - target))
    return worst


@pytest.mark.parametrize("pattern", ["r1", "r3"])
def test_fixed_points_satisfy_their_bellman_equations(pattern):
    chain = _chain(pattern)
    assert np.array_equal(chain.pair_state, np.unique(chain.pair_state))  # no looping penalty: a pair is a state
    for gamma, epsilon in ((0.3, None), (0.9, None), (0.3, 0.1), (0.9, 0.1)):
        q = np.zeros((MODEL.n_states, MODEL.n_actions))
        q[chain.pair_state] = analysis.fixed_point_q(chain, gamma, epsilon)
        assert _bellman_by_hand(MODEL, pattern, q, gamma, epsilon) < 1e-10


def test_q_star_is_the_optimal_plan_and_sarsa_fails_only_at_gamma_0_3():
    """The mechanism the findings page states: r3's Q* greedy is the optimal plan (no looping
    optimum at gamma 0.3); SARSA's on-policy fixed point fails at gamma 0.3 and is optimal at 0.9."""
    reachable = [s.index for s in MODEL.reachable_states() if not s.is_terminal]
    optimal = analysis.exact_success_probability(
        analysis.state_policy(_chain("r3"), analysis.fixed_point_q(_chain("r3"), 0.9), MODEL.n_states), 0.1, 500,
        model=MODEL)
    for pattern, gamma, epsilon, solved in (("r3", 0.3, None, True), ("r1", 0.3, 0.1, False),
                                            ("r1", 0.9, 0.1, True), ("r3", 0.3, 0.1, False)):
        chain = _chain(pattern)
        policy = analysis.state_policy(chain, analysis.fixed_point_q(chain, gamma, epsilon), MODEL.n_states)
        assert (policy[reachable] >= 0).all()
        greedy = float(analysis.exact_success_probability(np.maximum(policy, 0), 0.0, 500, model=MODEL))
        explored = float(analysis.exact_success_probability(np.maximum(policy, 0), 0.1, 500, model=MODEL))
        assert (greedy == pytest.approx(1.0)) is solved, (pattern, gamma, epsilon)
        assert (explored == pytest.approx(float(optimal))) is solved
    with pytest.raises(ValueError, match="gamma must be in"):
        analysis.fixed_point_q(_chain("r1"), 1.0)
    with pytest.raises(ValueError, match="unknown"):
        analysis.fixed_point_q(_chain("r4_cycle"), 0.3)


def _stacked(stats):
    return np.stack([np.atleast_1d(getattr(stats, name)) for name in asymptotes.QUANTITIES], axis=1)


@pytest.mark.parametrize("pattern", ["r1", "r4", "r4_cycle"])
def test_policy_statistics_equals_the_dp_of_every_policy_bit_for_bit(pattern):
    """Deduplicated and canonicalised off the policies' paths: the numbers of episode_statistics
    on each policy as given (NaN rewards of r4_cycle included)."""
    chain = _chain(pattern)
    rng = np.random.default_rng(11)
    n_states, n_actions = chain.probability.shape[:2]
    greedy = rng.integers(n_actions, size=(20, n_states))
    greedy[10:] = greedy[:10]
    greedy[10:, rng.integers(n_states, size=10)] = rng.integers(n_actions, size=10)  # many differ off their path
    pi = np.concatenate([rng.dirichlet(np.ones(n_actions), size=(4, n_states)),
                         analysis.action_probabilities(greedy, 0.0, n_actions),
                         analysis.action_probabilities(greedy, 0.1, n_actions)])
    expected = _stacked(asymptotes.episode_statistics(pi, chain, 500))
    shared = _stacked(asymptotes.policy_statistics(pi, chain, 500))
    reversed_order = _stacked(asymptotes.policy_statistics(pi[::-1], chain, 500))[::-1]
    assert shared.tobytes() == expected.tobytes() and reversed_order.tobytes() == expected.tobytes()


def test_greedy_policies_that_differ_off_their_path_share_one_dp(monkeypatch):
    computed = []
    dp = asymptotes.episode_statistics
    monkeypatch.setattr(asymptotes, "episode_statistics", lambda pi, *args: computed.append(len(pi)) or dp(pi, *args))
    chain = _chain("r4")
    q = train("q_learning", reward="r4", runs=40, iterations=3000, seed=5, task=MODEL).q
    greedy = asymptotes.greedy_asymptotes(q, 0.0, chain, 500)
    reference = asymptotes.episode_statistics(
        analysis.action_probabilities(analysis.greedy_policy(q), 0.0, MODEL.n_actions), chain, 500)
    assert _stacked(greedy).tobytes() == _stacked(reference).tobytes()
    reached = asymptotes.reached_states(
        analysis.action_probabilities(analysis.greedy_policy(q), 0.0, MODEL.n_actions), chain)
    paths = {tuple(np.where(row, policy, -1)) for row, policy in zip(reached, analysis.greedy_policy(q))}
    assert computed[0] == len(paths) < len(np.unique(analysis.greedy_policy(q), axis=0))  # the sharing is real


def test_reached_states_follow_a_deterministic_policy():
    chain = _chain("r1")
    policy = np.zeros(MODEL.n_states, dtype=np.int64)  # action 0 everywhere
    reached = asymptotes.reached_states(analysis.action_probabilities(policy[None], 0.0, MODEL.n_actions), chain)[0]
    table = TransitionTable.from_model(MODEL)
    expected = set()
    for start in MODEL.start_states():  # walk each start's path by hand
        state = start.index
        while state not in expected:
            expected.add(state)
            if table.outcome[state, 0, 0] == Outcome.TERMINAL:
                break
            state = int(table.next_state[state, 0, 0])
    assert set(np.flatnonzero(reached).tolist()) == expected
    everywhere = asymptotes.reached_states(np.ones((1, MODEL.n_states, MODEL.n_actions)), chain)[0]
    assert set(np.flatnonzero(everywhere).tolist()) == set(chain.pair_state.tolist())


def test_distinct_rows():
    rows = np.array([[1, 2], [3, 4], [1, 2], [0, 0], [3, 4]])
    first, inverse = asymptotes._distinct_rows(rows)
    assert first.tolist() == [0, 1, 3] and inverse.tolist() == [0, 1, 0, 2, 1]
    floats = np.array([[0.0], [-0.0], [0.0]])  # bytes, not values: -0.0 is its own row
    assert asymptotes._distinct_rows(floats)[1].tolist() == [0, 1, 0]


def test_learned_affordances_and_visits_read_the_int8_records_as_int64_ones():
    result = train("learned_affordance_q_learning", runs=6, iterations=800, epsilon=0.5, seed=4, task=MODEL)
    assert result.states.dtype == np.int8  # the records' own type: no int64 copy of them
    wide = [np.asarray(a, dtype=np.int64) for a in (result.states, result.actions, result.outcomes)]
    masks = analysis.learned_affordances(result.states, result.actions, result.outcomes, MODEL.n_states,
                                         MODEL.n_actions)
    assert not masks.all() and np.array_equal(masks, analysis.learned_affordances(*wide, MODEL.n_states,
                                                                                   MODEL.n_actions))
    counts = analysis.visit_counts(result.states, MODEL.n_states)
    assert np.array_equal(counts, analysis.visit_counts(wide[0], MODEL.n_states)) and counts.sum() == 6 * 800


def test_parameter_array_per_distinct_visit_count_is_the_per_entry_one():
    from tableclean_suite.learners.exploration import LinearDecay, VisitDecay

    visits = np.random.default_rng(3).integers(0, 50, size=(7, MODEL.n_states))
    for exploration in (VisitDecay(scale=0.03), LinearDecay(horizon=3000)):
        expected = [[exploration.parameter_at(0.3, 1000, int(n)) for n in row] for row in visits]
        actual = exploration.parameter_array(0.3, 1000, visits)
        assert actual.shape == visits.shape and actual.tobytes() == np.array(expected).tobytes()


@pytest.mark.parametrize("shape", [(2, 5, 3), (24, 8), (1, 2, 24, 8)])
def test_policies_of_the_wrong_shape_are_refused_naming_the_task_shape(shape):
    """The compiled passes index the policies by the chain's states and actions without bounds
    checks: a wrong shape must be an error, not a read past the array."""
    chain = _chain()
    policies = np.full(shape, 0.5)
    states, actions = chain.probability.shape[:2]
    for call in (lambda: asymptotes.reached_states(policies, chain),
                 lambda: asymptotes.policy_statistics(policies, chain, 50)):
        with pytest.raises(ValueError, match=re.escape(f"(P, {states}, {actions}) for this task, got {shape}")):
            call()
    with pytest.raises(ValueError, match="for this task"):  # one policy (S, A) is allowed here, not these
        asymptotes.episode_statistics(policies, chain, 50)
