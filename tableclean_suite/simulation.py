"""Simulated asymptotes: a Monte Carlo estimate of what a run's final policy scores, with its error.

Where the exact DP ([tableclean_suite.asymptotes][]) would take hours (millions of states), the
same quantities are estimated from ``episodes`` episodes of each policy, played on the task's
table exactly as ``train()`` plays them (looping rules of any memory included, so ``r4_cycle``
gets an average reward too), each with its Monte Carlo standard error.

**Random numbers** ([tableclean_suite.learners.rng][]): run ``r`` draws from side lane
``LANE_SIMULATION`` of its run key, at counter ``e * (2 * max_itr + 1)`` for episode ``e``'s start
state and ``+ 1 + 2 j`` / ``+ 2 + 2 j`` for step ``j``'s action and successor: an estimate depends
on (seed, run, policy) alone, and a run's final and checkpoint policies share their draws.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from tableclean_suite.asymptotes import QUANTITIES, Asymptotes
from tableclean_suite.executors.base import check_count
from tableclean_suite.learners.kernel import memory_adjusted_reward, sample_index
from tableclean_suite.learners.rng import LANE_SIMULATION, lane_key_py, run_key, uniform_at
from tableclean_suite.learners.transitions import TransitionTable
from tableclean_suite.rewards import LOOPING_OFF, get_reward_pattern
from tableclean_suite.task import Outcome

#: Episodes simulated per run by default: a success estimate's standard error is at most
#: 0.5 / sqrt(1000) = 0.016 per run, 0.016 / sqrt(R) for the mean of R runs.
SIMULATED_EPISODES = 1000
#: Simulated learner steps per second, and policy entries per second of preparing a policy's
#: cumulative probabilities, assumed by cost estimates.
SIMULATED_STEPS_PER_SECOND = 20_000_000
POLICY_ENTRIES_PER_SECOND = 50_000_000
#: Bytes per state of a simulation (its state clock) and per (state, action) of a policy given as
#: probabilities (the probabilities and their cumulative rows).
SIMULATION_BYTES_PER_STATE = 8
POLICY_BYTES_PER_ENTRY = 16

_TERMINAL = int(Outcome.TERMINAL)
_IMPROPER = int(Outcome.IMPROPER)


@dataclass(frozen=True)
class StepTable:
    """What a simulated episode reads: the stepped table, the reward pattern and the starts.

    Attributes:
        next_state, outcome: ``(S, A, K)`` integer successor states and `Outcome`
            codes of the table (the model's own, or a measured one).
        cumulative: ``(S, A, K)`` float64 cumulative successor probabilities (last one 1.0).
        values: ``(len(Outcome),)`` float64 reward of each outcome.
        loop_mode: the pattern's looping code (0 off, 1 replace, 2 add); ``loop_value`` its penalty.
        loop_memory: states the looping rule looks back (``RewardPattern.looping_memory``; 0: the episode).
        starts: ``(n_starts,)`` int64 start states, drawn uniformly.
        episodes: episodes simulated per policy, an integer >= 2.
    """

    next_state: np.ndarray
    outcome: np.ndarray
    cumulative: np.ndarray
    values: np.ndarray
    loop_mode: int
    loop_value: float
    loop_memory: int
    starts: np.ndarray
    episodes: int = SIMULATED_EPISODES

    @classmethod
    def build(cls, model, reward, table: TransitionTable | None = None,
              episodes: int = SIMULATED_EPISODES) -> "StepTable":
        """The step table of ``model`` (a `TaskModel`) under ``reward`` (a
        pattern or its registered name), stepping ``table`` (default: the model's own); ``episodes``
        per policy (an integer >= 2: a standard error needs two)."""
        check_count("episodes", episodes, 2)
        pattern = get_reward_pattern(reward)
        table = table if table is not None else TransitionTable.from_model(model)
        table.check_model(model)
        starts = np.array([s.index for s in model.start_states()], dtype=np.int64)
        penalty = 0.0 if pattern.looping_code == LOOPING_OFF else float(pattern.looping_penalty)
        return cls(table.next_state, table.outcome, table.cumulative, pattern.outcome_values(),
                   int(pattern.looping_code), penalty, int(pattern.looping_memory), starts, int(episodes))


def simulation_keys(seed: int, first_run: int, runs: int) -> np.ndarray:
    """``(runs,)`` uint64 keys of runs ``first_run .. first_run + runs - 1`` of a training with ``seed``:
    side lane ``LANE_SIMULATION`` of each run's key."""
    return np.array([lane_key_py(run_key(int(seed), int(first_run) + r), LANE_SIMULATION) for r in range(int(runs))],
                    dtype=np.uint64)


@numba.njit(cache=True)
def _simulate(policy_cumulative, q, epsilon, keys, next_state, outcome, cumulative, values, loop_mode, loop_value,
              loop_memory, starts, max_itr, episodes, entered, totals):
    """Plays ``episodes`` episodes of each policy; ``totals[p, j]`` gets the sum (``[..., 0]``) and
    the sum of squares (``[..., 1]``) over them of quantity ``j`` (success, terminal, return /
    length, length).

    A policy is row ``p`` of ``policy_cumulative`` ``(P, S, A)`` or, when ``q`` is not empty,
    epsilon-greedy on ``q[p]``, its cumulative row computed (the same bits as `_cumulative_rows`)
    only in visited states.  ``entered`` ``(S,)`` int64 scratch: when each state was last entered."""
    n_successors = cumulative.shape[2]
    n_starts = starts.shape[0]
    n_actions = next_state.shape[1]
    from_q = q.shape[0] > 0
    row = np.empty(n_actions)
    share = epsilon / n_actions
    top = 1.0 - epsilon + share
    stride = 2 * max_itr + 1
    for p in range(keys.shape[0]):
        key = keys[p]
        entered[:] = -1
        t = 0  # the run's step counter over its episodes (the looping memory's clock)
        for e in range(episodes):
            base = e * stride
            state = starts[min(int(uniform_at(key, base) * n_starts), n_starts - 1)]
            episode_start = t
            total = 0.0
            clean = 1.0
            ended = 0.0
            length = 0
            for j in range(max_itr):
                if from_q:
                    values_q = q[p, state]
                    greedy = 0
                    for a in range(1, n_actions):
                        if values_q[a] > values_q[greedy]:
                            greedy = a
                    running = 0.0
                    for a in range(n_actions):
                        running += top if a == greedy else share
                        row[a] = running
                    for a in range(n_actions):
                        row[a] /= running
                    row[n_actions - 1] = 1.0
                    action = sample_index(row, uniform_at(key, base + 1 + 2 * j))
                else:
                    action = sample_index(policy_cumulative[p, state], uniform_at(key, base + 1 + 2 * j))
                k = 0
                if n_successors > 1:
                    k = sample_index(cumulative[state, action], uniform_at(key, base + 2 + 2 * j))
                nxt = next_state[state, action, k]
                out = outcome[state, action, k]
                entered[state] = t
                reward = memory_adjusted_reward(values[out], out, nxt, entered, t, episode_start, loop_memory,
                                                loop_value, loop_mode)
                total += reward
                length += 1
                t += 1
                if out == _IMPROPER:
                    clean = 0.0
                if out == _TERMINAL:
                    ended = 1.0
                    break
                state = nxt
            success = clean * ended
            ratio = total / length
            totals[p, 0, 0] += success
            totals[p, 0, 1] += success * success
            totals[p, 1, 0] += ended
            totals[p, 1, 1] += ended * ended
            totals[p, 2, 0] += ratio
            totals[p, 2, 1] += ratio * ratio
            totals[p, 3, 0] += length
            totals[p, 3, 1] += length * length


def _cumulative_rows(probabilities: np.ndarray) -> np.ndarray:
    """``(P, S, A)`` cumulative action probabilities of ``probabilities``: running sums over actions
    divided by their total, the last set to exactly 1.0 (a draw in [0, 1) always picks an action)."""
    rows = np.cumsum(probabilities, axis=2)
    rows /= rows[..., -1:]
    rows[..., -1] = 1.0
    return rows


def _checked(max_itr: int, shape: tuple, steps: "StepTable", keys) -> np.ndarray:
    """``keys`` as uint64 after checking ``max_itr`` and the policies' ``(P, S, A)`` ``shape``
    against the task's; ValueError naming the value and what is allowed."""
    check_count("max_itr", max_itr, 1)
    states, actions = steps.next_state.shape[:2]
    if len(shape) != 3 or shape[1:] != (states, actions):
        raise ValueError(f"policies must have shape (P, S, A) = (P, {states}, {actions}) for this task, got {shape}")
    keys = np.asarray(keys, dtype=np.uint64)
    if keys.shape != shape[:1]:
        raise ValueError(f"keys must have shape ({shape[0]},), one per policy, got {keys.shape}")
    return keys


def _play(policy_cumulative, q, epsilon: float, steps: "StepTable", max_itr: int, keys) -> Asymptotes:
    """`_simulate` and the means and standard errors of its sums."""
    totals = np.zeros((keys.shape[0], len(QUANTITIES), 2))
    entered = np.empty(steps.next_state.shape[0], dtype=np.int64)
    _simulate(policy_cumulative, q, float(epsilon), keys, steps.next_state, steps.outcome, steps.cumulative,
              steps.values, steps.loop_mode, steps.loop_value, steps.loop_memory, steps.starts, int(max_itr),
              steps.episodes, entered, totals)
    n = steps.episodes
    mean = totals[..., 0] / n
    variance = np.maximum(totals[..., 1] - n * mean * mean, 0.0) / (n - 1)
    error = np.sqrt(variance / n)
    return Asymptotes(*(mean[:, i] for i in range(len(QUANTITIES))),
                      error=Asymptotes(*(error[:, i] for i in range(len(QUANTITIES)))))


def simulated_statistics(probabilities: np.ndarray, steps: StepTable, max_itr: int, keys: np.ndarray) -> Asymptotes:
    """Monte Carlo [Asymptotes][tableclean_suite.asymptotes.Asymptotes] of behaviour policies, with
    their standard errors in ``error``.

    Args:
        probabilities: ``(P, S, A)`` action probabilities (each row sums to 1).
        steps: the task's [StepTable][tableclean_suite.simulation.StepTable] (its ``episodes`` per policy).
        max_itr: episode length limit, an integer >= 1.
        keys: ``(P,)`` uint64 random-number keys, one per policy
            ([simulation_keys][tableclean_suite.simulation.simulation_keys]).

    Returns:
        ``(P,)`` means over the episodes; ``error``: ``sqrt(sample variance / episodes)``.
    """
    probabilities = np.asarray(probabilities, dtype=np.float64)
    keys = _checked(max_itr, probabilities.shape, steps, keys)
    return _play(_cumulative_rows(probabilities), np.zeros((0, 0, 0)), 0.0, steps, max_itr, keys)


def simulated_greedy_statistics(q: np.ndarray, epsilon: float, steps: StepTable, max_itr: int,
                                keys: np.ndarray) -> Asymptotes:
    """[simulated_statistics][tableclean_suite.simulation.simulated_statistics] of epsilon-greedy
    behaviour on Q-tables ``q`` ``(P, S, A)`` (ties to the first action, as in training), bit for bit,
    without forming the ``(P, S, A)`` probabilities: only the states the episodes visit are read.
    ``epsilon`` in [0, 1]."""
    if not 0.0 <= epsilon <= 1.0:
        raise ValueError(f"epsilon must be in [0, 1], got {epsilon!r}")
    q = np.ascontiguousarray(q, dtype=np.float64)
    keys = _checked(max_itr, q.shape, steps, keys)
    return _play(np.zeros((0, 0, 0)), q, epsilon, steps, max_itr, keys)


def simulation_seconds(n_states: int, n_actions: int, runs: int, max_itr: int, analyses: int = 1,
                       episodes: int = SIMULATED_EPISODES) -> float:
    """Estimated seconds (an upper bound) of simulating ``analyses`` policies per run of ``runs`` runs:
    ``episodes x max_itr`` steps and one (S, A) table each."""
    policies = int(runs) * int(analyses)
    per_policy = (int(episodes) * int(max_itr) / SIMULATED_STEPS_PER_SECOND
                  + int(n_states) * int(n_actions) / POLICY_ENTRIES_PER_SECOND)
    return policies * per_policy


def simulation_bytes(n_states: int, n_actions: int, runs_per_call: int) -> int:
    """Bytes a simulation of ``runs_per_call`` policies allocates at most (state clock, ``(P, S, A)`` tables)."""
    return (int(n_states) * SIMULATION_BYTES_PER_STATE
            + int(runs_per_call) * int(n_states) * int(n_actions) * POLICY_BYTES_PER_ENTRY)
