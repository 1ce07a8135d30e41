"""When a run has learned the task: its greedy policy follows a shortest plan from every start.

The greedy policy is the action the training loop takes when it does not explore (double Q: on
the average of its two tables; afforded actions only with affordances; ties to the first action
or, with ``ties="random"``, any tied one).  It is *optimal* when every state on its paths from the
start states is one step nearer the terminal state after its greedy action(s) in the task model's
transitions ([`TaskModel.distances_to_terminal`][tableclean_suite.task.model.TaskModel.distances_to_terminal]),
even for a run trained on a calibrated table.  The training loop checks it before its first step
and after every Q update, walking again ([`greedy_walk`][tableclean_suite.learners.optimality.greedy_walk],
O(visited x A)) only when [`walk_changed`][tableclean_suite.learners.optimality.walk_changed] (O(A)), and
records ``first_learned_at`` and ``learned_at``
([`TrainingResult`][tableclean_suite.learners.train.TrainingResult]).
"""

from __future__ import annotations

import numba
import numpy as np

from tableclean_suite.learners.assist import NOT_AFFORDED, afforded_count, afforded_greedy
from tableclean_suite.learners.exploration import greedy_action

#: ``learned_at`` / ``first_learned_at`` of a run that is not optimal at the end of its budget / never is.
NOT_LEARNED = -1


@numba.njit(cache=True)
def tied_greedy(q_row, masks, state, affording, draw):
    """Uniformly one of the actions of largest ``q_row`` value, picked by ``draw`` in [0, 1).

    With ``affording`` only afforded actions of ``masks[state]`` count (all actions when none
    is afforded), as [`afforded_greedy`][tableclean_suite.learners.assist.afforded_greedy].
    """
    n_actions = q_row.shape[0]
    restrict = affording and afforded_count(masks[state]) > 0
    best = -np.inf
    count = 0
    for a in range(n_actions):
        if restrict and masks[state, a] == NOT_AFFORDED:
            continue
        if count == 0 or q_row[a] > best:
            best = q_row[a]
            count = 1
        elif q_row[a] == best:
            count += 1
    k = min(int(draw * count), count - 1)
    for a in range(n_actions):
        if restrict and masks[state, a] == NOT_AFFORDED:
            continue
        if q_row[a] == best:
            if k == 0:
                return a
            k -= 1
    return n_actions - 1


@numba.njit(cache=True, inline="always")
def behaviour_row(q_a, q_b, state, double, row):
    """The Q row the policy acts on: ``q_a[state]``, or for double Q ``(q_a + q_b) / 2`` written into ``row``."""
    if not double:
        return q_a[state]
    for a in range(row.shape[0]):
        row[a] = (q_a[state, a] + q_b[state, a]) * 0.5
    return row


@numba.njit(cache=True, inline="always")
def first_greedy(q_row, masks, state, affording):
    """The greedy action under ``ties="first"`` (afforded actions only when ``affording``)."""
    if affording:
        return afforded_greedy(q_row, masks[state])
    return greedy_action(q_row)


@numba.njit(cache=True)
def greedy_walk(q_a, q_b, double, row, masks, affording, random_ties, starts, model_next, distance,
                walked, on_walk, choice, n_walked):
    """Walk the greedy paths from every start; returns ``(optimal, states examined)``.

    The walk stops at the first state whose greedy action is not one step nearer the terminal
    state; ``walked[:examined]`` are then exactly the states whose rows decided the verdict.

    Args:
        q_a, q_b: ``(S, A)`` the run's Q-table(s); the policy acts on ``q_a``, or for double Q
            on ``(q_a + q_b) / 2`` (written into ``row``, ``(A,)``).
        masks: ``(S, A)`` int8 affordance masks (read only when ``affording``).
        random_ties: the greedy choice is uniform among tied actions (every one is followed).
        starts: ``(n_starts,)`` int64 start states.
        model_next: ``(S, A)`` int64 the task model's successors.
        distance: ``(S,)`` int64 shortest-plan lengths (0 terminal, -1 no plan).
        walked, on_walk, choice: ``(S,)`` working arrays: the examined states (first
            ``n_walked`` from the last walk, replaced by this one's), whether a state is among
            them, and the greedy action the walk took there (``ties="first"``).
        n_walked: how many states the last walk examined.
    """
    for i in range(n_walked):
        on_walk[walked[i]] = False
    n = 0
    for i in range(starts.shape[0]):
        s = starts[i]
        if not on_walk[s]:
            on_walk[s] = True
            walked[n] = s
            n += 1
    head = 0
    optimal = True
    while head < n:
        s = walked[head]
        head += 1
        here = distance[s]
        if here == 0:
            continue
        q_row = behaviour_row(q_a, q_b, s, double, row)
        if random_ties:  # every tied greedy action must lead one step nearer
            best = q_row[tied_greedy(q_row, masks, s, affording, 0.0)]
            restrict = affording and afforded_count(masks[s]) > 0
            for a in range(q_row.shape[0]):
                if q_row[a] != best or (restrict and masks[s, a] == NOT_AFFORDED):
                    continue
                nxt = model_next[s, a]
                if here < 0 or distance[nxt] != here - 1:
                    optimal = False
                    break
                if distance[nxt] > 0 and not on_walk[nxt]:
                    on_walk[nxt] = True
                    walked[n] = nxt
                    n += 1
            if not optimal:
                break
        else:
            action = first_greedy(q_row, masks, s, affording)
            choice[s] = action
            nxt = model_next[s, action]
            if here < 0 or distance[nxt] != here - 1:
                optimal = False
                break
            if distance[nxt] > 0 and not on_walk[nxt]:
                on_walk[nxt] = True
                walked[n] = nxt
                n += 1
    if not optimal:
        for i in range(head, n):
            on_walk[walked[i]] = False
        n = head
    return optimal, n


@numba.njit(cache=True)
def walk_changed(q_a, q_b, double, row, masks, affording, random_ties, state, on_walk, choice):
    """Whether an update of ``state``'s row (or mask) can change the last walk's verdict: the
    state was examined and its greedy action differs from the walk's (under random ties: it was
    examined)."""
    if not on_walk[state]:
        return False
    if random_ties:
        return True
    return first_greedy(behaviour_row(q_a, q_b, state, double, row), masks, state, affording) != choice[state]


def task_arrays(model) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(starts (n,), model_next (S, A), distance (S,))`` int64: what the walk needs of ``model``
    (a [`TaskModel`][tableclean_suite.task.model.TaskModel])."""
    starts = np.array([s.index for s in model.start_states()], dtype=np.int64)
    return starts, np.ascontiguousarray(model.transition_arrays()[0]), model.distances_to_terminal()
