"""The batched, compiled training loop: many independent runs, one step per run per iteration.

This is Algorithm 1 of the paper (with the learner's TD target plugged in),
compiled with numba and parallel over runs.  :mod:`.reference` is the same loop
in plain Python, one step at a time; both draw the same counter-based random
numbers (:mod:`.rng`), so they produce identical arrays.

The loop picks the built-in TD target by an integer code, so :func:`train_batch`
takes no function argument and numba's disk cache (``cache=True``) serves it to every
new process without recompiling.  A user learner's target gets its own compiled copy
of the same loop (:func:`user_train_batch`), built once per process.
"""

from __future__ import annotations

import hashlib
import inspect
import types

import numba

from tableclean_suite.learners.rng import STREAM_EXPLORE, STREAM_RANDOM_ACTION, STREAM_START, STREAM_TRANSITION, uniform
from tableclean_suite.learners.rules import TabularLearner, builtin_td_target, greedy_action
from tableclean_suite.task import Outcome

#: Codes of ``episode_end`` in training records.
EPISODE_CONTINUES, EPISODE_TERMINAL, EPISODE_TRUNCATED = 0, 1, 2
NO_STATE = -1  # no previous state (first step of an episode) / no pending action

_ROUTINE = int(Outcome.ROUTINE)
_INEFFECTIVE = int(Outcome.INEFFECTIVE)
_TERMINAL = int(Outcome.TERMINAL)
_LOOPING_ADD = 2


@numba.njit(cache=True)
def epsilon_greedy(q_row, epsilon, explore_draw, action_draw):
    """Epsilon-greedy action: random (uniform over all actions) when ``explore_draw < epsilon``."""
    if explore_draw < epsilon:
        return min(int(action_draw * q_row.shape[0]), q_row.shape[0] - 1)
    return greedy_action(q_row)


@numba.njit(cache=True)
def sample_index(cumulative, draw):
    """Index k of the first ``cumulative[k] > draw`` (the last index at worst)."""
    k = 0
    while k < cumulative.shape[0] - 1 and draw >= cumulative[k]:
        k += 1
    return k


@numba.njit(cache=True)
def loop_adjusted_reward(reward, outcome, state, next_state, previous_state, loop_value, loop_mode):
    """Apply the looping penalty (r4): routine/ineffective steps to s_{t-1} or staying put."""
    if loop_mode == 0:
        return reward
    if outcome != _ROUTINE and outcome != _INEFFECTIVE:
        return reward
    if next_state != previous_state and next_state != state:
        return reward
    if loop_mode == _LOOPING_ADD:
        return reward + loop_value
    return loop_value


