"""One run trained one step at a time from Python, for step environments the compiled loop cannot call.

[`train_run`][tableclean_suite.learners.stepper.train_run] is the loop of
[`kernel`][tableclean_suite.learners.kernel] driven from Python: each step calls the kernel's own
compiled pieces (behaviour, looping rule, TD targets, update rules, the optimality walk), so on a
table it gives the compiled loop's arrays bit for bit.  It steps any object with a ``model``
([`TaskModel`][tableclean_suite.task.model.TaskModel]), ``reset(draw) -> state`` and
``step(state, action, draw) -> (next_state, outcome)`` (codes, ``draw`` uniform in [0, 1)):
a transition table ([`TableStepEnv`][tableclean_suite.learners.stepper.TableStepEnv],
``train(engine="reference")``) or skills in MuJoCo (the physics backend).
"""

from __future__ import annotations

import numpy as np

from tableclean_suite.backends import CHECKPOINT_Q
from tableclean_suite.learners import assist, kernel as k, optimality
from tableclean_suite.learners.exploration import EPSILON_GREEDY_CODE, SOFTMAX_CODE, exploration_parameter
from tableclean_suite.learners.rng import (LANE_ADVICE, LANE_LEARNER, LANE_PLANNING, LANE_TIES, STREAM_DOUBLE_TABLE,
                                           STREAM_START, STREAM_TRANSITION, lane_key, run_key, uniform)
from tableclean_suite.learners.rules import (EXPECTED_SARSA_TARGET, METHOD_DOUBLE_Q, METHOD_DYNA, METHOD_TRACES,
                                             Q_LEARNING_TARGET, TIES, TIES_RANDOM, USER_TARGET, builtin_td_target)
from tableclean_suite.task import Outcome

#: Key of double Q-learning's two tables in a record / ``TrainingResult.info``: ``(..., 2, S, A)``.
DOUBLE_Q_TABLES = "double_q_tables"
RECORD_FIELDS = ("rewards", "outcomes", "states", "actions", "episode_end")


class TableStepEnv:
    """A [`TransitionTable`][tableclean_suite.learners.transitions.TransitionTable] of ``model`` as a step environment."""

    def __init__(self, model, table):
        self.model, self.table = model, table

    def reset(self, draw: float) -> int:
        return self.model.sample_start(draw).index

    def step(self, state: int, action: int, draw: float) -> tuple[int, int]:
        return self.table.sample(state, action, draw)


