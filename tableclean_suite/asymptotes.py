"""Exact asymptotes of the learning curves: what a run's final policy scores, by dynamic programming.

For one policy (action probabilities per state), per episode (a uniform start state until the
terminal state or ``max_itr`` steps, as ``train()`` runs it): ``success`` (terminal with no
improper action) and ``terminal`` probabilities in [0, 1], ``average_reward`` E[return / length]
(reward units per iteration, the reward pattern applied as in training) and ``length`` E[length]
in [1, max_itr]: the limits of the [`metrics`][tableclean_suite.metrics] curves.

r4's looping penalty makes the DP state the pair (s_t, s_{t-1}) (``NO_STATE`` = -1 at an episode's
first step); a longer looping memory (e.g. ``r4_cycle``) gives NaN average rewards, the other
quantities stay exact.  The DP is a forward pass over steps 1 .. max_itr that stops once less than
`MASS_TOLERANCE` is left inside an episode; its cost is [exact_seconds][tableclean_suite.asymptotes.exact_seconds],
and [tableclean_suite.simulation][] estimates the same quantities where that is hours.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from tableclean_suite.executors.base import check_count
from tableclean_suite.learners.transitions import TransitionTable
from tableclean_suite.rewards import LOOPABLE_OUTCOMES, LOOPING_ADD, LOOPING_OFF, get_reward_pattern
from tableclean_suite.task import Outcome

#: The forward pass stops once less than this probability is still inside the episode.
MASS_TOLERANCE = 1e-12
#: Seconds per (DP step, pair, action, successor, clean flag) visit of the forward pass, and per
#: policy on top of it (a fast machine's): [`exact_seconds`][tableclean_suite.asymptotes.exact_seconds].
PAIR_VISIT_SECONDS = 1e-8
POLICY_VISIT_SECONDS = 2.5e-9
#: Bytes per (state, action, successor) entry of the exact analysis at its peak.
EXACT_BYTES_PER_ENTRY = 256
#: Table entries (state x action x successor) per second of building an [`EpisodeChain`][tableclean_suite.asymptotes.EpisodeChain].
CHAIN_ENTRIES_PER_SECOND = 3_000_000
#: s_{t-1} at an episode's first step.
NO_STATE = -1

_TERMINAL = int(Outcome.TERMINAL)
_IMPROPER = int(Outcome.IMPROPER)
_LOOPABLE = np.array([int(o) for o in LOOPABLE_OUTCOMES], dtype=np.int64)
#: Index of each quantity in the DP's output row.
SUCCESS, TERMINAL, AVERAGE_REWARD, LENGTH = 0, 1, 2, 3
QUANTITIES = ("success", "terminal", "average_reward", "length")


@dataclass(frozen=True)
class Asymptotes:
    """Per-policy episode statistics under a fixed behaviour policy (arrays of shape ``(P,)``).

    Attributes:
        success: P(terminal with no improper action), in [0, 1].
        terminal: P(terminal within ``max_itr`` steps), in [0, 1].
        average_reward: E[return / length], reward units per iteration.
        length: E[length], iterations in [1, max_itr].
        error: the Monte Carlo standard errors of a simulated estimate, the same fields and shapes
            ([tableclean_suite.simulation.simulated_statistics][]); None for the exact DP.
    """

    success: np.ndarray
    terminal: np.ndarray
    average_reward: np.ndarray
    length: np.ndarray
    error: "Asymptotes | None" = None


@dataclass(frozen=True)
class EpisodeChain:
    """The (state, previous state) chain of one task, table and reward pattern, ready for the DP.

    Attributes:
        pair_state: ``(n_pairs,)`` int64, s of each pair.
        next_pair: ``(S, A, K)`` int64, the pair after (s, a, successor k) (-1 for terminal ones).
        probability: ``(S, A, K)`` float64 successor probabilities.
        outcome: ``(S, A, K)`` int64 [`Outcome`][tableclean_suite.task.state.Outcome] codes.
        reward: ``(n_pairs, A, K)`` float64 reward of each step from each pair.
        start_pairs: ``(n_starts,)`` int64 pairs an episode starts in (uniform).
    """

    pair_state: np.ndarray
    next_pair: np.ndarray
    probability: np.ndarray
    outcome: np.ndarray
    reward: np.ndarray
    start_pairs: np.ndarray

    @classmethod
    def build(cls, model, reward, table: TransitionTable | None = None) -> "EpisodeChain":
        """The chain of ``model`` (a [`TaskModel`][tableclean_suite.task.model.TaskModel]) under ``reward``
        (a pattern or its registered name), stepping ``table`` (default: the model's own)."""
        pattern = get_reward_pattern(reward)
        table = table if table is not None else TransitionTable.from_model(model)
        table.check_model(model)
        probability = np.diff(table.cumulative, axis=2, prepend=0.0)
        next_state, outcome = table.next_state.astype(np.int64), table.outcome.astype(np.int64)
        n_states = next_state.shape[0]
        starts = np.array([s.index for s in model.start_states()], dtype=np.int64)
        looping = pattern.looping_code != LOOPING_OFF and pattern.paper_looping
        unknown_reward = pattern.looping_code != LOOPING_OFF and not pattern.paper_looping
        continuing = (probability > 0) & (outcome != _TERMINAL)
        if looping:
            sources = np.broadcast_to(np.arange(n_states)[:, None, None], next_state.shape)
            codes = np.r_[starts * (n_states + 1), (next_state * (n_states + 1) + sources + 1)[continuing]]
        else:
            codes = np.r_[starts, next_state[continuing]] * (n_states + 1)
        unique, inverse = np.unique(codes, return_inverse=True)
        pair_state, pair_previous = unique // (n_states + 1), unique % (n_states + 1) - 1
        start_pairs = inverse[: len(starts)].astype(np.int64)
        next_pair = np.full(next_state.shape, -1, dtype=np.int64)
        next_pair[continuing] = inverse[len(starts):]
        values = pattern.outcome_values()
        base = values[outcome]  # (S, A, K)
        reward_table = base[pair_state].copy()  # (n_pairs, A, K)
        if looping:
            out, nxt = outcome[pair_state], next_state[pair_state]
            loops = (np.isin(out, _LOOPABLE)
                     & ((nxt == pair_previous[:, None, None]) | (nxt == pair_state[:, None, None])))
            penalty = float(pattern.looping_penalty)
            reward_table = np.where(loops, reward_table + penalty if pattern.looping_code == LOOPING_ADD else penalty,
                                    reward_table)
        if unknown_reward:  # the reward depends on the whole episode so far: no exact average reward
            reward_table = np.full(reward_table.shape, np.nan)
        return cls(pair_state.astype(np.int64), next_pair, probability, outcome, reward_table, start_pairs)


@numba.njit(cache=True)
def _retire(p, active, order, acc, inside, mass, gain, pi_t, result):
    """Write policy slot ``p``'s results to ``result[order[p]]`` and move the last active slot
    (``active - 1``) into ``p``; returns the new number of active slots."""
    for j in range(acc.shape[0]):
        result[order[p], j] = acc[j, p]
    active -= 1
    if p != active:
        order[p] = order[active]
        inside[p] = inside[active]
        for j in range(acc.shape[0]):
            acc[j, p] = acc[j, active]
        for c in range(mass.shape[0]):
            for n in range(mass.shape[1]):
                mass[c, n, p] = mass[c, n, active]
                gain[c, n, p] = gain[c, n, active]
        for s in range(pi_t.shape[0]):
            for a in range(pi_t.shape[1]):
                pi_t[s, a, p] = pi_t[s, a, active]
    return active


@numba.njit(cache=True)
def _episode_statistics(pi_t, pair_state, next_pair, probability, outcome, reward, start_pairs, max_itr, tolerance,
                        result):
    """The module docstring's forward DP for every policy at once; writes ``result[p] = (success,
    terminal, E[R/L], E[L])`` for ``p`` in ``range(P)``.

    ``pi_t`` is ``(S, A, P)`` (overwritten: slots are reordered).  The policies step in lockstep,
    policy index innermost; each policy's arithmetic is the per-policy DP's (the tests' reference)
    in the same order, plus additions of exact zeros.  A policy whose mass inside drops below
    ``tolerance`` is retired (results written, the last active policy moved into its slot).
    """
    n_pairs = pair_state.shape[0]
    n_actions, n_successors = probability.shape[1], probability.shape[2]
    n_policies = pi_t.shape[2]
    order = np.arange(n_policies)  # slot -> policy
    mass = np.zeros((2, n_pairs, n_policies))  # [clean flag, pair, slot]
    gain = np.zeros((2, n_pairs, n_policies))
    new_mass = np.zeros((2, n_pairs, n_policies))
    new_gain = np.zeros((2, n_pairs, n_policies))
    acc = np.zeros((len(QUANTITIES), n_policies))  # [quantity, slot]
    inside = np.zeros(n_policies)
    for i in range(start_pairs.shape[0]):
        for p in range(n_policies):
            mass[1, start_pairs[i], p] += 1.0 / start_pairs.shape[0]
    active = n_policies
    for step in range(1, max_itr + 1):
        last = step == max_itr
        new_mass[:, :, :active] = 0.0
        new_gain[:, :, :active] = 0.0
        inside[:active] = 0.0
        for clean in range(2):
            for n in range(n_pairs):
                s = pair_state[n]
                m, g = mass[clean, n], gain[clean, n]
                for a in range(n_actions):
                    w = pi_t[s, a]
                    for k in range(n_successors):
                        q = probability[s, a, k]
                        if q == 0.0:
                            continue
                        r = reward[n, a, k]
                        still_clean = clean if outcome[s, a, k] != _IMPROPER else 0
                        if outcome[s, a, k] == _TERMINAL:
                            for p in range(active):
                                step_mass = m[p] * w[p] * q
                                step_gain = g[p] * w[p] * q + step_mass * r
                                acc[TERMINAL, p] += step_mass
                                if still_clean == 1:
                                    acc[SUCCESS, p] += step_mass
                                acc[AVERAGE_REWARD, p] += step_gain / step
                                acc[LENGTH, p] += step_mass * step
                        elif last:
                            for p in range(active):
                                step_mass = m[p] * w[p] * q
                                step_gain = g[p] * w[p] * q + step_mass * r
                                acc[AVERAGE_REWARD, p] += step_gain / step
                                acc[LENGTH, p] += step_mass * step
                        else:
                            target_mass = new_mass[still_clean, next_pair[s, a, k]]
                            target_gain = new_gain[still_clean, next_pair[s, a, k]]
                            for p in range(active):
                                step_mass = m[p] * w[p] * q
                                step_gain = g[p] * w[p] * q + step_mass * r
                                target_mass[p] += step_mass
                                target_gain[p] += step_gain
                                inside[p] += step_mass
        mass, new_mass = new_mass, mass
        gain, new_gain = new_gain, gain
        p = np.int64(0)  # not a bare 0: a literal argument makes numba compile _retire twice
        while p < active:
            if last or inside[p] < tolerance:
                active = _retire(p, active, order, acc, inside, mass, gain, pi_t, result)
            else:
                p += 1
        if active == 0:
            break


def greedy_policy(q: np.ndarray) -> np.ndarray:
    """Greedy actions of Q-tables ``(..., S, A)`` -> ``(..., S)`` int64, ties to the first action."""
    return np.argmax(np.asarray(q), axis=-1)


def action_probabilities(policy: np.ndarray, epsilon, n_actions: int) -> np.ndarray:
    """Epsilon-greedy action probabilities ``(..., S, n_actions)`` of a greedy ``policy`` ``(..., S)``.

    ``epsilon``: in [0, 1], a number or an array broadcastable to ``policy`` (per-state epsilon).
    """
    epsilon = np.asarray(epsilon, dtype=np.float64)
    if not np.all((epsilon >= 0.0) & (epsilon <= 1.0)):
        raise ValueError(f"epsilon must be in [0, 1], got {epsilon.tolist()!r}")
    policy = np.asarray(policy)
    rate = np.broadcast_to(epsilon, policy.shape)[..., None]
    probabilities = np.broadcast_to(rate / n_actions, policy.shape + (n_actions,)).copy()
    np.put_along_axis(probabilities, policy[..., None], 1.0 - rate + rate / n_actions, axis=-1)
    return probabilities


def _policies_of(probabilities, chain: EpisodeChain) -> np.ndarray:
    """``probabilities`` as float64 ``(P, S, A)`` policies of ``chain``'s task, or a ValueError naming
    the shapes (the compiled passes index them by the chain's states and actions, unchecked)."""
    probabilities = np.asarray(probabilities, dtype=np.float64)
    states, actions = chain.probability.shape[:2]
    if probabilities.ndim != 3 or probabilities.shape[1:] != (states, actions):
        raise ValueError(f"policies must have shape (P, S, A) = (P, {states}, {actions}) for this task, "
                         f"got {probabilities.shape}")
    return probabilities


def _check_pass(max_itr, tolerance) -> None:
    check_count("max_itr", max_itr, 1)
    if not 0.0 <= tolerance < 1.0:
        raise ValueError(f"tolerance must be in [0, 1), got {tolerance!r}")


def episode_statistics(probabilities: np.ndarray, chain: EpisodeChain, max_itr: int,
                       tolerance: float = MASS_TOLERANCE) -> Asymptotes:
    """[`Asymptotes`][tableclean_suite.asymptotes.Asymptotes] of behaviour policies given as action probabilities.

    Args:
        probabilities: ``(P, S, A)`` (or ``(S, A)``) probabilities of each action in each state.
        chain: [`EpisodeChain.build`][tableclean_suite.asymptotes.EpisodeChain.build] of the task, table and reward pattern.
        max_itr: episode length limit, an integer >= 1 (``train(max_itr=...)``).
        tolerance: probability mass left inside the episode at which the pass stops, in [0, 1).

    Returns:
        [`Asymptotes`][tableclean_suite.asymptotes.Asymptotes] with arrays of shape ``(P,)`` (``()`` for a single ``(S, A)`` policy).
    """
    _check_pass(max_itr, tolerance)
    probabilities = np.asarray(probabilities, dtype=np.float64)
    single = probabilities.ndim == 2
    probabilities = np.ascontiguousarray(_policies_of(probabilities[None] if single else probabilities, chain))
    result = np.zeros((probabilities.shape[0], len(QUANTITIES)))
    _episode_statistics(np.ascontiguousarray(probabilities.transpose(1, 2, 0)), chain.pair_state, chain.next_pair,
                        chain.probability, chain.outcome, chain.reward, chain.start_pairs, int(max_itr),
                        float(tolerance), result)
    columns = [result[0, i] if single else result[:, i] for i in range(len(QUANTITIES))]
    return Asymptotes(*columns)


def greedy_asymptotes(q: np.ndarray, epsilon: float, chain: EpisodeChain, max_itr: int) -> Asymptotes:
    """[`Asymptotes`][tableclean_suite.asymptotes.Asymptotes] of epsilon-greedy behaviour on final Q-tables, one per run.

    Args:
        q: ``(R, S, A)`` final Q-tables (``TrainingResult.q``); greedy ties go to the first action,
            as in training.
        epsilon: exploration rate in [0, 1] of the final behaviour (random actions uniform).
        chain: the task's [`EpisodeChain`][tableclean_suite.asymptotes.EpisodeChain].
        max_itr: episode length limit (>= 1).

    Returns:
        [`Asymptotes`][tableclean_suite.asymptotes.Asymptotes] with arrays of shape ``(R,)``.  Runs sharing a greedy policy share the
        computation (trained runs mostly converge to a few policies; [`policy_statistics`][tableclean_suite.asymptotes.policy_statistics]).
    """
    policies = greedy_policy(np.asarray(q))
    first, inverse = _distinct_rows(policies)
    stats = policy_statistics(action_probabilities(policies[first], epsilon, q.shape[-1]), chain, max_itr)
    return Asymptotes(*(getattr(stats, name)[inverse] for name in QUANTITIES))


def _distinct_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(first, inverse)`` of the distinct rows of ``rows`` ``(P, n)``, compared byte for byte, in
    order of first occurrence (``rows[first][inverse]`` equals ``rows``); faster than ``np.unique(axis=0)``."""
    rows = np.ascontiguousarray(rows)
    index: dict[bytes, int] = {}
    first: list[int] = []
    inverse = np.empty(rows.shape[0], dtype=np.int64)
    for i, row in enumerate(rows):
        j = index.setdefault(row.tobytes(), len(first))
        if j == len(first):
            first.append(i)
        inverse[i] = j
    return np.array(first, dtype=np.int64), inverse


@numba.njit(cache=True)
def _reached_pairs(probabilities, pair_state, next_pair, probability, start_pairs, reached):
    """Marks ``reached[p, n]`` (``(P, n_pairs)`` bool, all False on entry) for every pair an episode
    can be in under policy ``p`` of ``probabilities`` ``(P, S, A)`` (a depth-first search per policy)."""
    n_actions, n_successors = probability.shape[1], probability.shape[2]
    stack = np.empty(pair_state.shape[0], dtype=np.int64)  # each pair is pushed at most once
    for p in range(probabilities.shape[0]):
        top = 0
        for i in range(start_pairs.shape[0]):
            if not reached[p, start_pairs[i]]:
                reached[p, start_pairs[i]] = True
                stack[top] = start_pairs[i]
                top += 1
        while top > 0:
            top -= 1
            s = pair_state[stack[top]]
            for a in range(n_actions):
                if probabilities[p, s, a] > 0.0:
                    for k in range(n_successors):
                        target = next_pair[s, a, k]
                        if probability[s, a, k] > 0.0 and target >= 0 and not reached[p, target]:
                            reached[p, target] = True
                            stack[top] = target
                            top += 1


def reached_states(probabilities: np.ndarray, chain: EpisodeChain) -> np.ndarray:
    """``(P, S)`` bool: the states an episode can be in under each of the policies ``(P, S, A)``
    (`_reached_pairs`; a state is reached when one of its pairs is).  Elsewhere the DP's
    mass and expected return stay exactly 0 whatever the policy does there."""
    probabilities = np.ascontiguousarray(_policies_of(probabilities, chain))
    reached = np.zeros((probabilities.shape[0], chain.pair_state.shape[0]), dtype=bool)
    _reached_pairs(probabilities, chain.pair_state, chain.next_pair, chain.probability, chain.start_pairs, reached)
    states = np.zeros(probabilities.shape[:2], dtype=bool)
    for n, state in enumerate(chain.pair_state):
        states[:, state] |= reached[:, n]
    return states


def policy_statistics(probabilities: np.ndarray, chain: EpisodeChain, max_itr: int,
                      tolerance: float = MASS_TOLERANCE) -> Asymptotes:
    """[`episode_statistics`][tableclean_suite.asymptotes.episode_statistics] of ``(P, S, A)`` policies
    (arrays of shape ``(P,)``), bit for bit, each distinct policy computed once: policies are distinct
    when they differ in a state an episode can reach under them
    ([`reached_states`][tableclean_suite.asymptotes.reached_states]; elsewhere the DP only adds exact zeros).
    """
    _check_pass(max_itr, tolerance)
    probabilities = _policies_of(probabilities, chain)
    first, inverse = _distinct_rows(probabilities.reshape(probabilities.shape[0], -1))
    distinct = probabilities[first]
    if np.isfinite(chain.reward).all():
        kept = reached_states(distinct, chain)  # (P, S): the states where the DP reads each policy
    else:  # NaN rewards: an exact zero times NaN is not zero, so the DP reads every state of the chain
        kept = np.zeros(distinct.shape[:2], dtype=bool)
        kept[:, chain.pair_state] = True
    canonical = np.where(kept[:, :, None], distinct, 0.0)
    first, canonical_inverse = _distinct_rows(canonical.reshape(canonical.shape[0], -1))
    computed = episode_statistics(canonical[first], chain, max_itr, tolerance)
    inverse = canonical_inverse[inverse]
    return Asymptotes(*(getattr(computed, name)[inverse] for name in QUANTITIES))


def exact_seconds(n_states: int, n_actions: int, max_itr: int, runs: int, looping: bool = True,
                  runs_per_call: int | None = None, calls_per_run: int = 1, max_successors: int = 1) -> float:
    """Estimated seconds of the exact analysis of ``runs`` runs' policies, before any of it is built.

    Args:
        n_states, n_actions: the task's S state codes and A actions.
        max_itr: the DP's steps (an upper bound: a pass stops once the episodes have ended).
        runs: runs analysed.
        looping: the reward pattern has the paper's looping penalty, so a DP state is a (state,
            previous state) pair (at most S x A x K of them) instead of a state (at most S).
        runs_per_call: runs analysed together (a training chunk's; default all): each call visits
            every pair, its policies in lockstep.
        calls_per_run: analyses per run (e.g. 3: the final behaviour, the final greedy policy and
            the settling checkpoint's behaviour).
        max_successors: K successors per (state, action) of the stepped table.

    Returns:
        Building the chain (`CHAIN_ENTRIES_PER_SECOND`) plus, per call, ``max_itr x 2 x pairs x A x K``
        visits at `PAIR_VISIT_SECONDS` + `POLICY_VISIT_SECONDS` per policy: an upper bound (every
        run a distinct policy, every pair reached).
    """
    entries = int(n_states) * int(n_actions) * max(1, int(max_successors))
    pairs = entries if looping else int(n_states)
    per_call = int(runs) if runs_per_call is None else max(1, min(int(runs_per_call), int(runs)))
    calls = -(-int(runs) // per_call) * int(calls_per_run)
    visits = float(max_itr) * 2 * pairs * int(n_actions) * max(1, int(max_successors))
    return entries / CHAIN_ENTRIES_PER_SECOND + calls * visits * (PAIR_VISIT_SECONDS + per_call * POLICY_VISIT_SECONDS)