@numba.njit(cache=True, parallel=True)
def train_batch(
    next_state_table,
    outcome_table,
    cumulative_table,
    starts,
    outcome_values,
    loop_value,
    loop_mode,
    target_code,
    on_policy,
    alpha,
    gamma,
    epsilon,
    max_itr,
    keys,
    q,
    rewards,
    outcomes,
    states,
    actions,
    episode_end,
):
    """Train ``len(keys)`` runs for ``rewards.shape[1]`` iterations, in place.

    Args:
        next_state_table, outcome_table: ``(S, A, K)`` int64 successors and outcomes.
        cumulative_table: ``(S, A, K)`` float64 cumulative successor probabilities.
        starts: ``(n_starts,)`` int64 start states, picked uniformly per episode.
        outcome_values: ``(n_outcomes,)`` float64 reward per outcome.
        loop_value, loop_mode: looping penalty and its mode (0 off, 1 replace, 2 add).
        target_code: the built-in learner's target code (``rules.Q_LEARNING_TARGET``, ...);
            ignored by a :func:`user_train_batch` copy, which calls its own target.
        on_policy: choose the next action before the update and take it (SARSA).
        alpha, gamma, epsilon: learning rate, discount, exploration rate.
        max_itr: iterations after which an episode is truncated.
        keys: ``(R,)`` uint64 per-run random keys.
        q: ``(R, S, A)`` float64 Q-tables, updated in place.
        rewards: ``(R, T)`` float64 output, reward of each iteration.
        outcomes, states, actions: ``(R, T)`` int outputs (state before the step), of the
            task model's ``record_dtype`` (int8 for the paper's 24 states).
        episode_end: ``(R, T)`` int output (same dtype), EPISODE_* code after each iteration.
    """
    n_runs, n_iterations = rewards.shape
    n_starts = starts.shape[0]
    n_successors = next_state_table.shape[2]
    for r in numba.prange(n_runs):
        key = keys[r]
        qr = q[r]
        state = NO_STATE
        previous = NO_STATE
        pending = NO_STATE
        length = 0
        for t in range(n_iterations):
            if state == NO_STATE:
                if n_starts == 1:
                    state = starts[0]
                else:
                    state = starts[min(int(uniform(key, t, STREAM_START) * n_starts), n_starts - 1)]
                previous = NO_STATE
                pending = NO_STATE
                length = 0
            if pending != NO_STATE:
                action = pending
            else:
                action = epsilon_greedy(
                    qr[state], epsilon, uniform(key, t, STREAM_EXPLORE), uniform(key, t, STREAM_RANDOM_ACTION)
                )
            k = 0
            if n_successors > 1:
                k = sample_index(cumulative_table[state, action], uniform(key, t, STREAM_TRANSITION))
            nxt = next_state_table[state, action, k]
            outcome = outcome_table[state, action, k]
            reward = loop_adjusted_reward(
                outcome_values[outcome], outcome, state, nxt, previous, loop_value, loop_mode
            )
            length += 1
            terminal = outcome == _TERMINAL
            pending = NO_STATE
            if on_policy and not terminal:
                pending = epsilon_greedy(
                    qr[nxt], epsilon, uniform(key, t + 1, STREAM_EXPLORE), uniform(key, t + 1, STREAM_RANDOM_ACTION)
                )
            target = builtin_td_target(target_code, qr[nxt], pending, reward, gamma, epsilon, terminal)
            qr[state, action] += alpha * (target - qr[state, action])
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
                previous = state
                state = nxt


_USER_KERNELS: dict = {}


def user_train_batch(learner: TabularLearner):
    """:func:`train_batch` compiled with ``learner.td_target`` in place of the built-in targets.

    The same code object with one global swapped, so the loop is written once; compiled
    on first use in each process (not disk-cached: numba cannot cache a loop that calls
    a function passed in from outside).
    """
    target = learner.td_target
    if target not in _USER_KERNELS:

        def call_target(code, q_next, next_action, reward, gamma, epsilon, terminal):
            return target(q_next, next_action, reward, gamma, epsilon, terminal)

        source = train_batch.py_func
        namespace = dict(source.__globals__, builtin_td_target=numba.njit(call_target))
        function = types.FunctionType(source.__code__, namespace, f"train_batch_{learner.name}")
        _USER_KERNELS[target] = numba.njit(parallel=True)(function)
    return _USER_KERNELS[target]


def kernel_for(learner: TabularLearner):
    """The compiled loop that trains ``learner``: the cached built-in one or its own copy."""
    from tableclean_suite.learners.rules import USER_TARGET

    return user_train_batch(learner) if learner.target_code == USER_TARGET else train_batch


def code_digest(learner: TabularLearner) -> str:
    """SHA-256 (hex) of the code that turns a task and a seed into ``learner``'s records.

    Covers this loop, the random numbers, the rules module (built-in targets, greedy
    choice) and the learner's own target source and on-policy flag, so a cache keyed on
    it retrains when any of them changes (e.g. a user learner re-registered with another body).
    """
    from tableclean_suite.learners import rng, rules

    digest = hashlib.sha256()
    for module in (rng, rules):
        digest.update(inspect.getsource(module).encode())
    digest.update(inspect.getsource(train_batch.py_func).encode())
    digest.update(inspect.getsource(loop_adjusted_reward.py_func).encode())
    digest.update(inspect.getsource(epsilon_greedy.py_func).encode())
    target = learner.td_target.py_func
    try:
        digest.update(inspect.getsource(target).encode())
    except (OSError, TypeError):
        digest.update(repr((target.__code__.co_code, target.__code__.co_consts)).encode())
    digest.update(f"{learner.name}|{learner.on_policy}|{learner.target_code}".encode())
    return digest.hexdigest()
