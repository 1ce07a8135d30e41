"""Exact analysis of policies on the task: success probabilities by dynamic programming.

The paper's ~84 % success plateau is the chance that epsilon-greedy exploration
avoids every improper action on the way to the terminal state.  Here that
chance is computed exactly, for any policy, over the model (or a measured
transition table), so learners' measured plateaus can be checked against it.

With an exploration other than constant epsilon-greedy (``exploration=``), the policy
evaluated is the exploration's *final* action distribution: the one that would pick the
action at iteration ``iteration`` (pass the training's ``iterations``, the step after the
last one) from the final Q-tables, i.e. epsilon (or the temperature) of that iteration,
per-state epsilon from the visits counted over the whole training (``visit_decay``), or
the softmax of the final Q-table.  :func:`final_behaviour` reads these from a training result.
"""

from __future__ import annotations

import numpy as np

from tableclean_suite.learners.exploration import EpsilonGreedy, VisitDecay, as_exploration, softmax_probabilities
from tableclean_suite.learners.transitions import TransitionTable
from tableclean_suite.task import Outcome, TaskModel, TaskState


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


def visit_counts(states: np.ndarray, n_states: int) -> np.ndarray:
    """Iterations spent in each state: ``(R, T)`` recorded states -> ``(R, n_states)`` int64."""
    states = np.atleast_2d(np.asarray(states, dtype=np.int64))
    counts = np.zeros((states.shape[0], n_states), dtype=np.int64)
    for run, row in enumerate(states):
        counts[run] = np.bincount(row, minlength=n_states)
    return counts


def final_behaviour(result) -> dict:
    """The keyword arguments of :func:`exact_success_probability` that describe ``result``'s final
    behaviour policy: ``exploration``, ``q`` (final Q-tables), ``iteration`` (= its iterations)
    and ``visits`` (per run and state, over the whole training).

    ``result`` is a :class:`~tableclean_suite.learners.TrainingResult`; pass ``epsilon`` and
    ``max_itr`` from its ``config`` alongside.
    """
    settings = result.config.get("learner_settings", {})
    return {
        "exploration": as_exploration(settings.get("exploration")),
        "q": result.q,
        "iteration": result.iterations,
        "visits": visit_counts(result.states, result.q.shape[-2]),
    }


def behaviour_probabilities(policy, epsilon, n_actions, exploration=None, q=None, iteration=None, visits=None):
    """The action distribution ``(R, S, A)`` evaluated by :func:`exact_success_probability` (see there)."""
    exploration = as_exploration(exploration)
    if q is not None:
        q = np.asarray(q, dtype=np.float64)
        q = q[None] if q.ndim == 2 else q
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
    return action_probabilities(policy, exploration.parameter_array(float(epsilon), iteration or 0, counts), n_actions)


def exact_success_probability(
    policy: np.ndarray | None,
    epsilon: float,
    max_itr: int,
    model: TaskModel | None = None,
    table: TransitionTable | None = None,
    starts: list[TaskState] | None = None,
    exploration=None,
    q: np.ndarray | None = None,
    iteration: int | None = None,
    visits: np.ndarray | None = None,
) -> np.ndarray:
    """Probability that an episode succeeds (terminal within ``max_itr`` steps, no improper action).

    Args:
        policy: greedy action per state, shape ``(S,)`` or ``(R, S)`` for R policies (S = ``model.n_states``);
            may be ``None`` when ``q`` is given (its greedy actions).
        epsilon: exploration rate in [0, 1] (random actions uniform over the task's actions);
            the start value of an epsilon schedule.
        max_itr: episode length limit (>= 1).
        model: the task model (rules and start states); default ``TaskModel()``.
        table: transitions to use instead of the model's (e.g. calibrated).
        starts: start states (default the model's), weighted uniformly.
        exploration: the behaviour policy (name, :class:`~tableclean_suite.learners.exploration.Exploration`
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
    if int(max_itr) != max_itr or max_itr < 1:
        raise ValueError(f"max_itr must be an integer >= 1, got {max_itr!r}")
    model = model if model is not None else TaskModel()
    table = table if table is not None else TransitionTable.from_model(model)
    starts = starts if starts is not None else model.start_states()
    single = (policy is not None and np.ndim(policy) == 1) or (policy is None and q is not None and np.ndim(q) == 2)
    pi = behaviour_probabilities(policy, epsilon, model.n_actions, exploration, q, iteration, visits)  # (R, S, A)
    if pi.shape[-2] != model.n_states:
        raise ValueError(f"policy has {pi.shape[-2]} states; task {model.spec.name!r} has {model.n_states}")
    table.check_model(model)
    probability = np.diff(table.cumulative, axis=2, prepend=0.0)  # (S, A, K)
    safe = probability * (table.outcome != Outcome.IMPROPER)
    finishing = (safe * (table.outcome == Outcome.TERMINAL)).sum(axis=2)  # (S, A)
    continuing = safe * (table.outcome != Outcome.TERMINAL)  # (S, A, K)
    value = np.zeros(pi.shape[:2])  # P(success within k steps), k = 0
    for _ in range(int(max_itr)):
        future = (continuing[None] * value[:, table.next_state]).sum(axis=3)  # (R, S, A)
        updated = (pi * (finishing[None] + future)).sum(axis=2)
        if np.array_equal(updated, value):
            break
        value = updated
    codes = [s.index for s in starts]
    result = value[:, codes].mean(axis=1)
    return result[0] if single else result
