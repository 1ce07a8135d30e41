"""Exact analysis of policies on the task: success probabilities by dynamic programming.

The policy evaluated is a run's *final* behaviour ([`final_probabilities`][tableclean_suite.analysis.final_probabilities]):
the exploration's distribution at the training's last iteration on the final Q-table, restricted
to afforded actions and mixed with the advisor for Cruz et al.'s learners.
[analysis_plan][tableclean_suite.analysis.analysis_plan] costs the exact DP and the Monte Carlo
estimate before any work and chooses; [analysis_chain][tableclean_suite.analysis.analysis_chain]
builds an [EpisodeChain][tableclean_suite.asymptotes.EpisodeChain] (exact) or a
[StepTable][tableclean_suite.simulation.StepTable] (simulated, whose standard errors
[with_monte_carlo_error][tableclean_suite.bench.statistics.with_monte_carlo_error] adds to an interval).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from tableclean_suite import asymptotes, simulation
from tableclean_suite.asymptotes import action_probabilities, greedy_policy  # noqa: F401  (re-exported)
from tableclean_suite.executors.base import check_count
from tableclean_suite.learners.assist import NO_ADVICE, advisor_policy, given_affordances
from tableclean_suite.learners.exploration import EpsilonGreedy, VisitDecay, as_exploration, softmax_probabilities
from tableclean_suite.learners.transitions import TransitionTable
from tableclean_suite.task import Outcome, TaskModel


def visit_counts(states: np.ndarray, n_states: int) -> np.ndarray:
    """Iterations spent in each state: ``(R, T)`` recorded states -> ``(R, n_states)`` int64."""
    states = _integers(states)
    counts = np.zeros((states.shape[0], n_states), dtype=np.int64)
    for run, row in enumerate(states):
        counts[run] = np.bincount(row, minlength=n_states)
    return counts


def _integers(records) -> np.ndarray:
    """``(R, T)`` records as an integer array, in their own integer type (the records are int8: no
    int64 copy of the whole window)."""
    records = np.atleast_2d(np.asarray(records))
    return records if np.issubdtype(records.dtype, np.integer) else records.astype(np.int64)


def final_behaviour(result) -> dict:
    """The keyword arguments of [`exact_success_probability`][tableclean_suite.analysis.exact_success_probability]
    describing a [`TrainingResult`][tableclean_suite.learners.train.TrainingResult]'s final behaviour:
    ``exploration``, ``q`` (final Q-tables), ``iteration`` (its iterations), ``visits`` ``(R, S)``."""
    settings = result.config.get("learner_settings", {})
    return {
        "exploration": as_exploration(settings.get("exploration")),
        "q": result.q,
        "iteration": result.iterations,
        "visits": visit_counts(result.states, result.q.shape[-2]),
    }


def behaviour_probabilities(policy, epsilon, n_actions, exploration=None, q=None, iteration=None, visits=None):
    """The action distribution ``(R, S, A)`` evaluated by [`exact_success_probability`][tableclean_suite.analysis.exact_success_probability] (see there)."""
    exploration = as_exploration(exploration)
    if q is not None:
        q = _runs_q(q)
        if policy is None:
            policy = greedy_policy(q)
    if policy is None and not exploration.softmax:
        raise ValueError("give the greedy policy (policy=) or the Q-tables (q=)")
    if isinstance(exploration, EpsilonGreedy):
        return action_probabilities(np.atleast_2d(policy), epsilon, n_actions)
    exploration.check(float(epsilon))
    if iteration is None and not isinstance(exploration, VisitDecay):
        raise ValueError(f"exploration {exploration.name!r} needs iteration= (the iteration whose parameter to use, "
                         "e.g. the training's iterations)")
    if exploration.softmax:
        if q is None:
            raise ValueError("exploration 'softmax' needs the final Q-tables (q=): its policy is their softmax")
        return softmax_probabilities(q, exploration.parameter_at(float(epsilon), iteration))
    if isinstance(exploration, VisitDecay) and visits is None:
        raise ValueError("exploration 'visit_decay' needs visits= (per state, e.g. visit_counts(result.states, S))")
    policy = np.atleast_2d(policy)
    counts = np.zeros(policy.shape) if visits is None else np.broadcast_to(np.atleast_2d(visits), policy.shape)
    parameter = exploration.parameter_array(float(epsilon), iteration or 0, counts)
    return action_probabilities(policy, parameter, n_actions)


def exact_success_probability(
    policy: np.ndarray | None,
    epsilon: float,
    max_itr: int,
    model: TaskModel | None = None,
    table: TransitionTable | None = None,
    exploration=None,
    q: np.ndarray | None = None,
    iteration: int | None = None,
    visits: np.ndarray | None = None,
) -> np.ndarray:
    """Probability that an episode succeeds (terminal within ``max_itr`` steps, no improper action):
    the ``success`` of [`asymptotes.episode_statistics`][tableclean_suite.asymptotes.episode_statistics]
    (exact to ``asymptotes.MASS_TOLERANCE``), episodes starting uniformly in the
    model's start states.

    Args:
        policy: greedy action per state, shape ``(S,)`` or ``(R, S)`` for R policies (S = ``model.n_states``);
            may be ``None`` when ``q`` is given (its greedy actions).
        epsilon: exploration rate in [0, 1] (random actions uniform over the task's actions);
            the start value of an epsilon schedule.
        max_itr: episode length limit (>= 1).
        model: the task model (rules and start states); default ``TaskModel()``.
        table: transitions to use instead of the model's (e.g. calibrated).
        exploration: the behaviour policy (name, [`Exploration`][tableclean_suite.learners.exploration.Exploration]
            or mapping; default constant epsilon-greedy).  Others are evaluated at their final
            distribution (module docstring): schedules at ``iteration``, ``visit_decay`` with
            ``visits``, ``softmax`` on ``q``.
        q: final Q-tables ``(S, A)`` or ``(R, S, A)`` (needed by ``softmax``).
        iteration: iteration (>= 0) whose epsilon / temperature to use, normally the training's
            ``iterations`` (needed by ``linear_decay``, ``exponential_decay``, ``softmax``).
        visits: ``(S,)`` or ``(R, S)`` iterations spent per state over training (``visit_decay``).

    Returns:
        Success probability per policy: shape ``()`` for one policy, ``(R,)`` for R.
    """
    model = model if model is not None else TaskModel()
    single = (policy is not None and np.ndim(policy) == 1) or (policy is None and q is not None and np.ndim(q) == 2)
    pi = behaviour_probabilities(policy, epsilon, model.n_actions, exploration, q, iteration, visits)  # (R, S, A)
    if pi.shape[-2] != model.n_states:
        raise ValueError(f"policy has {pi.shape[-2]} states; task {model.spec.name!r} has {model.n_states}")
    chain = asymptotes.EpisodeChain.build(model, "r1", table)  # success does not depend on the rewards
    success = asymptotes.episode_statistics(pi, chain, max_itr).success
    return success[0] if single else success


# Cruz et al.'s assisted learners: affordances and a simulated advisor
def learned_affordances(states: np.ndarray, actions: np.ndarray, outcomes: np.ndarray, n_states: int,
                        n_actions: int) -> np.ndarray:
    """Per-run affordances learned from ``(R, T)`` records: ``(R, S, A)`` bool, False where the run
    observed the pair improper."""
    states, actions, outcomes = (_integers(a) for a in (states, actions, outcomes))
    masks = np.ones((states.shape[0], n_states, n_actions), dtype=bool)
    runs, steps = np.nonzero(outcomes == int(Outcome.IMPROPER))
    masks[runs, states[runs, steps].astype(np.int64), actions[runs, steps].astype(np.int64)] = False
    return masks


def afforded_probabilities(q: np.ndarray, masks: np.ndarray, parameter, softmax: bool = False) -> np.ndarray:
    """Action probabilities ``(R, S, A)`` of the behaviour policy restricted to afforded actions.

    Args:
        q: ``(R, S, A)`` Q-tables.
        masks: ``(S, A)`` or ``(R, S, A)`` bool, True = afforded; an all-False row allows every action.
        parameter: epsilon in [0, 1] (or the softmax temperature > 0), a number or ``(R, S)``.
        softmax: Boltzmann over the afforded actions instead of epsilon-greedy.

    Epsilon-greedy: the afforded action of largest Q (ties to the first) gets ``1 - epsilon``
    more, every afforded action ``epsilon / n_afforded``.
    """
    q = _runs_q(q)
    if softmax:
        masks = np.broadcast_to(np.asarray(masks, dtype=bool), q.shape)
        masks = masks | ~masks.any(axis=-1, keepdims=True)
        blocked = np.where(masks, q, -np.inf)
        rate = np.broadcast_to(np.asarray(parameter, dtype=np.float64), q.shape[:2])[..., None]
        weights = np.where(masks, np.exp((q - blocked.max(axis=-1, keepdims=True)) / rate), 0.0)
        return weights / weights.sum(axis=-1, keepdims=True)
    epsilon = np.asarray(parameter, dtype=np.float64)
    if not np.all((epsilon >= 0.0) & (epsilon <= 1.0)):
        raise ValueError(f"epsilon must be in [0, 1], got {np.unique(epsilon).tolist()!r}")
    probabilities = np.empty(q.shape)
    _afforded_epsilon_greedy(q, np.broadcast_to(np.asarray(masks, dtype=bool), q.shape),
                             np.broadcast_to(epsilon, q.shape[:2]), probabilities)
    return probabilities


@numba.njit(cache=True)
def _afforded_epsilon_greedy(q, masks, epsilon, probabilities):
    """Fill ``probabilities`` ``(R, S, A)`` as [`afforded_probabilities`][tableclean_suite.analysis.afforded_probabilities]'s
    epsilon-greedy, in one pass without temporaries (every action afforded where none is)."""
    runs, states, actions = q.shape
    for r in range(runs):
        for s in range(states):
            count = 0
            for a in range(actions):
                count += masks[r, s, a]
            every = count == 0
            share = epsilon[r, s] / (actions if every else count)
            best = -1
            for a in range(actions):
                afforded = every or masks[r, s, a]
                probabilities[r, s, a] = share if afforded else 0.0
                if afforded and (best < 0 or q[r, s, a] > q[r, s, best]):
                    best = a
            probabilities[r, s, best] += 1.0 - epsilon[r, s]


def advised_probabilities(probabilities: np.ndarray, advisor: np.ndarray, advice_probability: float,
                          consistency: float) -> np.ndarray:
    """Mix a learner's action probabilities ``(..., S, A)`` with a simulated advisor's.

    Args:
        advisor: ``(S,)`` the advisor's action per state (``NO_ADVICE``: it never advises there).
        advice_probability: L in [0, 1].
        consistency: C in [0, 1].

    Returns ``L * (C * onehot(advisor) + (1 - C) / A) + (1 - L) * probabilities`` where the
    advisor has an action, ``probabilities`` elsewhere.
    """
    for name, value in (("advice_probability", advice_probability), ("consistency", consistency)):
        if not 0.0 <= value <= 1.0:
            raise ValueError(f"{name} must be in [0, 1], got {value!r}")
    probabilities = np.asarray(probabilities, dtype=np.float64)
    advisor = np.asarray(advisor, dtype=np.int64)
    n_actions = probabilities.shape[-1]
    advising = advisor != NO_ADVICE
    own = np.zeros((advisor.shape[0], n_actions))
    own[np.nonzero(advising)[0], advisor[advising]] = 1.0
    advice = consistency * own + (1.0 - consistency) / n_actions
    mixed = advice_probability * advice + (1.0 - advice_probability) * probabilities
    return np.where(advising[:, None], mixed, probabilities)


def final_probabilities(result, model: TaskModel | None = None, masks: np.ndarray | None = None) -> np.ndarray:
    """The final behaviour policy of every run of ``result``, ``(R, S, A)`` (module docstring).

    ``model``: the task model trained on (default ``TaskModel()``); ``masks``: its
    [`affordance_masks`][tableclean_suite.analysis.affordance_masks] if already known.
    """
    model = model if model is not None else TaskModel()
    assist = _assist_options(result.config.get("learner_settings", {}))
    behaviour = final_behaviour(result)
    exploration, q = behaviour["exploration"], behaviour["q"]
    epsilon = float(result.config["epsilon"])
    masks = affordance_masks(result, model) if masks is None else masks
    parameter = exploration.parameter_array(epsilon, behaviour["iteration"], behaviour["visits"])
    probabilities = afforded_probabilities(q, True if masks is None else masks, np.broadcast_to(parameter, q.shape[:2]),
                                           exploration.softmax)  # every action afforded without masks
    if assist.get("advice_probability", 0.0) > 0.0:
        probabilities = advised_probabilities(probabilities, advisor_policy(model), assist["advice_probability"],
                                              assist["advice_consistency"])
    return probabilities


def affordance_masks(result, model: TaskModel) -> np.ndarray | None:
    """The afforded actions ``result``'s learner chooses among: ``(S, A)`` bool for ``given``
    affordances, ``(R, S, A)`` for ``learned`` ones (from each run's records), None without."""
    affordance = _assist_options(result.config.get("learner_settings", {})).get("affordance", "none")
    if affordance == "none":
        return None
    if affordance == "given":
        return given_affordances(model) != 0
    return learned_affordances(result.states, result.actions, result.outcomes, model.n_states, model.n_actions)


def _assist_options(settings: dict) -> dict:
    """The assistance options recorded in ``learner_settings`` (``TabularLearner.settings()``)."""
    return {name: settings[name] for name in ("affordance", "advice_probability", "advice_consistency")
            if name in settings}


def final_asymptotes(result, chain, max_itr: int, model: TaskModel | None = None,
                     masks: np.ndarray | None = None):
    """Exact [`Asymptotes`][tableclean_suite.asymptotes.Asymptotes] (one per run) of ``result``'s final
    behaviour ([`final_probabilities`][tableclean_suite.analysis.final_probabilities]) over an
    `EpisodeChain`, or Monte Carlo estimates (``error`` set) over a
    [StepTable][tableclean_suite.simulation.StepTable]; constant epsilon-greedy without assistance
    goes through [`greedy_asymptotes`][tableclean_suite.asymptotes.greedy_asymptotes].
    """
    settings = result.config.get("learner_settings", {})
    plain = (as_exploration(settings.get("exploration")).name == EpsilonGreedy.name
             and not _assist_options(settings))
    probabilities = None if plain else final_probabilities(result, model, masks)
    return _statistics(result, chain, max_itr, float(result.config["epsilon"]), probabilities)


def _statistics(result, chain, max_itr: int, epsilon: float, probabilities=None):
    """Asymptotes of ``result``'s runs over ``chain``, exact or simulated (a
    [StepTable][tableclean_suite.simulation.StepTable]): of ``probabilities`` ``(R, S, A)``, or
    with None of epsilon-greedy behaviour on the final Q-tables."""
    q = _runs_q(result.q)
    if isinstance(chain, simulation.StepTable):
        keys = simulation.simulation_keys(int(result.config.get("seed", 0)), int(result.config.get("first_run", 0)),
                                          len(q))
        if probabilities is None:
            return simulation.simulated_greedy_statistics(q, epsilon, chain, max_itr, keys)
        return simulation.simulated_statistics(probabilities, chain, max_itr, keys)
    if probabilities is None:
        return asymptotes.greedy_asymptotes(q, epsilon, chain, max_itr)
    return asymptotes.policy_statistics(probabilities, chain, max_itr)


def _runs_q(q) -> np.ndarray:
    """Q-tables ``(S, A)`` or ``(R, S, A)`` as float64 ``(R, S, A)``."""
    q = np.asarray(q, dtype=np.float64)
    return q[None] if q.ndim == 2 else q


def never_terminal(result) -> np.ndarray:
    """``(R,)`` float64, 1.0 for each run that never reached the terminal state in its window
    (so never received the terminal reward), else 0.0."""
    outcomes = np.atleast_2d(np.asarray(result.outcomes))
    return (~(outcomes == int(Outcome.TERMINAL)).any(axis=1)).astype(np.float64)


#: Per-run quantities of [final_run_facts][tableclean_suite.analysis.final_run_facts] that an
#: analysis estimates (the others, e.g. ``never_terminal``, are read off the records).
ESTIMATED_FACTS = ("success", "average_reward", "terminal", "greedy_success")
#: Suffix of a fact's Monte Carlo standard error in [final_run_facts][tableclean_suite.analysis.final_run_facts].
ERROR_SUFFIX = "_error"


def final_run_facts(result, chain, max_itr: int, model: TaskModel | None = None) -> dict[str, np.ndarray]:
    """Per run of ``result``, each quantity behind [`Plateaus`][tableclean_suite.metrics.Plateaus]
    (``metrics.PLATEAU_NAMES``), ``(R,)``: final behaviour's asymptotes, final greedy success and
    [`never_terminal`][tableclean_suite.analysis.never_terminal].  Over a
    [StepTable][tableclean_suite.simulation.StepTable] each of `ESTIMATED_FACTS` adds its per-run
    Monte Carlo standard error as ``<name>_error``."""
    model = model if model is not None else TaskModel()
    masks = affordance_masks(result, model)  # once for both analyses
    final = final_asymptotes(result, chain, max_itr, model, masks)
    # each run's final greedy policy (epsilon 0) over the afforded actions, without the advisor
    greedy = _statistics(result, chain, max_itr, 0.0,
                         None if masks is None else afforded_probabilities(_runs_q(result.q), masks, 0.0))
    facts = {"success": np.atleast_1d(final.success), "average_reward": np.atleast_1d(final.average_reward),
             "terminal": np.atleast_1d(final.terminal), "greedy_success": np.atleast_1d(greedy.success),
             "never_terminal": never_terminal(result)}
    if final.error is not None:
        for name, stats, field in (("success", final, "success"), ("average_reward", final, "average_reward"),
                                   ("terminal", final, "terminal"), ("greedy_success", greedy, "success")):
            facts[name + ERROR_SUFFIX] = np.atleast_1d(getattr(stats.error, field))
    return facts


# Exact or simulated: the analysis's cost, chosen before any work
#: Kinds of analysis [analysis_plan][tableclean_suite.analysis.analysis_plan] accepts.
ANALYSIS_KINDS = ("auto", "exact", "simulated")
#: ``auto`` simulates when the exact analysis's estimate exceeds this many times the training's
#: and `EXACT_AFFORDABLE_SECONDS` (the paper's cells: about 3 s).
EXACT_COST_FACTOR = 10.0
EXACT_AFFORDABLE_SECONDS = 60.0


@dataclass(frozen=True)
class AnalysisPlan:
    """How a cell's asymptotes are computed, decided (and costed) before training.

    Attributes:
        kind: ``"exact"`` (the DP over the task's pairs) or ``"simulated"`` (Monte Carlo episodes).
        episodes: episodes simulated per run and policy (``simulated``); 0 for ``exact``.
        exact_seconds: the exact analysis's estimate ([tableclean_suite.asymptotes.exact_seconds][]).
        simulated_seconds: the simulation's ([tableclean_suite.simulation.simulation_seconds][]).
        training_seconds: the training's, the cell's runs ([tableclean_suite.resources.training_seconds][]).
        bytes: memory the chosen kind allocates per analysis call, at most (for the resource guard).
    """

    kind: str
    episodes: int
    exact_seconds: float
    simulated_seconds: float
    training_seconds: float
    bytes: int = 0

    @property
    def label(self) -> str:
        """``'exact'`` or ``'simulated (1000 episodes per run)'``: what the tables print."""
        return "exact" if self.kind == "exact" else f"simulated ({self.episodes} episodes per run)"

    @property
    def seconds(self) -> float:
        """The estimate of the chosen kind."""
        return self.exact_seconds if self.kind == "exact" else self.simulated_seconds

    def describe(self) -> str:
        """One clause for the harness's estimate line, e.g. ``'asymptotes simulated (1000 episodes per
        run): about 17 s, where exact ones would take about 2.7 hours and the training about 1.3 s'``."""
        from tableclean_suite.resources import format_seconds

        other = "simulated" if self.kind == "exact" else "exact"
        return (f"asymptotes {self.label}: about {format_seconds(self.seconds)}, where {other} ones would take about "
                f"{format_seconds(self.simulated_seconds if self.kind == 'exact' else self.exact_seconds)} and the "
                f"training about {format_seconds(self.training_seconds)}")


def analysis_plan(model, reward, runs: int, max_itr: int, training_seconds: float, analysis: str = "auto",
                  episodes: int = simulation.SIMULATED_EPISODES, runs_per_call: int | None = None,
                  checkpoint: bool = False, max_successors: int = 1) -> AnalysisPlan:
    """Choose and cost a cell's analysis before training.

    Args:
        model: the `TaskModel` (its S and A; nothing is built).
        reward: the cell's reward pattern or its name (the paper's looping penalty makes the exact
            DP's states pairs of states).
        runs: the cell's runs; ``runs_per_call``: runs analysed together (a training chunk's).
        max_itr: episode length limit.
        training_seconds: the cell's training estimate ([tableclean_suite.resources.training_seconds][]).
        analysis: ``"exact"``, ``"simulated"`` or ``"auto"``: exact unless its estimate exceeds both
            `EXACT_COST_FACTOR` times the training's and
            `EXACT_AFFORDABLE_SECONDS`.
        episodes: simulated episodes per run and policy (>= 2).
        checkpoint: the settling checkpoint's policies are analysed too (a third analysis per run,
            beside the final behaviour and the final greedy policy).
        max_successors: K successors per (state, action) of the stepped table.

    Raises:
        ValueError: an unknown ``analysis`` or a bad ``episodes``, naming what is allowed.
    """
    from tableclean_suite.rewards import LOOPING_OFF, get_reward_pattern

    if analysis not in ANALYSIS_KINDS:
        raise ValueError(f"analysis must be one of {', '.join(ANALYSIS_KINDS)}, got {analysis!r}")
    check_count("episodes", episodes, 2)
    pattern = get_reward_pattern(reward)
    calls = 2 + int(bool(checkpoint))
    exact = asymptotes.exact_seconds(model.n_states, model.n_actions, max_itr, runs,
                                     looping=pattern.looping_code != LOOPING_OFF and pattern.paper_looping,
                                     runs_per_call=runs_per_call, calls_per_run=calls, max_successors=max_successors)
    simulated = simulation.simulation_seconds(model.n_states, model.n_actions, runs, max_itr, calls, int(episodes))
    kind = analysis
    if analysis == "auto":
        too_costly = exact > EXACT_COST_FACTOR * float(training_seconds) and exact > EXACT_AFFORDABLE_SECONDS
        kind = "simulated" if too_costly else "exact"
    per_call = int(runs) if runs_per_call is None else max(1, min(int(runs_per_call), int(runs)))
    entries = int(model.n_states) * int(model.n_actions) * max(1, int(max_successors))
    memory = (entries * asymptotes.EXACT_BYTES_PER_ENTRY if kind == "exact"
              else simulation.simulation_bytes(model.n_states, model.n_actions, per_call))
    return AnalysisPlan(kind, int(episodes) if kind == "simulated" else 0, exact, simulated,
                        float(training_seconds), memory)


def cell_plan(model, reward, learner, runs: int, iterations: int, max_itr: int, analysis: str = "auto",
              runs_per_call: int | None = None, checkpoint: bool = False, max_successors: int = 1,
              episodes: int = simulation.SIMULATED_EPISODES) -> AnalysisPlan:
    """[analysis_plan][tableclean_suite.analysis.analysis_plan] of one harness cell, its training
    estimated by [tableclean_suite.resources.training_seconds][] for ``learner`` on ``runs`` x ``iterations``."""
    from tableclean_suite.learners.rules import METHOD_DOUBLE_Q
    from tableclean_suite.resources import training_seconds

    training = training_seconds(runs, iterations, model.n_states, model.n_actions,
                                planning_steps=getattr(learner, "planning_steps", 0),
                                q_tables=2 if getattr(learner, "method", None) == METHOD_DOUBLE_Q else 1)
    return analysis_plan(model, reward, runs, max_itr, training, analysis, episodes, runs_per_call, checkpoint,
                         max_successors)


def analysis_chain(model, reward, table=None, plan: AnalysisPlan | None = None):
    """What [final_run_facts][tableclean_suite.analysis.final_run_facts] analyses a cell's runs over:
    the [EpisodeChain][tableclean_suite.asymptotes.EpisodeChain] for an exact ``plan`` (or None), the
    [StepTable][tableclean_suite.simulation.StepTable] (with the plan's episodes) for a simulated one.
    ``table``: the stepped transition table (default: the model's own)."""
    if plan is not None and plan.kind == "simulated":
        return simulation.StepTable.build(model, reward, table, plan.episodes)
    return asymptotes.EpisodeChain.build(model, reward, table)


def monte_carlo_error(errors) -> float:
    """The Monte Carlo standard error of a mean over runs, from each run's ``(R,)`` standard error:
    ``sqrt(sum(error_r ** 2)) / R`` (the runs' simulations are independent)."""
    errors = np.asarray(errors, dtype=np.float64)
    return float(np.sqrt(np.sum(errors * errors)) / errors.size)


# Exact fixed points: what Q-learning and SARSA converge to on the task's own table
#: Value-iteration sweeps stop once no Q-value changes by more than this (reward units).
VALUE_TOLERANCE = 1e-13
#: At most this many sweeps (gamma <= 0.99 converges to VALUE_TOLERANCE well within it).
MAX_SWEEPS = 100_000


def _backup(chain, q: np.ndarray, gamma: float, probabilities: np.ndarray | None) -> np.ndarray:
    """One Bellman backup of pair-action values ``q`` ``(n_pairs, A)``: the max over actions
    (``probabilities`` None) or the expectation under ``probabilities`` ``(n_pairs, A)``."""
    value = q.max(axis=1) if probabilities is None else (probabilities * q).sum(axis=1)
    following = np.where(chain.next_pair >= 0, value[np.maximum(chain.next_pair, 0)], 0.0)  # (S, A, K)
    return (chain.probability[chain.pair_state] * (chain.reward + gamma * following[chain.pair_state])).sum(axis=2)


def fixed_point_q(chain, gamma: float, epsilon: float | None = None) -> np.ndarray:
    """Exact action values over the chain's (state, previous state) pairs, ``(n_pairs, A)``.

    Args:
        chain: [`tableclean_suite.asymptotes.EpisodeChain.build`][tableclean_suite.asymptotes.EpisodeChain.build] of the task, table and reward
            (r4's looping penalty makes the pair the Markov state; for the other patterns a pair is
            a state).  A longer looping memory (NaN rewards) is refused.
        gamma: discount in [0, 1).
        epsilon: None for Q* (the fixed point of Q-learning's update, value iteration); a number
            in [0, 1] for the on-policy fixed point of SARSA / expected SARSA under epsilon-greedy
            behaviour on its own Q (Q = Q^pi with pi epsilon-greedy on Q: policy iteration that
            re-derives pi after every evaluation until pi stops changing).

    Returns:
        ``(n_pairs, A)`` float64; episodes are not truncated (the discounted values of an endless
        episode).
    """
    if not 0.0 <= gamma < 1.0:
        raise ValueError(f"gamma must be in [0, 1) for a finite fixed point, got {gamma!r}")
    if np.isnan(chain.reward).any():
        raise ValueError("the chain's rewards are unknown (a looping memory longer than the paper's); "
                         "no exact fixed point")
    n_actions = chain.probability.shape[1]
    q, policy = np.zeros((len(chain.pair_state), n_actions)), None
    for _ in range(MAX_SWEEPS):
        probabilities = None if epsilon is None else action_probabilities(greedy_policy(q), epsilon, n_actions)
        for _ in range(MAX_SWEEPS):
            q, previous = _backup(chain, q, gamma, probabilities), q
            if np.max(np.abs(q - previous)) <= VALUE_TOLERANCE:
                break
        greedy = greedy_policy(q)
        if epsilon is None or (policy is not None and np.array_equal(greedy, policy)):
            return q
        policy = greedy
    raise RuntimeError(f"no fixed point within {MAX_SWEEPS} policy updates")


def greedy_gap(q: np.ndarray, pairs: np.ndarray | None = None) -> float:
    """Smallest difference between the best and the second-best action value over ``pairs``
    (default all rows of ``q``): how firmly the greedy policy is decided (0: a tie)."""
    rows = np.sort(np.asarray(q)[pairs if pairs is not None else slice(None)], axis=1)
    return float(np.min(rows[:, -1] - rows[:, -2]))


def state_policy(chain, q: np.ndarray, n_states: int) -> np.ndarray:
    """``(S,)`` the greedy action of each state from pair values, when every pair of a state
    agrees (always, without a looping penalty); -1 where they disagree or the state has no pair."""
    greedy = greedy_policy(q)
    policy = np.full(n_states, -1, dtype=np.int64)
    for state in np.unique(chain.pair_state):
        actions = np.unique(greedy[chain.pair_state == state])
        if len(actions) == 1:
            policy[state] = actions[0]
    return policy
