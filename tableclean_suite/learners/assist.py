"""Cruz et al.'s assisted learners: contextual affordances and a simulated advisor.

**Affordances** (``TabularLearner.affordance``): an action predicted to lead to a failed
state is not taken, neither greedily nor when exploring.

==================== ==========================================================================
``none``             every action is afforded (the paper's learners)
``given``            the task model's affordances: ``TaskModel.action_mask`` (improper actions
                     are never afforded)
``learned``          learned from the run's own experience: every action is afforded until
                     it is observed to be improper (outcome IMPROPER) in a state; from then
                     on it is not afforded in that state
==================== ==========================================================================

With affordances the greedy action, a random action (the same two main-lane draws), softmax and
the Q-learning target's max all run over the state's afforded actions (all actions where none is).

**Advice** (``advice_probability`` L, ``advice_consistency`` C, both in [0, 1]): before the
learner chooses an action, a simulated advisor advises with probability L; its advice is its own
policy's action with probability C, else an action drawn uniformly over all actions; the learner
takes the advice.  The advisor's policy ([`advisor_policy`][tableclean_suite.learners.assist.advisor_policy]) is the optimal policy of the
task model: in each state, the first action of a shortest plan to a terminal state that takes no
improper action (ties to the first action in the task's order).  Its draws come from the side
lane ``LANE_ADVICE`` ([`rng`][tableclean_suite.learners.rng]), counted by the iteration at which the action is taken, so the
main lane's four streams are unchanged.

The compiled functions here run in [`kernel`][tableclean_suite.learners.kernel]'s loop.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from tableclean_suite.learners.exploration import epsilon_greedy, greedy_action
from tableclean_suite.learners.rng import STREAM_ADVICE_ACTION, STREAM_ADVISE, STREAM_CONSISTENT, uniform

#: Affordance codes (``TabularLearner.affordance_code``) and their names.
AFFORD_NONE, AFFORD_GIVEN, AFFORD_LEARNED = 0, 1, 2
AFFORDANCES = {"none": AFFORD_NONE, "given": AFFORD_GIVEN, "learned": AFFORD_LEARNED}
#: The advisor gives no advice (this iteration, or in a state where it has no action).
NO_ADVICE = -1
#: Indices of the advice parameter array ([`TabularLearner.advice_parameters`][tableclean_suite.learners.rules.TabularLearner.advice_parameters]).
P_ADVICE, P_CONSISTENCY = 0, 1
N_ADVICE_PARAMETERS = 2
#: Mask entries: afforded (1) or not (0), int8.
AFFORDED, NOT_AFFORDED = 1, 0


# compiled: choices restricted to afforded actions, the advisor's action
@numba.njit(cache=True)
def afforded_count(mask_row):
    """Number of afforded actions in ``mask_row`` (``(n_actions,)`` int8, 1 = afforded)."""
    n = 0
    for a in range(mask_row.shape[0]):
        if mask_row[a] != NOT_AFFORDED:
            n += 1
    return n


@numba.njit(cache=True)
def afforded_greedy(q_row, mask_row):
    """The afforded action of largest ``q_row`` value (ties to the first); all actions when none is afforded."""
    best = -1
    for a in range(q_row.shape[0]):
        if mask_row[a] != NOT_AFFORDED and (best < 0 or q_row[a] > q_row[best]):
            best = a
    if best < 0:
        return greedy_action(q_row)
    return best


@numba.njit(cache=True)
def afforded_epsilon_greedy(q_row, mask_row, epsilon, explore_draw, action_draw):
    """Epsilon-greedy over the afforded actions: uniform over them when ``explore_draw < epsilon``."""
    n = afforded_count(mask_row)
    if n == 0:
        return epsilon_greedy(q_row, epsilon, explore_draw, action_draw)
    if explore_draw < epsilon:  # the k-th afforded action
        k = min(int(action_draw * n), n - 1)
        for a in range(mask_row.shape[0]):
            if mask_row[a] != NOT_AFFORDED:
                if k == 0:
                    return a
                k -= 1
    return afforded_greedy(q_row, mask_row)


@numba.njit(cache=True)
def afforded_softmax(q_row, mask_row, temperature, draw):
    """Boltzmann choice at ``temperature`` (> 0) over the afforded actions, picked by ``draw`` in [0, 1)."""
    best = q_row[afforded_greedy(q_row, mask_row)]
    n = afforded_count(mask_row)
    total = 0.0
    for a in range(q_row.shape[0]):
        if n == 0 or mask_row[a] != NOT_AFFORDED:
            total += math.exp((q_row[a] - best) / temperature)
    threshold = draw * total
    running = 0.0
    last = 0
    for a in range(q_row.shape[0]):
        if n == 0 or mask_row[a] != NOT_AFFORDED:
            running += math.exp((q_row[a] - best) / temperature)
            last = a
            if threshold < running:
                return a
    return last


@numba.njit(cache=True)
def afforded_max_target(q_next, mask_row, reward, gamma, terminal):
    """Q-learning's target with the max over afforded actions: ``r + gamma * max_{a afforded} Q(s', a)``."""
    if terminal:
        return reward
    return reward + gamma * q_next[afforded_greedy(q_next, mask_row)]


@numba.njit(cache=True)
def advice_action(advisor, advice, advice_key, iteration, state, n_actions):
    """The advisor's action for ``state`` at ``iteration``, or ``NO_ADVICE``.

    Args:
        advisor: ``(S,)`` int64 the advisor's action per state (``NO_ADVICE`` where it has none).
        advice: ``(N_ADVICE_PARAMETERS,)`` float64 ``[L, C]``, each in [0, 1].
        advice_key: the run's ``LANE_ADVICE`` key.
        iteration: the run's iteration (>= 0) at which the action is taken.
        n_actions: the task's number of actions (random advice is uniform over them).
    """
    if uniform(advice_key, iteration, STREAM_ADVISE) >= advice[P_ADVICE]:
        return NO_ADVICE
    own = advisor[state]
    if own == NO_ADVICE:
        return NO_ADVICE
    if uniform(advice_key, iteration, STREAM_CONSISTENT) < advice[P_CONSISTENCY]:
        return own
    return min(int(uniform(advice_key, iteration, STREAM_ADVICE_ACTION) * n_actions), n_actions - 1)


@numba.njit(cache=True)
def run_masks(afforded, affordance, n_states, n_actions):
    """One run's affordance masks ``(S, A)`` int8: the shared given table, or all-afforded for ``learned``."""
    if affordance == AFFORD_LEARNED:
        return np.ones((n_states, n_actions), dtype=np.int8)
    return afforded


