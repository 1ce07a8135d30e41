"""Simulated asymptotes against the exact DP within their stated Monte Carlo error, their
determinism and independence of batching, and the analysis plan that chooses between them."""

import math

import numpy as np
import pytest

from tableclean_suite import analysis, asymptotes, resources, simulation
from tableclean_suite.bench import statistics
from tableclean_suite.learners import TransitionTable, train
from tableclean_suite.task import Outcome, TaskModel, TaskSpec

PAPER = TaskModel()
#: |simulated - exact| / standard error above which a test fails: with a few hundred comparisons
#: per run of the file, a false failure has a probability of about 1e-3 (normal tails).
Z_LIMIT = 4.5
FIELDS = ("success", "terminal", "average_reward", "length")


def _stochastic_table(model: TaskModel) -> TransitionTable:
    """The model's table with every MOVE failing (arm stays, ineffective) one time in five: K = 2
    successors, so the simulation's successor draws are exercised."""
    table = TransitionTable.from_model(model)
    move = list(model.spec.actions).index("move")
    next_state = np.repeat(table.next_state, 2, axis=2)
    outcome = np.repeat(table.outcome, 2, axis=2)
    cumulative = np.ones(next_state.shape)
    states = np.arange(model.n_states)
    moving = table.outcome[:, move, 0] != int(Outcome.TERMINAL)
    next_state[moving, move, 1] = states[moving]
    outcome[moving, move, 1] = int(Outcome.INEFFECTIVE)
    cumulative[moving, move, 0] = 0.8
    return TransitionTable(next_state, outcome, cumulative, "test", spec=model.spec)


def _z_scores(exact: asymptotes.Asymptotes, simulated: asymptotes.Asymptotes, episodes: int,
              max_itr: int) -> np.ndarray:
    """``(fields, P)`` standardised differences.  Where every episode gave the same value (standard
    error 0) an event of probability p was missed with probability (1 - p) ** episodes, so the
    difference may be up to about 7 / episodes times the quantity's range (rule of three at
    99.9 %): the error is floored at a sixth of that."""
    scale = {"success": 1.0, "terminal": 1.0, "average_reward": 2.0, "length": float(max_itr)}
    scores = []
    for name in FIELDS:
        difference = np.asarray(getattr(simulated, name)) - np.asarray(getattr(exact, name))
        floor = 7.0 / episodes * scale[name] / Z_LIMIT
        scores.append(difference / np.maximum(np.asarray(getattr(simulated.error, name)), floor))
    return np.array(scores)


CASES = [
    ("paper r1", PAPER, "r1", None),
    ("paper r4", PAPER, "r4", None),
    ("three segments r3, uniform starts", TaskModel(spec=TaskSpec("sim_uniform", segments=3, objects=("box",),
                                                                  start="uniform_unclean")), "r3", None),
    ("paper r4, stochastic moves", PAPER, "r4", "stochastic"),
]


@pytest.mark.parametrize("name, model, reward, table", CASES, ids=[case[0] for case in CASES])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_simulated_agrees_with_exact_within_its_stated_error(name, model, reward, table, seed):
    """Several seeds and specs: every quantity of every run within Z_LIMIT standard errors of the
    exact DP, and the stated error of success is the binomial one of the exact probability (so
    the error is neither understated nor inflated to pass)."""
    table = _stochastic_table(model) if table == "stochastic" else None
    result = train(runs=6, iterations=1500, reward=reward, task=model, seed=seed,
                   **({"backend": "calibrated", "transitions": table} if table is not None else {}))
    episodes = 4000
    exact_chain = asymptotes.EpisodeChain.build(model, reward, table)
    steps = simulation.StepTable.build(model, reward, table, episodes=episodes)
    exact = analysis.final_asymptotes(result, exact_chain, 200, model)
    simulated = analysis.final_asymptotes(result, steps, 200, model)
    assert np.all(np.abs(_z_scores(exact, simulated, episodes, 200)) < Z_LIMIT)
    binomial = np.sqrt(exact.success * (1 - exact.success) / episodes)
    np.testing.assert_allclose(simulated.error.success, binomial, rtol=0.15, atol=1e-3)


