"""The batched, compiled training loop: many independent runs, one step per run per iteration.

Algorithm 1 of the paper with the learner's TD target plugged in, compiled with numba.  The loop
(`_train_loop`, written once) picks the built-in TD target, the update rule (one-step, double Q,
eligibility traces, Dyna planning) and the exploration by integer codes; its compiled copies are
`train_batch` (one-step, constant epsilon-greedy: the paper's learners), `train_batch_general`
and a user target's own ([`kernel_for`][tableclean_suite.learners.kernel.kernel_for] picks).  A
run's numbers depend only on its key ([`rng`][tableclean_suite.learners.rng]), so slices of the runs train
on several threads at once ([`run_in_threads`][tableclean_suite.learners.threads.run_in_threads]; the loop is
compiled ``nogil``) with the same bits for any thread count.
[`stepper`][tableclean_suite.learners.stepper] drives the same pieces one step at a time.

Per-step cost: O(A) for one-step and double-Q updates and for Cruz et al.'s affordances; trace
learners touch only the pairs with a non-zero trace; Dyna-Q adds ``planning_steps`` O(A) updates.
"""

from __future__ import annotations

import hashlib
import inspect
import types

import numba
import numpy as np

from tableclean_suite.learners.assist import (
    AFFORD_LEARNED,
    AFFORD_NONE,
    NO_ADVICE,
    NOT_AFFORDED,
    advice_action,
    afforded_epsilon_greedy,
    afforded_max_target,
    afforded_softmax,
    run_masks,
)
from tableclean_suite.learners.exploration import (
    EPSILON_GREEDY_CODE,
    P_START,
    SOFTMAX_CODE,
    VISIT_DECAY_CODE,
    epsilon_greedy,
    exploration_parameter,
    softmax_action,
)
from tableclean_suite.learners.rng import (
    LANE_ADVICE,
    LANE_LEARNER,
    LANE_PLANNING,
    LANE_TIES,
    STREAM_DOUBLE_TABLE,
    STREAM_EXPLORE,
    STREAM_RANDOM_ACTION,
    STREAM_START,
    STREAM_TIE,
    STREAM_TRANSITION,
    lane_key,
    uniform,
    uniform_at,
)
from tableclean_suite.learners.optimality import NOT_LEARNED, behaviour_row, greedy_walk, tied_greedy, walk_changed
from tableclean_suite.learners.rules import (
    EXPECTED_SARSA_TARGET,
    METHOD_DOUBLE_Q,
    METHOD_DYNA,
    METHOD_ONE_STEP,
    METHOD_TRACES,
    PARAM_ACCUMULATE,
    PARAM_LAMBDA,
    PARAM_PLANNING,
    Q_LEARNING_TARGET,
    TIES_RANDOM,
    USER_TARGET,
    TabularLearner,
    builtin_td_target,
    greedy_action,
    q_learning_target,
    softmax_expected_sarsa_target,
)
from tableclean_suite.rewards import LOOPING_ADD, LOOPING_OFF
from tableclean_suite.task import Outcome

#: Codes of ``episode_end`` in training records.
EPISODE_CONTINUES, EPISODE_TERMINAL, EPISODE_TRUNCATED = 0, 1, 2
NO_STATE = -1  # no previous state (first step of an episode) / no pending action
#: ``train_batch``'s ``snapshot_at`` when no Q-table snapshot is taken.
NO_SNAPSHOT = -1
#: A double-Q step updates table A when its side-lane draw is below this, else table B.
DOUBLE_Q_SPLIT = 0.5
HALF = 0.5
#: ``LOOP_METHOD`` / ``LOOP_EXPLORATION`` of the general loop: the update rule and the exploration are
#: taken from the loop's ``method`` and ``explore_code`` arguments.
FROM_ARGUMENTS = -1
#: The update rule and exploration compiled into a copy of the loop ([`specialised_loop`][tableclean_suite.learners.kernel.specialised_loop]): a
#: constant, so numba drops the other rules' branches before compiling (and never compiles their callees).
LOOP_METHOD = FROM_ARGUMENTS
LOOP_EXPLORATION = FROM_ARGUMENTS