# plain Python: the given affordances and the advisor, from the task model
def given_affordances(model) -> np.ndarray:
    """``(S, A)`` int8 the task model's affordances: ``model.action_mask`` per state (1 = afforded).
    Terminal states (where no action is ever taken) are all-afforded, so no row is empty."""
    from tableclean_suite.task import Outcome

    return (model.transition_arrays()[1] != int(Outcome.IMPROPER)).astype(np.int8)


def advisor_policy(model) -> np.ndarray:
    """``(S,)`` int64 the optimal advisor: [`TaskModel.optimal_policy`][tableclean_suite.task.model.TaskModel.optimal_policy]
    (the first action of a shortest plan, which takes no improper action) where a terminal state is
    reachable, ``NO_ADVICE`` where none is."""
    return np.where(model.distances_to_terminal() >= 0, model.optimal_policy(), NO_ADVICE).astype(np.int64)


def assistance_arrays(learner, model) -> tuple[np.ndarray, np.ndarray]:
    """The kernel's ``afforded`` ``(S, A)`` int8 (the model's affordances when ``learner`` uses them
    given, else ``(0, 0)``) and ``advisor`` ``(S,)`` int64 (the optimal advisor when it is advised,
    else ``(0,)``)."""
    afforded = given_affordances(model) if learner.affordance_code == AFFORD_GIVEN else np.zeros((0, 0), np.int8)
    return afforded, advisor_policy(model) if learner.advised else np.zeros(0, dtype=np.int64)