def test_simulated_mean_over_runs_within_the_combined_monte_carlo_error():
    """The cell-level statement: the mean over runs of the simulated success is within Z_LIMIT
    combined errors ([analysis.monte_carlo_error]) of the exact mean, on 40 runs of r4."""
    result = train(runs=40, iterations=1000, reward="r4", seed=5)
    exact = analysis.final_run_facts(result, analysis.analysis_chain(PAPER, "r4"), 500, PAPER)
    plan = analysis.analysis_plan(PAPER, "r4", 40, 500, 1.0, "simulated", episodes=500)
    simulated = analysis.final_run_facts(result, analysis.analysis_chain(PAPER, "r4", plan=plan), 500, PAPER)
    for name in analysis.ESTIMATED_FACTS:
        error = analysis.monte_carlo_error(simulated[name + analysis.ERROR_SUFFIX])
        difference = abs(simulated[name].mean() - exact[name].mean())
        assert difference <= Z_LIMIT * error or (error == 0 and difference < 1e-9), name
    assert not any(key.endswith(analysis.ERROR_SUFFIX) for key in exact)  # exact facts carry no error
    np.testing.assert_array_equal(simulated["never_terminal"], exact["never_terminal"])


def test_simulation_is_deterministic_and_independent_of_batching():
    """The same runs trained in one chunk or in three give bit-identical simulated facts; a second
    call repeats them; another seed changes them."""
    steps = simulation.StepTable.build(PAPER, "r4", episodes=300)
    whole = train(runs=6, iterations=600, reward="r4", seed=3)
    parts = [train(runs=2, first_run=first, iterations=600, reward="r4", seed=3) for first in (0, 2, 4)]
    facts = analysis.final_run_facts(whole, steps, 500, PAPER)
    again = analysis.final_run_facts(whole, steps, 500, PAPER)
    pieces = [analysis.final_run_facts(part, steps, 500, PAPER) for part in parts]
    for name, values in facts.items():
        assert values.tobytes() == again[name].tobytes()
        assert values.tobytes() == np.concatenate([piece[name] for piece in pieces]).tobytes(), name
    other = analysis.final_run_facts(train(runs=6, iterations=600, reward="r4", seed=4), steps, 500, PAPER)
    assert not np.array_equal(other["success"], facts["success"])


def test_greedy_path_equals_the_probability_path_bit_for_bit():
    """Epsilon-greedy read off the Q-tables in the visited states only gives the same bits as the
    full ``(P, S, A)`` probabilities (ties to the first action included: untrained Q-tables)."""
    steps = simulation.StepTable.build(PAPER, "r4", episodes=200)
    q = np.concatenate([train(runs=3, iterations=700, reward="r4").q, np.zeros((1, PAPER.n_states, PAPER.n_actions))])
    keys = simulation.simulation_keys(0, 0, len(q))
    for epsilon in (0.0, 0.1, 1.0):
        lazy = simulation.simulated_greedy_statistics(q, epsilon, steps, 500, keys)
        full = simulation.simulated_statistics(analysis.action_probabilities(analysis.greedy_policy(q), epsilon,
                                                                             PAPER.n_actions), steps, 500, keys)
        for name in FIELDS:
            assert getattr(lazy, name).tobytes() == getattr(full, name).tobytes()
            assert getattr(lazy.error, name).tobytes() == getattr(full.error, name).tobytes()


def test_a_longer_looping_memory_gets_an_estimated_average_reward():
    """``r4_cycle``: the DP cannot say its average reward (NaN); the simulation estimates it, and it
    is at most r4's (the longer memory penalises more returns) while success and length agree."""
    result = train(runs=4, iterations=800, reward="r4")
    exact = analysis.final_asymptotes(result, asymptotes.EpisodeChain.build(PAPER, "r4_cycle"), 500, PAPER)
    cycle = analysis.final_asymptotes(result, simulation.StepTable.build(PAPER, "r4_cycle", episodes=1000), 500, PAPER)
    paper = analysis.final_asymptotes(result, simulation.StepTable.build(PAPER, "r4", episodes=1000), 500, PAPER)
    assert np.isnan(exact.average_reward).all() and np.isfinite(cycle.average_reward).all()
    assert (cycle.average_reward <= paper.average_reward).all()
    assert np.all(np.abs(_z_scores(exact, cycle, 1000, 500)[[0, 1, 3]]) < Z_LIMIT)


def test_assisted_learners_are_simulated_from_their_final_probabilities():
    """An affordance learner's behaviour (restricted to afforded actions) through the general path."""
    result = train("affordance_q_learning", runs=3, iterations=800)
    exact = analysis.final_asymptotes(result, asymptotes.EpisodeChain.build(PAPER, "r4"), 500, PAPER)
    simulated = analysis.final_asymptotes(result, simulation.StepTable.build(PAPER, "r4", episodes=3000), 500, PAPER)
    assert np.all(np.abs(_z_scores(exact, simulated, 3000, 500)) < Z_LIMIT)