_ROUTINE = int(Outcome.ROUTINE)
_INEFFECTIVE = int(Outcome.INEFFECTIVE)
_IMPROPER = int(Outcome.IMPROPER)
_TERMINAL = int(Outcome.TERMINAL)


@numba.njit(cache=True)
def sample_index(cumulative, draw):
    """Index k of the first ``cumulative[k] > draw`` (the last index at worst)."""
    k = 0
    while k < cumulative.shape[0] - 1 and draw >= cumulative[k]:
        k += 1
    return k


@numba.njit(cache=True)
def memory_adjusted_reward(reward, outcome, next_state, entered, t, episode_start, memory, loop_value, loop_mode):
    """Apply the looping penalty, which looks back ``memory`` states (2: the paper's r4, s_t and
    s_{t-1}; 0: the whole episode), as [`reward`][tableclean_suite.rewards.RewardPattern.reward].

    ``entered[s]`` is the iteration at which state s was last entered (the current state s_t at
    ``t``), so s_{t+1} is among the episode's last ``memory`` states s_t .. s_{t-memory+1} when
    ``entered[s_{t+1}] > t - memory`` and it was entered in this episode (>= ``episode_start``).
    """
    if loop_mode == LOOPING_OFF:
        return reward
    if outcome != _ROUTINE and outcome != _INEFFECTIVE:
        return reward
    last = entered[next_state]
    if last < episode_start or (memory != 0 and last <= t - memory):
        return reward
    if loop_mode == LOOPING_ADD:
        return reward + loop_value
    return loop_value


# -- behaviour ------------------------------------------------------------------------------
@numba.njit(cache=True, inline="always")
def visit_count(visits, state):
    """Earlier visits of ``state`` (0 when the exploration does not count them: ``visits`` is empty)."""
    if visits.shape[0] == 0:
        return 0
    return visits[state]


@numba.njit(cache=True, inline="always")
def act(q_a, q_b, row, state, plain, double, explore_code, explore_parameters, key, iteration, visits,
        affordance, masks, advisor, advice, advice_key, random_ties, tie_key):
    """The behaviour policy's action in ``state`` at ``iteration`` (main-lane draws of that iteration).

    ``plain``: constant epsilon-greedy on ``q_a`` without affordances (the paper's policy, by a
    shorter path: the same action).
    An advisor (``advisor`` non-empty) is asked first (advice-lane draws); with affordances
    (``affordance`` != AFFORD_NONE) the choice is restricted to ``masks[state]`` ([`assist`][tableclean_suite.learners.assist]).
    With ``random_ties`` a greedy (not exploring) epsilon-greedy choice is uniform among the tied
    actions, by the ties lane's draw ([`optimality.tied_greedy`][tableclean_suite.learners.optimality.tied_greedy]).
    """
    if advisor.shape[0] > 0:
        advised = advice_action(advisor, advice, advice_key, iteration, state, q_a.shape[1])
        if advised != NO_ADVICE:
            return advised
    explore_draw = uniform(key, iteration, STREAM_EXPLORE)
    action_draw = uniform(key, iteration, STREAM_RANDOM_ACTION)
    if plain:
        return epsilon_greedy(q_a[state], explore_parameters[P_START], explore_draw, action_draw)
    parameter = exploration_parameter(explore_code, explore_parameters, iteration, visit_count(visits, state))
    q_row = behaviour_row(q_a, q_b, state, double, row)
    if random_ties and explore_code != SOFTMAX_CODE and explore_draw >= parameter:
        return tied_greedy(q_row, masks, state, affordance != AFFORD_NONE, uniform(tie_key, iteration, STREAM_TIE))
    if affordance != AFFORD_NONE:  # softmax at temperature parameter, or epsilon-greedy, over the afforded actions
        if explore_code == SOFTMAX_CODE:
            return afforded_softmax(q_row, masks[state], parameter, action_draw)
        return afforded_epsilon_greedy(q_row, masks[state], parameter, explore_draw, action_draw)
    if explore_code == SOFTMAX_CODE:
        return softmax_action(q_row, parameter, action_draw)
    return epsilon_greedy(q_row, parameter, explore_draw, action_draw)