def train_run(env, learner, reward, iterations: int, alpha: float, gamma: float, epsilon: float, max_itr: int,
              seed: int, run: int, on_step=None, checkpoint: int = 0) -> dict[str, np.ndarray]:
    """Train run ``run`` (key of ``(seed, run)``) of ``learner`` on ``env`` for ``iterations`` steps.

    ``learner`` is a configured [`TabularLearner`][tableclean_suite.learners.rules.TabularLearner]
    (``epsilon`` is its exploration's start value), ``reward`` a
    [`RewardPattern`][tableclean_suite.rewards.RewardPattern].  ``on_step(t)`` is called after every
    iteration; ``checkpoint`` in [1, iterations] also keeps the Q-table after that many iterations.

    Returns:
        ``rewards`` ``(T,)`` float64; ``outcomes``, ``states``, ``actions``, ``episode_end`` ``(T,)`` of
        ``env.model.record_dtype``; ``q`` ``(S, A)`` float64 (double Q: the average of its tables, both
        under ``"double_q_tables"`` ``(2, S, A)``); ``"checkpoint_q"`` ``(S, A)`` with a checkpoint;
        ``first_learned_at`` and ``learned_at``, int64 0-d ([`optimality`][tableclean_suite.learners.optimality]).
    """
    model = env.model
    n_states, n_actions = model.n_states, model.n_actions
    key = np.uint64(run_key(seed, run))
    side_key, planning_key, advice_key, tie_key = (np.uint64(lane_key(key, lane)) for lane in (
        LANE_LEARNER, LANE_PLANNING, LANE_ADVICE, LANE_TIES))
    method, code = learner.method, learner.exploration.code
    double, traced, modelling = method == METHOD_DOUBLE_Q, method == METHOD_TRACES, method == METHOD_DYNA
    affording, random_ties = learner.affordance_code != assist.AFFORD_NONE, TIES[learner.ties] == TIES_RANDOM
    plain = code == EPSILON_GREEDY_CODE and not double and not affording and not random_ties
    user_target = learner.target_code == USER_TARGET
    afforded_max = affording and learner.target_code == Q_LEARNING_TARGET
    softmax_expected = code == SOFTMAX_CODE and learner.target_code == EXPECTED_SARSA_TARGET
    parameters, explore = learner.kernel_parameters(), learner.exploration.kernel_parameters(epsilon)
    decay, planning_steps = gamma * parameters[k.PARAM_LAMBDA], int(parameters[k.PARAM_PLANNING])
    accumulate = parameters[k.PARAM_ACCUMULATE] != 0.0
    afforded, advisor = assist.assistance_arrays(learner, model)
    advice = learner.advice_parameters()
    masks = assist.run_masks(afforded, learner.affordance_code, n_states, n_actions)
    q = np.full((n_states, n_actions), learner.q_init)
    q_b = np.full((n_states, n_actions) if double else (0, 0), learner.q_init)
    (row, visits, traces, pairs, model_next, model_reward, model_terminal, observed, walked, on_walk, choice,
     entered) = k.run_memory(n_states, n_actions, double, traced, code == k.VISIT_DECAY_CODE, modelling)
    starts, task_next, distance = optimality.task_arrays(model)
    values = reward.outcome_values()
    loop_value = 0.0 if reward.looping_penalty is None else reward.looping_penalty

    def tables() -> np.ndarray:
        return (q + q_b) * k.HALF if double else q.copy()

    def act(state: int, t: int) -> int:
        return int(k.act(q, q_b, row, state, plain, double, code, explore, key, t, visits, learner.affordance_code,
                         masks, advisor, advice, advice_key, random_ties, tie_key))

    walked_count = [np.int64(0)]  # the last walk's examined states, which the next walk unmarks

    def walk() -> bool:
        optimal, walked_count[0] = k.greedy_walk(q, q_b, double, row, masks, affording, random_ties, starts, task_next,
                                                 distance, walked, on_walk, choice, walked_count[0])
        return optimal

    record = {name: np.zeros(iterations, dtype=np.float64 if name == "rewards" else model.record_dtype)
              for name in RECORD_FIELDS}
    optimal = walk()
    first, last_not_optimal = (0, -1) if optimal else (optimality.NOT_LEARNED, 0)
    state = pending = k.NO_STATE
    n_pairs = n_observed = np.int64(0)
    length = episode_start = 0
    for t in range(iterations):
        if state == k.NO_STATE:
            state, pending, length, episode_start = env.reset(uniform(key, t, STREAM_START)), k.NO_STATE, 0, t
            if traced:
                n_pairs = k.clear_traces(traces, pairs, n_pairs)
        action = pending if pending != k.NO_STATE else act(state, t)
        nxt, outcome = env.step(state, action, uniform(key, t, STREAM_TRANSITION))
        entered[state] = t
        r = k.memory_adjusted_reward(values[outcome], outcome, nxt, entered, t, episode_start, reward.looping_memory,
                                     loop_value, reward.looping_code)
        length += 1
        terminal = outcome == Outcome.TERMINAL
        if visits.shape[0]:
            visits[state] += 1
        if learner.affordance_code == assist.AFFORD_LEARNED and outcome == Outcome.IMPROPER:
            masks[state, action] = assist.NOT_AFFORDED
        pending = act(nxt, t + 1) if (learner.on_policy or traced) and not terminal else k.NO_STATE
        if double:
            k.double_q_update(q, q_b, state, action, nxt, r, alpha, gamma, terminal,
                              uniform(side_key, t, STREAM_DOUBLE_TABLE))
        else:
            behaviour = exploration_parameter(code, explore, t + 1, k.visit_count(visits, nxt))
            if softmax_expected:
                target = k.softmax_expected_sarsa_target(q[nxt], r, gamma, behaviour, terminal)
            elif afforded_max:
                target = assist.afforded_max_target(q[nxt], masks[nxt], r, gamma, terminal)
            elif user_target:
                target = learner.td_target(q[nxt], pending, r, gamma, behaviour, terminal)
            else:
                target = builtin_td_target(learner.target_code, q[nxt], pending, r, gamma, behaviour, terminal)
            if traced:
                cut = (not learner.on_policy) and pending != k.NO_STATE and k.is_exploratory(q[nxt], pending)
                n_pairs = k.trace_update(q, traces, pairs, n_pairs, state, action, target - q[state, action], alpha,
                                         decay, accumulate, cut)
            else:
                q[state, action] += alpha * (target - q[state, action])
            if modelling:
                n_observed = k.remember(model_next, model_reward, model_terminal, observed, n_observed, state, action,
                                        nxt, r, terminal)
                k.plan(q, model_next, model_reward, model_terminal, observed, n_observed, planning_key, t,
                       planning_steps, alpha, gamma)
        for name, value in zip(RECORD_FIELDS, (r, outcome, state, action)):
            record[name][t] = value
        if terminal or length >= max_itr:
            record["episode_end"][t] = k.EPISODE_TERMINAL if terminal else k.EPISODE_TRUNCATED
            state = k.NO_STATE
        else:
            record["episode_end"][t] = k.EPISODE_CONTINUES
            state = nxt
        optimal = walk()
        if not optimal:
            last_not_optimal = t + 1
        elif first == optimality.NOT_LEARNED:
            first = t + 1
        if t + 1 == checkpoint:
            record[CHECKPOINT_Q] = tables()
        if on_step is not None:
            on_step(t)
    record["q"] = tables()
    if double:
        record[DOUBLE_Q_TABLES] = np.stack((q, q_b))
    record["first_learned_at"] = np.int64(first)
    record["learned_at"] = np.int64(last_not_optimal + 1 if optimal else optimality.NOT_LEARNED)
    return record