def test_bad_arguments_are_refused_with_the_value_named():
    steps = simulation.StepTable.build(PAPER, "r1", episodes=10)
    q = np.zeros((2, PAPER.n_states, PAPER.n_actions))
    keys = simulation.simulation_keys(0, 0, 2)
    with pytest.raises(ValueError, match=r"\(P, 24, 4\).*\(2, 5, 4\)"):
        simulation.simulated_greedy_statistics(q[:, :5], 0.1, steps, 10, keys)
    with pytest.raises(ValueError, match=r"keys must have shape \(2,\)"):
        simulation.simulated_greedy_statistics(q, 0.1, steps, 10, keys[:1])
    with pytest.raises(ValueError, match="max_itr must be an integer >= 1, got 0"):
        simulation.simulated_greedy_statistics(q, 0.1, steps, 0, keys)
    with pytest.raises(ValueError, match="epsilon must be in"):
        simulation.simulated_greedy_statistics(q, 1.5, steps, 10, keys)
    with pytest.raises(ValueError, match="episodes must be an integer >= 2, got 1"):
        simulation.StepTable.build(PAPER, "r1", episodes=1)
    with pytest.raises(ValueError, match=r"max_itr must be an integer >= 1, got 10\.0"):  # a count, not a float
        simulation.simulated_greedy_statistics(q, 0.1, steps, 10.0, keys)
    with pytest.raises(ValueError, match="analysis must be one of auto, exact, simulated, got 'fast'"):
        analysis.analysis_plan(PAPER, "r1", 10, 500, 1.0, "fast")


def test_auto_keeps_exact_on_the_paper_and_simulates_a_large_spec():
    """The paper's default cells (1000 runs x 4000 iterations, settling checkpoint) stay exact; an
    11-segment, 2-object spec's 20 runs x 300 iterations are simulated (the exact estimate is
    hours); either kind can be forced; the estimates grow with what they count."""
    for reward in ("r1", "r2", "r3", "r4", "r4_cycle"):
        training = resources.training_seconds(1000, 4000, PAPER.n_states, PAPER.n_actions)
        plan = analysis.analysis_plan(PAPER, reward, 1000, 500, training, runs_per_call=1000, checkpoint=True)
        assert plan.kind == "exact" and plan.label == "exact" and plan.episodes == 0
    large = TaskModel(spec=TaskSpec("sim_large", segments=11, objects=("box", "box")))
    training = resources.training_seconds(20, 300, large.n_states, large.n_actions)
    plan = analysis.analysis_plan(large, "r1", 20, 500, training, runs_per_call=1, checkpoint=True)
    assert plan.kind == "simulated" and plan.label == "simulated (1000 episodes per run)"
    assert plan.exact_seconds > 3600 > plan.simulated_seconds
    assert plan.exact_seconds > analysis.EXACT_COST_FACTOR * plan.training_seconds
    assert plan.describe().startswith("asymptotes simulated (1000 episodes per run): about ")
    assert "where exact ones would take about " in plan.describe()
    forced = analysis.analysis_plan(large, "r1", 20, 500, training, "exact")
    assert forced.bytes == large.n_states * large.n_actions * asymptotes.EXACT_BYTES_PER_ENTRY
    assert plan.bytes == simulation.simulation_bytes(large.n_states, large.n_actions, 1) < forced.bytes / 10
    assert forced.kind == "exact"
    assert analysis.analysis_plan(PAPER, "r1", 10, 500, 1.0, "simulated", episodes=50).label == \
        "simulated (50 episodes per run)"
    # the threshold: just above both bounds simulates, just below either keeps the exact DP
    exact = analysis.analysis_plan(large, "r1", 20, 500, training).exact_seconds
    assert analysis.analysis_plan(large, "r1", 20, 500, exact / analysis.EXACT_COST_FACTOR * 1.01).kind == "exact"
    assert analysis.analysis_plan(large, "r1", 20, 500, exact / analysis.EXACT_COST_FACTOR * 0.99).kind == "simulated"
    assert asymptotes.exact_seconds(100, 4, 500, 10) < asymptotes.exact_seconds(100, 4, 1000, 10)
    assert asymptotes.exact_seconds(100, 4, 500, 10, looping=False) < asymptotes.exact_seconds(100, 4, 500, 10)
    assert simulation.simulation_seconds(100, 4, 10, 500, 3) == pytest.approx(
        3 * simulation.simulation_seconds(100, 4, 10, 500))