@numba.njit(cache=True)
def is_exploratory(q_row, action):
    """True when ``action``'s value is below the row's maximum (a tie with the greedy action is not)."""
    return q_row[action] < q_row[greedy_action(q_row)]


# -- update rules -----------------------------------------------------------------------------
@numba.njit(cache=True)
def double_q_update(q_a, q_b, state, action, next_state, reward, alpha, gamma, terminal, draw):
    """Double Q-learning: update A (``draw < DOUBLE_Q_SPLIT``) evaluated by B, or B evaluated by A; the target is
    ``r + gamma * Q_other(s', argmax_a Q_updated(s', a))``, ``r`` at a terminal state."""
    if draw < DOUBLE_Q_SPLIT:
        updated, other = q_a, q_b
    else:
        updated, other = q_b, q_a
    target = reward if terminal else reward + gamma * other[next_state, greedy_action(updated[next_state])]
    updated[state, action] += alpha * (target - updated[state, action])


@numba.njit(cache=True)
def trace_update(q, traces, pairs, n_pairs, state, action, delta, alpha, decay, accumulate, cut):
    """One eligibility-trace step; returns the new number of listed pairs.

    Visits (state, action) (``e = 1``, or ``e += 1`` when ``accumulate``), then for every
    pair with a non-zero trace ``Q += (alpha * delta) * e`` and ``e *= decay`` (``e = 0``
    for all when ``cut``).  ``pairs[:n_pairs]`` lists exactly the pairs with ``e != 0``
    (codes ``s * A + a``), so this equals the dense sweep over all S x A pairs.

    Args:
        q, traces: ``(S, A)`` float64 Q-table and traces, updated in place.
        pairs: ``(S * A,)`` int64 pair list, updated in place.
        decay: gamma * lambda in [0, 1].
    """
    n_actions = q.shape[1]
    if traces[state, action] == 0.0:
        pairs[n_pairs] = state * n_actions + action
        n_pairs += 1
        traces[state, action] = 1.0
    elif accumulate:
        traces[state, action] += 1.0
    else:
        traces[state, action] = 1.0
    step = alpha * delta
    kept = 0
    for i in range(n_pairs):
        pair = pairs[i]
        s = pair // n_actions
        a = pair - s * n_actions
        q[s, a] += step * traces[s, a]
        trace = 0.0 if cut else traces[s, a] * decay
        traces[s, a] = trace
        if trace != 0.0:
            pairs[kept] = pair
            kept += 1
    return kept