def test_analysis_chain_follows_the_plan():
    simulated = analysis.analysis_plan(PAPER, "r2", 10, 500, 1.0, "simulated", episodes=77)
    steps = analysis.analysis_chain(PAPER, "r2", plan=simulated)
    assert isinstance(steps, simulation.StepTable) and steps.episodes == simulated.episodes == 77
    assert isinstance(analysis.analysis_chain(PAPER, "r2"), asymptotes.EpisodeChain)
    exact = analysis.analysis_plan(PAPER, "r2", 10, 500, 1.0, "exact")
    assert isinstance(analysis.analysis_chain(PAPER, "r2", plan=exact), asymptotes.EpisodeChain)


def test_monte_carlo_error_widens_the_interval_in_quadrature():
    assert analysis.monte_carlo_error([0.3, 0.4]) == pytest.approx(0.25)  # sqrt(0.09 + 0.16) / 2
    z = 1.959963984540054
    low, high = statistics.with_monte_carlo_error(0.5, 0.4, 0.7, 0.05, 0.95)
    assert low == pytest.approx(0.5 - math.hypot(0.1, z * 0.05))
    assert high == pytest.approx(0.5 + math.hypot(0.2, z * 0.05))
    assert low < 0.4 and high > 0.7
    assert statistics.with_monte_carlo_error(0.5, 0.4, 0.7, 0.0, 0.95) == (0.4, 0.7)  # exact: unchanged
    assert all(math.isnan(v) for v in statistics.with_monte_carlo_error(0.5, 0.4, 0.7, math.nan, 0.95))
    clipped = statistics.with_monte_carlo_error(0.0, 0.0, 0.0002, 0.001, 0.95, statistics.FACT_LIMITS["terminal"])
    assert clipped[0] == 0.0 and clipped[1] == pytest.approx(math.hypot(0.0002, z * 0.001))
    point = 0.5  # an interval of zero width still gets the Monte Carlo part
    assert statistics.with_monte_carlo_error(point, point, point, 0.01, 0.95) == pytest.approx(
        (point - z * 0.01, point + z * 0.01))


def test_cell_plan_counts_every_update_of_the_learner():
    """A harness cell's plan costs its learner's training: Dyna-Q's planning updates and double
    Q-learning's second table make it dearer, so auto keeps the exact DP longer for them."""
    from tableclean_suite.learners import get_learner

    large = TaskModel(spec=TaskSpec("sim_plan", segments=6, objects=("box", "box")))
    plans = {name: analysis.cell_plan(large, "r1", get_learner(name), 50, 100_000, 500, runs_per_call=50)
             for name in ("q_learning", "double_q_learning", "dyna_q")}
    planning = get_learner("dyna_q").planning_steps
    assert plans["dyna_q"].training_seconds == pytest.approx(resources.training_seconds(
        50, 100_000, large.n_states, large.n_actions, planning_steps=planning))
    assert plans["q_learning"].training_seconds < plans["double_q_learning"].training_seconds
    assert plans["q_learning"].training_seconds < plans["dyna_q"].training_seconds
    assert plans["q_learning"].exact_seconds == plans["dyna_q"].exact_seconds


def _afforded_epsilon_greedy_oracle(q, masks, epsilon):
    """Epsilon-greedy over afforded actions in plain numpy (the compiled pass's reference)."""
    masks = np.broadcast_to(masks, q.shape)
    masks = masks | ~masks.any(axis=-1, keepdims=True)
    rate = np.broadcast_to(np.asarray(epsilon, dtype=np.float64), q.shape[:2])[..., None]
    probabilities = masks * (rate / masks.sum(axis=-1, keepdims=True))
    greedy = np.argmax(np.where(masks, q, -np.inf), axis=-1)[..., None]
    np.put_along_axis(probabilities, greedy, np.take_along_axis(probabilities, greedy, axis=-1) + (1.0 - rate),
                      axis=-1)
    return probabilities


@pytest.mark.parametrize("trial", range(6))
def test_afforded_epsilon_greedy_is_the_numpy_definition_bit_for_bit(trial):
    """Ties to the first afforded action, all-blocked rows open to every action, per-state epsilon."""
    rng = np.random.default_rng(trial)
    runs, states, actions = 3, 40, 5
    q = np.round(rng.normal(size=(runs, states, actions)), 1)  # ties
    masks = rng.random((runs, states, actions) if trial % 2 else (states, actions)) < 0.4
    epsilon = rng.random((runs, states)) if trial % 3 else 0.1
    np.testing.assert_array_equal(analysis.afforded_probabilities(q, masks, epsilon),
                                  _afforded_epsilon_greedy_oracle(q, masks, epsilon))