@numba.njit(cache=True)
def clear_traces(traces, pairs, n_pairs):
    """Zero the listed traces (episode start); returns 0, the new list length."""
    n_actions = traces.shape[1]
    for i in range(n_pairs):
        traces[pairs[i] // n_actions, pairs[i] % n_actions] = 0.0
    return 0


@numba.njit(cache=True)
def remember(model_next, model_reward, model_terminal, observed, n_observed, state, action, next_state, reward,
             terminal):
    """Dyna's model: store the last (next state, reward, terminal) of (state, action); returns pairs observed."""
    if model_next[state, action] == NO_STATE:
        observed[n_observed] = state * model_next.shape[1] + action
        n_observed += 1
    model_next[state, action] = next_state
    model_reward[state, action] = reward
    model_terminal[state, action] = terminal
    return n_observed


@numba.njit(cache=True)
def plan(q, model_next, model_reward, model_terminal, observed, n_observed, planning_key, iteration, planning_steps,
         alpha, gamma):
    """Dyna-Q's planning after ``iteration``: ``planning_steps`` Q-learning updates on modelled pairs.

    The j-th pair is ``observed[floor(u * n_observed)]`` with ``u`` the planning lane's draw
    at counter ``iteration * planning_steps + j``.
    """
    n_actions = q.shape[1]
    for j in range(planning_steps):
        draw = uniform_at(planning_key, iteration * planning_steps + j)
        pair = observed[min(int(draw * n_observed), n_observed - 1)]
        s = pair // n_actions
        a = pair - s * n_actions
        target = q_learning_target(q[model_next[s, a]], np.int64(NO_STATE), model_reward[s, a], gamma, 0.0, model_terminal[s, a])
        q[s, a] += alpha * (target - q[s, a])


@numba.njit(cache=True)
def copy_tables(q_a, q_b, snapshot_a, snapshot_b, double):
    """Copy a run's Q-table (and, for double Q, table B) into its snapshot arrays (element loops: a slice
    assignment compiles its shape-mismatch message, seconds of a first process's compile)."""
    for s in range(q_a.shape[0]):
        for a in range(q_a.shape[1]):
            snapshot_a[s, a] = q_a[s, a]
            if double:
                snapshot_b[s, a] = q_b[s, a]


# -- per-run working memory ---------------------------------------------------------------------
@numba.njit(cache=True)
def run_memory(n_states, n_actions, double, traced, counting, modelling):
    """Per-run arrays, empty when the learner or exploration does not use them.

    Returns (behaviour row ``(A,)``, visits ``(S,)``, traces ``(S, A)``, trace pairs ``(S*A,)``,
    model next states ``(S, A)`` (NO_STATE = unseen), model rewards, model terminal flags,
    observed pairs ``(S*A,)``, and the greedy walk's examined states ``(S,)`` int64, their flags
    ``(S,)`` bool and greedy actions ``(S,)`` int64 ([`optimality.greedy_walk`][tableclean_suite.learners.optimality.greedy_walk]), and the iteration
    each state was last entered ``(S,)`` int64, -1 = never (the looping rule's memory)).
    """
    row = np.empty(n_actions if double else 0)
    visits = np.zeros(n_states if counting else 0, dtype=np.int64)
    n_traced = n_states if traced else 0
    traces = np.zeros((n_traced, n_actions))
    pairs = np.empty(n_traced * n_actions, dtype=np.int64)
    n_modelled = n_states if modelling else 0
    model_next = np.full((n_modelled, n_actions), NO_STATE, dtype=np.int64)
    model_reward = np.zeros((n_modelled, n_actions))
    model_terminal = np.zeros((n_modelled, n_actions), dtype=np.bool_)
    observed = np.empty(n_modelled * n_actions, dtype=np.int64)
    walked = np.empty(n_states, dtype=np.int64)
    on_walk = np.zeros(n_states, dtype=np.bool_)
    choice = np.zeros(n_states, dtype=np.int64)
    entered = np.full(n_states, -1, dtype=np.int64)
    return (row, visits, traces, pairs, model_next, model_reward, model_terminal, observed, walked, on_walk, choice,
            entered)


def _train_loop(
    lo,
    hi,
    next_state_table,
    outcome_table,
    cumulative_table,
    starts,
    outcome_values,
    loop_value,
    loop_mode,
    loop_memory,
    target_code,
    on_policy,
    method,
    learner_parameters,
    alpha,
    gamma,
    explore_code,
    explore_parameters,
    affordance,
    afforded,
    advisor,
    advice,
    max_itr,
    ties,
    task_next,
    distance,
    keys,
    q,
    q_second,
    rewards,
    outcomes,
    states,
    actions,
    episode_end,
    snapshot_at,
    q_snapshot,
    q_second_snapshot,
    first_learned,
    learned,
):
    """Train runs ``lo .. hi - 1`` (indices into the first axis of ``keys``, ``q`` and the outputs)
    for ``rewards.shape[1]`` iterations, in place, without the GIL.

    The Python source of the compiled copies ([`specialised_loop`][tableclean_suite.learners.kernel.specialised_loop],
    [`kernel_for`][tableclean_suite.learners.kernel.kernel_for]); a copy compiled for one update
    rule and exploration raises ``ValueError`` when ``method`` or ``explore_code`` is another.

    Args:
        lo, hi: the runs to train, ``0 <= lo <= hi <= R``.
        next_state_table, outcome_table: ``(S, A, K)`` int64 successors and outcomes.
        cumulative_table: ``(S, A, K)`` float64 cumulative successor probabilities.
        starts: ``(n_starts,)`` int64 start states, picked uniformly per episode.
        outcome_values: ``(n_outcomes,)`` float64 reward per outcome.
        loop_value, loop_mode: looping penalty and its mode (0 off, 1 replace, 2 add).
        loop_memory: states of the episode the looping rule looks back (``RewardPattern.looping_memory``:
            2 = the paper's s_t and s_{t-1}; 0 = the whole episode).
        target_code: the built-in learner's target code (``rules.Q_LEARNING_TARGET``, ...);
            ignored by a [`user_train_batch`][tableclean_suite.learners.kernel.user_train_batch] copy, which calls its own target.
        on_policy: choose the next action before the update and take it (SARSA).
        method: update rule (``rules.METHOD_*``).
        learner_parameters: ``(N_LEARNER_PARAMETERS,)`` float64, ``TabularLearner.kernel_parameters()``.
        alpha, gamma: learning rate, discount.
        explore_code, explore_parameters: the exploration's code and ``(N_PARAMETERS,)`` float64
            parameters ([`exploration`][tableclean_suite.learners.exploration]).
        affordance: ``assist.AFFORD_*`` code (none, given, learned).
        afforded: ``(S, A)`` int8 the given affordances (1 = afforded; used with AFFORD_GIVEN).
        advisor: ``(S,)`` int64 the advisor's action per state, or ``(0,)`` for no advisor.
        advice: ``(2,)`` float64 ``[L, C]`` advice probability and consistency, each in [0, 1].
        max_itr: iterations after which an episode is truncated.
        ties: ``rules.TIES_FIRST`` (greedy ties to the first action) or ``rules.TIES_RANDOM``.
        task_next: ``(S, A)`` int64 the task model's successors, on which optimality is judged.
        distance: ``(S,)`` int64 the task model's shortest-plan lengths (0 terminal, -1 none).
        keys: ``(R,)`` uint64 per-run random keys.
        q: ``(R, S, A)`` float64 Q-tables (table A for double Q), initialised, updated in place.
        q_second: ``(R, S, A)`` float64 table B for double Q, else ``(R, 0, 0)``.
        rewards: ``(R, T)`` float64 output, reward of each iteration.
        outcomes, states, actions: ``(R, T)`` int outputs (state before the step), of the
            task model's ``record_dtype`` (int8 for the paper's 24 states).
        episode_end: ``(R, T)`` int output (same dtype), EPISODE_* code after each iteration.
        snapshot_at: iterations after which the Q-tables are copied into ``q_snapshot`` (and
            ``q_second_snapshot`` for double Q), in [0, T]; `NO_SNAPSHOT`: no copy.  The copy is the final
            Q-tables of the same runs trained for ``snapshot_at`` iterations (the loop is a prefix:
            counter-based random numbers), so one pass gives both.
        q_snapshot, q_second_snapshot: ``(R, S, A)`` float64 outputs, or ``(R, 0, 0)`` when unused.
        first_learned, learned: ``(R,)`` int64 outputs, each run's first iteration after which its
            greedy policy is optimal and the iteration from which it stays so (-1: never / censored);
            see [`optimality`][tableclean_suite.learners.optimality].
    """
    n_iterations = rewards.shape[1]
    n_states, n_actions = q.shape[1], q.shape[2]
    n_starts = starts.shape[0]
    n_successors = next_state_table.shape[2]
    if LOOP_METHOD != FROM_ARGUMENTS and (method != LOOP_METHOD or explore_code != LOOP_EXPLORATION):
        raise ValueError("this copy of the training loop is compiled for another update rule or exploration")
    # The general copy reads the rule and exploration from its arguments; a specialised copy has them as constants
    # (new names: numba prunes branches on a variable with a single constant definition).
    rule = method if LOOP_METHOD == FROM_ARGUMENTS else LOOP_METHOD
    exploring = explore_code if LOOP_EXPLORATION == FROM_ARGUMENTS else LOOP_EXPLORATION
    double = rule == METHOD_DOUBLE_Q
    traced = rule == METHOD_TRACES
    modelling = rule == METHOD_DYNA
    choose_first = on_policy or traced
    watkins = traced and not on_policy
    decay = gamma * learner_parameters[PARAM_LAMBDA]
    accumulate = learner_parameters[PARAM_ACCUMULATE] != 0.0
    planning_steps = int(learner_parameters[PARAM_PLANNING])
    counting = exploring == VISIT_DECAY_CODE
    random_ties = ties == TIES_RANDOM
    plain = exploring == EPSILON_GREEDY_CODE and not double and affordance == AFFORD_NONE and not random_ties
    affording = affordance != AFFORD_NONE
    # One Q entry changes per step and the greedy choice is the first maximum of the plain row.
    one_entry = not (double or traced or modelling or affording or random_ties)
    learning_affordances = affordance == AFFORD_LEARNED
    afforded_max = affordance != AFFORD_NONE and target_code == Q_LEARNING_TARGET
    softmaxing = exploring == SOFTMAX_CODE  # (one definition, so a copy prunes the target's branch below)
    softmax_expected = target_code == EXPECTED_SARSA_TARGET
    for r in range(lo, hi):
        episode_start = 0
        key = keys[r]
        side_key = lane_key(key, LANE_LEARNER)
        planning_key = lane_key(key, LANE_PLANNING)
        advice_key = lane_key(key, LANE_ADVICE)
        tie_key = lane_key(key, LANE_TIES)
        masks = run_masks(afforded, affordance, n_states, n_actions)
        qr = q[r]
        qb = q_second[r]
        (row, visits, traces, pairs, model_next, model_reward, model_terminal, observed, walked, on_walk, choice,
         entered) = run_memory(n_states, n_actions, double, traced, counting, modelling)
        # np.int64(...), not bare constants: numba would compile a callee twice (for the literal type, then int64).
        n_pairs = np.int64(0)
        n_observed = np.int64(0)
        state = np.int64(NO_STATE)
        pending = np.int64(NO_STATE)
        length = 0
        optimal, n_walked = greedy_walk(qr, qb, double, row, masks, affording, random_ties, starts, task_next,
                                        distance, walked, on_walk, choice, np.int64(0))
        first = np.int64(0) if optimal else np.int64(NOT_LEARNED)
        last_not_optimal = np.int64(-1) if optimal else np.int64(0)
        for t in range(n_iterations):
            if t == snapshot_at:
                copy_tables(qr, qb, q_snapshot[r], q_second_snapshot[r], double)
            if state == NO_STATE:
                if n_starts == 1:
                    state = starts[0]
                else:
                    state = starts[min(int(uniform(key, t, STREAM_START) * n_starts), n_starts - 1)]
                pending = np.int64(NO_STATE)
                length = 0
                episode_start = t
                if traced:
                    n_pairs = clear_traces(traces, pairs, n_pairs)
            if pending != NO_STATE:
                action = pending
            else:
                action = act(qr, qb, row, state, plain, double, exploring, explore_parameters, key, t, visits,
                             affordance, masks, advisor, advice, advice_key, random_ties, tie_key)
            k = 0
            if n_successors > 1:
                k = sample_index(cumulative_table[state, action], uniform(key, t, STREAM_TRANSITION))
            nxt = next_state_table[state, action, k]
            outcome = outcome_table[state, action, k]
            entered[state] = t
            reward = memory_adjusted_reward(outcome_values[outcome], outcome, nxt, entered, t, episode_start,
                                            loop_memory, loop_value, loop_mode)
            length += 1
            terminal = outcome == _TERMINAL
            if counting:
                visits[state] += 1
            if learning_affordances and outcome == _IMPROPER:
                masks[state, action] = NOT_AFFORDED
            pending = NO_STATE
            if choose_first and not terminal:
                pending = act(qr, qb, row, nxt, plain, double, exploring, explore_parameters, key, t + 1, visits,
                              affordance, masks, advisor, advice, advice_key, random_ties, tie_key)
            before = qr[state, action]
            if double:
                double_q_update(qr, qb, state, action, nxt, reward, alpha, gamma, terminal,
                                uniform(side_key, t, STREAM_DOUBLE_TABLE))
            else:
                behaviour = exploration_parameter(exploring, explore_parameters, t + 1, visit_count(visits, nxt))
                if softmaxing and softmax_expected:
                    target = softmax_expected_sarsa_target(qr[nxt], reward, gamma, behaviour, terminal)
                elif afforded_max:
                    target = afforded_max_target(qr[nxt], masks[nxt], reward, gamma, terminal)
                else:
                    target = builtin_td_target(target_code, qr[nxt], pending, reward, gamma, behaviour, terminal)
                if traced:
                    cut = watkins and pending != NO_STATE and is_exploratory(qr[nxt], pending)
                    n_pairs = trace_update(qr, traces, pairs, n_pairs, state, action, target - qr[state, action],
                                           alpha, decay, accumulate, cut)
                else:
                    qr[state, action] += alpha * (target - qr[state, action])
                if modelling:
                    n_observed = remember(model_next, model_reward, model_terminal, observed, n_observed, state, action,
                                          nxt, reward, terminal)
                    plan(qr, model_next, model_reward, model_terminal, observed, n_observed, planning_key, t,
                         planning_steps, alpha, gamma)
            # Did this iteration's update change the greedy policy where the last walk looked?
            changed = False
            if one_entry:
                # Only Q(state, action) changed: the greedy action of a walked state changes when the taken
                # action's value fell below another's, or another action's value reached it (O(1) mostly).
                if on_walk[state]:
                    taken = choice[state]
                    value = qr[state, action]
                    if action == taken:
                        changed = value < before and greedy_action(qr[state]) != taken
                    else:
                        changed = value > qr[state, taken] or (value == qr[state, taken] and action < taken)
            elif traced or modelling:
                for i in range(n_walked):
                    if walk_changed(qr, qb, double, row, masks, affording, random_ties, walked[i], on_walk, choice):
                        changed = True
                        break
            else:
                changed = walk_changed(qr, qb, double, row, masks, affording, random_ties, state, on_walk, choice)
            if changed:
                optimal, n_walked = greedy_walk(qr, qb, double, row, masks, affording, random_ties, starts,
                                                task_next, distance, walked, on_walk, choice, n_walked)
            if optimal:
                if first == NOT_LEARNED:
                    first = t + 1
            else:
                last_not_optimal = t + 1
            rewards[r, t] = reward
            outcomes[r, t] = outcome
            states[r, t] = state
            actions[r, t] = action
            if terminal:
                episode_end[r, t] = EPISODE_TERMINAL
                state = NO_STATE
            elif length >= max_itr:
                episode_end[r, t] = EPISODE_TRUNCATED
                state = NO_STATE
            else:
                episode_end[r, t] = EPISODE_CONTINUES
                state = nxt
        if snapshot_at == n_iterations:
            copy_tables(qr, qb, q_snapshot[r], q_second_snapshot[r], double)
        first_learned[r] = first
        learned[r] = last_not_optimal + 1 if optimal else NOT_LEARNED


def specialised_loop(name: str, method: int, exploration: int):
    """A disk-cached compiled copy of `_train_loop` named ``name`` with the update rule ``method``
    (``rules.METHOD_*``) and the exploration ``exploration`` (``exploration.*_CODE``) compiled in as
    constants, or `FROM_ARGUMENTS` for both: read from its arguments (the general loop).

    Same code object, other globals (`LOOP_METHOD`, `LOOP_EXPLORATION`): numba drops the other rules'
    and explorations' branches before typing, so it never compiles their callees, and the copy gives
    the general loop's bits for learners of that rule and exploration.
    """
    function = _loop_function(name, LOOP_METHOD=method, LOOP_EXPLORATION=exploration)
    return numba.njit(cache=True, nogil=True)(function)


def _loop_function(name: str, **replaced_globals):
    """`_train_loop` as a new Python function named ``name`` whose globals are its module's with
    ``replaced_globals`` in their place (the one loop source behind every compiled copy)."""
    code = _train_loop.__code__.replace(co_name=name, co_qualname=name)
    function = types.FunctionType(code, dict(_train_loop.__globals__, **replaced_globals), name)
    function.__doc__ = _train_loop.__doc__
    return function


#: The compiled loop of one-step learners with constant epsilon-greedy exploration (the paper's learners:
#: every cell of the default grid); see `_train_loop` for its arguments.
train_batch = specialised_loop("train_batch", METHOD_ONE_STEP, EPSILON_GREEDY_CODE)
#: The compiled loop of every other built-in learner (double Q, traces, Dyna, decaying, visit-count and
#: softmax explorations), which reads the update rule and exploration from its arguments.
train_batch_general = specialised_loop("train_batch_general", FROM_ARGUMENTS, FROM_ARGUMENTS)

_USER_KERNELS: dict = {}


def user_train_batch(learner: TabularLearner):
    """The general loop (`_train_loop`) compiled with ``learner.td_target`` in place of the built-in targets.

    The same code object with one global swapped (same arguments); compiled on first use in each
    process (numba cannot disk-cache a loop that calls a function passed in from outside).
    """
    target = learner.td_target
    if target not in _USER_KERNELS:

        def call_target(code, q_next, next_action, reward, gamma, epsilon, terminal):
            return target(q_next, next_action, reward, gamma, epsilon, terminal)

        function = _loop_function(f"train_batch_{learner.name}", builtin_td_target=numba.njit(call_target))
        _USER_KERNELS[target] = numba.njit(nogil=True)(function)
    return _USER_KERNELS[target]


def kernel_for(learner: TabularLearner):
    """The compiled loop that trains ``learner`` (runs ``lo .. hi - 1`` of a batch): its own copy
    for a user's target, else the cached `train_batch` (one-step, constant epsilon-greedy) or
    `train_batch_general`."""
    if learner.target_code == USER_TARGET:
        return user_train_batch(learner)
    if learner.method == METHOD_ONE_STEP and learner.exploration.code == EPSILON_GREEDY_CODE:
        return train_batch
    return train_batch_general


def code_digest(learner: TabularLearner) -> str:
    """SHA-256 (hex) of what makes ``learner`` itself: its TD target's source (a user's target lives
    outside the package, whose own code a cache keys on with
    [`digests.code_digest`][tableclean_suite.bench.digests.code_digest]), name, on-policy flag,
    update rule and [`settings`][tableclean_suite.learners.rules.TabularLearner.settings], so a user
    learner re-registered with another body gets another digest."""
    target = learner.td_target.py_func
    try:
        source = inspect.getsource(target)
    except (OSError, TypeError):
        source = repr((target.__code__.co_code, target.__code__.co_consts))
    text = f"{source}|{learner.name}|{learner.on_policy}|{learner.target_code}|{learner.settings()}"
    return hashlib.sha256(text.encode()).hexdigest()


def _guard_disk_cache() -> None:
    """Recompile the cached kernel when any module it inlines, or whose constants it compiles in (the looping
    codes of [`rewards`][tableclean_suite.rewards], the outcome codes of [`state`][tableclean_suite.task.state]),
    has changed (see [`cache_guard`][tableclean_suite.learners.cache_guard])."""
    import sys

    from tableclean_suite.learners import cache_guard

    modules = [sys.modules[f"tableclean_suite.learners.{name}"]
               for name in ("kernel", "rng", "rules", "exploration", "assist", "optimality")]
    modules += [sys.modules["tableclean_suite.rewards"], sys.modules["tableclean_suite.task.state"]]  # constants
    dispatchers = [value for module in modules for value in vars(module).values()
                   if isinstance(value, numba.core.registry.CPUDispatcher)]
    cache_guard.guard("learners.kernel", dispatchers, modules)


_guard_disk_cache()
