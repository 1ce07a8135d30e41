"""The learners' oracle: the training loop in plain Python, written independently of the compiled
functions (Algorithm 1 as written), against which the tests check the compiled loop bit for bit.

Every learner has its plain twin here (`_Agent`): double Q's two tables, eligibility traces as the
dense S x A sweep of their definition, Dyna-Q's planning, each exploration's schedule, Cruz et
al.'s affordances and advisor and the learning times.  [`oracle_train`][learner_oracle.oracle_train]
is ``train(engine="reference")`` with this loop in place of the package's stepper.
"""

from __future__ import annotations

import math

import numpy as np

from tableclean_suite.learners.kernel import (
    DOUBLE_Q_SPLIT,
    EPISODE_CONTINUES,
    EPISODE_TERMINAL,
    EPISODE_TRUNCATED,
    HALF,
    NO_STATE,
)
from tableclean_suite.learners import optimality
from tableclean_suite.learners.assist import advisor_policy, given_affordances
from tableclean_suite.learners.exploration import ExponentialDecay, LinearDecay, Softmax, VisitDecay
from tableclean_suite.learners.optimality import NOT_LEARNED
from tableclean_suite.learners.rng import (
    LANE_ADVICE,
    LANE_LEARNER,
    LANE_PLANNING,
    LANE_TIES,
    STREAM_ADVICE_ACTION,
    STREAM_ADVISE,
    STREAM_CONSISTENT,
    STREAM_DOUBLE_TABLE,
    STREAM_EXPLORE,
    STREAM_RANDOM_ACTION,
    STREAM_START,
    STREAM_TIE,
    STREAM_TRANSITION,
    lane_key_py,
    run_key,
)
from tableclean_suite.learners.rules import (
    EXPECTED_SARSA_TARGET,
    Q_LEARNING_TARGET,
    METHOD_DOUBLE_Q,
    METHOD_DYNA,
    METHOD_TRACES,
    TabularLearner,
)
from tableclean_suite.rewards import RewardPattern
from tableclean_suite.learners import stepper, train
from tableclean_suite.task import Outcome, TaskModel


_MASK64, _GOLDEN, _MIX1, _MIX2 = (1 << 64) - 1, 0x9E3779B97F4A7C15, 0xBF58476D1CE4E5B9, 0x94D049BB133111EB


def uniform_at_py(key: int, counter: int) -> float:
    """SplitMix64's uniform draw in [0, 1) at ``counter`` of ``key``, in plain integers (the rng's definition)."""
    z = (key + (counter & _MASK64) * _GOLDEN + _GOLDEN) & _MASK64
    z = ((z ^ (z >> 30)) * _MIX1) & _MASK64
    z = ((z ^ (z >> 27)) * _MIX2) & _MASK64
    return ((z ^ (z >> 31)) >> 11) * 2.0**-53


def uniform_py(key: int, iteration: int, stream: int) -> float:
    """The main-lane draw of ``stream`` at ``iteration`` (four streams per iteration)."""
    return uniform_at_py(key, iteration * 4 + stream)


#: Key of double Q-learning's two tables in a record / ``TrainingResult.info``: ``(..., 2, S, A)``.
DOUBLE_Q_TABLES = "double_q_tables"
#: Key of a run's Q-table after ``train_run(checkpoint=k)``'s k iterations, ``(S, A)``.
CHECKPOINT_Q = "checkpoint_q"


def _tied(q_row, actions: list[int]) -> list[int]:
    """The actions of ``actions`` with the largest ``q_row`` value, in order."""
    best = max(q_row[a] for a in actions)
    return [a for a in actions if q_row[a] == best]


def _greedy_choice(q_row, actions: list[int], tie_draw: float | None) -> int:
    """The greedy action among ``actions``: the first tied one, or with ``tie_draw`` a uniform pick."""
    tied = _tied(q_row, actions)
    if tie_draw is None:
        return tied[0]
    return tied[min(int(tie_draw * len(tied)), len(tied) - 1)]


def _softmax_weights(q_row, temperature: float) -> list[float]:
    """``exp((Q - max Q) / temperature)`` per action, in action order."""
    best = max(q_row)
    return [math.exp((value - best) / temperature) for value in q_row]


def _softmax_expected_target(q_row, reward: float, gamma: float, temperature: float, terminal: bool) -> float:
    if terminal:
        return reward
    total = weighted = 0.0
    for weight, value in zip(_softmax_weights(q_row, temperature), q_row):
        total += weight
        weighted += weight * value
    return reward + gamma * (weighted / total)


class _Assistance:
    """Cruz et al.'s affordances and advisor for one run, in plain Python.

    ``blocked`` holds the (state, action) pairs not afforded: the model's improper pairs
    (``given``), or those observed improper so far (``learned``).  The advisor acts through
    `advice` with the advice lane's draws.
    """

    def __init__(self, learner: TabularLearner, model: TaskModel, key: int):
        self.affordance = learner.affordance
        self.n_actions = model.n_actions
        self.blocked: set[tuple[int, int]] = set()
        if self.affordance == "given":
            self.blocked = {(int(s), int(a)) for s, a in zip(*np.nonzero(given_affordances(model) == 0))}
        self.advisor = [int(a) for a in advisor_policy(model)] if learner.advised else None
        self.probability, self.consistency = learner.advice_probability, learner.advice_consistency
        self.key = lane_key_py(key, LANE_ADVICE)

    def afforded(self, state: int) -> list[int]:
        """The afforded actions of ``state`` in action order (all of them when none is)."""
        actions = [a for a in range(self.n_actions) if (state, a) not in self.blocked]
        return actions or list(range(self.n_actions))

    def observe(self, state: int, action: int, outcome: int) -> None:
        """Learned affordances: an improper outcome blocks (state, action) from now on."""
        if self.affordance == "learned" and outcome == Outcome.IMPROPER:
            self.blocked.add((state, action))

    def advice(self, state: int, t: int) -> int:
        """The advisor's action at iteration ``t``, or NO_STATE (no advisor, no advice, or none for this state)."""
        if self.advisor is None or uniform_py(self.key, t, STREAM_ADVISE) >= self.probability:
            return NO_STATE
        if self.advisor[state] == NO_STATE:
            return NO_STATE
        if uniform_py(self.key, t, STREAM_CONSISTENT) < self.consistency:
            return self.advisor[state]
        return min(int(uniform_py(self.key, t, STREAM_ADVICE_ACTION) * self.n_actions), self.n_actions - 1)


def _schedule(exploration, epsilon: float, t: int, visits: int) -> float:
    """Epsilon (softmax: temperature) of ``exploration`` at iteration ``t`` in a state visited ``visits``
    times, from each schedule's definition (the compiled ``exploration_parameter`` must agree bit for bit)."""
    if isinstance(exploration, LinearDecay):
        fraction = t / exploration.horizon
        return exploration.epsilon_min if fraction >= 1.0 else epsilon + (exploration.epsilon_min - epsilon) * fraction
    if isinstance(exploration, ExponentialDecay):
        return max(exploration.epsilon_min, epsilon * math.exp(-exploration.rate * t))
    if isinstance(exploration, VisitDecay):
        return epsilon / (1.0 + exploration.scale * visits)
    if isinstance(exploration, Softmax):
        return max(exploration.temperature_min, exploration.temperature * math.exp(-exploration.rate * t))
    return epsilon


def _behaviour_action(q_row, actions: list[int], softmax: bool, parameter: float, explore_draw: float,
                      action_draw: float, tie_draw=None) -> int:
    """The behaviour policy over ``actions`` (all, or the afforded ones): softmax, or epsilon-greedy with
    uniform exploration."""
    if softmax:
        best = max(q_row[a] for a in actions)
        weights = [math.exp((q_row[a] - best) / parameter) for a in actions]
        threshold, running = action_draw * sum(weights), 0.0
        for a, weight in zip(actions, weights):
            running += weight
            if threshold < running:
                return a
        return actions[-1]
    if explore_draw < parameter:
        return actions[min(int(action_draw * len(actions)), len(actions) - 1)]
    return _greedy_choice(q_row, actions, tie_draw)


class _Agent:
    """One run's learner in plain Python: tables, traces (dense, S x A), Dyna's model, visit counts.

    The dense trace sweep here is the definition the compiled loop's sparse pair list
    must reproduce exactly.
    """

    def __init__(self, learner: TabularLearner, n_states: int, n_actions: int, alpha: float, gamma: float,
                 epsilon: float, key: int, assistance: _Assistance | None = None):
        self.learner, self.alpha, self.gamma, self.epsilon, self.key = learner, alpha, gamma, epsilon, key
        self.exploration = learner.exploration
        self.double = learner.method == METHOD_DOUBLE_Q
        self.traced = learner.method == METHOD_TRACES
        self.planning = learner.method == METHOD_DYNA
        self.choose_first = learner.on_policy or self.traced
        self.q = self._table(n_states, n_actions, learner.q_init)
        self.q_b = self._table(n_states, n_actions, learner.q_init) if self.double else None
        self.traces = self._table(n_states, n_actions, 0.0) if self.traced else None
        self.decay = gamma * learner.lambda_
        self.visits = [0] * n_states
        self.model: dict[tuple[int, int], tuple[int, float, bool]] = {}
        self.observed: list[tuple[int, int]] = []
        self.side_key = lane_key_py(key, LANE_LEARNER)
        self.planning_key = lane_key_py(key, LANE_PLANNING)
        self.assistance = assistance
        self.affording = learner.affordance != "none"
        self.tie_key = lane_key_py(key, LANE_TIES) if learner.ties == "random" else None

    @staticmethod
    def _table(n_states, n_actions, value):
        return [[value] * n_actions for _ in range(n_states)]

    def begin_episode(self) -> None:
        if self.traced:
            for row in self.traces:
                row[:] = [0.0] * len(row)

    def row(self, state: int) -> list[float]:
        """The Q row the behaviour policy acts on (double Q: the tables' average)."""
        if not self.double:
            return self.q[state]
        return [(a + b) * HALF for a, b in zip(self.q[state], self.q_b[state])]

    def act(self, state: int, t: int) -> int:
        if self.assistance is not None:
            advised = self.assistance.advice(state, t)
            if advised != NO_STATE:
                return advised
        parameter = _schedule(self.exploration, self.epsilon, t, self.visits[state])
        tie_draw = None if self.tie_key is None else uniform_py(self.tie_key, t, STREAM_TIE)
        actions = self.assistance.afforded(state) if self.affording else list(range(len(self.q[state])))
        return _behaviour_action(self.row(state), actions, self.exploration.softmax, parameter,
                                 uniform_py(self.key, t, STREAM_EXPLORE), uniform_py(self.key, t, STREAM_RANDOM_ACTION),
                                 tie_draw)

    def greedy_actions(self, state: int) -> list[int]:
        """The actions the greedy policy may take in ``state``: the first tied one, or every tied one
        under random ties (afforded actions only when the learner uses affordances)."""
        actions = self.assistance.afforded(state) if self.affording else list(range(len(self.q[state])))
        tied = _tied(self.row(state), actions)
        return tied if self.tie_key is not None else tied[:1]

    def greedy_is_optimal(self, starts: list[int], task_next, distance) -> bool:
        """Whether the greedy policy reaches the terminal state from every start in its shortest-plan
        number of steps, in the task model's transitions ``task_next`` ``(S, A)`` (see [`optimality`][tableclean_suite.learners.optimality])."""
        frontier, seen = list(starts), set(starts)
        while frontier:
            state = frontier.pop()
            here = int(distance[state])
            if here == 0:
                continue
            for action in self.greedy_actions(state):
                nxt = int(task_next[state][action])
                if here < 0 or distance[nxt] != here - 1:
                    return False
                if nxt not in seen:
                    seen.add(nxt)
                    frontier.append(nxt)
        return True

    def learn(self, t: int, state: int, action: int, reward: float, nxt: int, pending: int, terminal: bool) -> None:
        if self.double:
            self._learn_double(t, state, action, reward, nxt, terminal)
            return
        target = self._target(t, reward, nxt, pending, terminal)
        if self.traced:
            exploratory = pending != NO_STATE and self.q[nxt][pending] < max(self.q[nxt])
            self._learn_traces(state, action, target - self.q[state][action], exploratory and not self.learner.on_policy)
        else:
            self.q[state][action] += self.alpha * (target - self.q[state][action])
        if self.planning:
            self._remember_and_plan(t, state, action, reward, nxt, terminal)

    def _target(self, t, reward, nxt, pending, terminal) -> float:
        behaviour = _schedule(self.exploration, self.epsilon, t + 1, self.visits[nxt])
        if self.exploration.softmax and self.learner.target_code == EXPECTED_SARSA_TARGET:
            return _softmax_expected_target(self.q[nxt], reward, self.gamma, behaviour, terminal)
        if self.affording and self.learner.target_code == Q_LEARNING_TARGET:
            if terminal:
                return reward
            return reward + self.gamma * max(self.q[nxt][a] for a in self.assistance.afforded(nxt))
        return self.learner.td_target.py_func(np.asarray(self.q[nxt]), pending, reward, self.gamma, behaviour, terminal)

    def _learn_double(self, t, state, action, reward, nxt, terminal) -> None:
        if uniform_py(self.side_key, t, STREAM_DOUBLE_TABLE) < DOUBLE_Q_SPLIT:
            updated, other = self.q, self.q_b
        else:
            updated, other = self.q_b, self.q
        greedy = _greedy_choice(updated[nxt], list(range(len(updated[nxt]))), None)
        target = reward if terminal else reward + self.gamma * other[nxt][greedy]
        updated[state][action] += self.alpha * (target - updated[state][action])

    def _learn_traces(self, state, action, delta, cut) -> None:
        """The dense definition: every (s, a) gets ``Q += (alpha delta) e``, then ``e *= gamma lambda`` (or 0)."""
        traces = self.traces
        accumulating = self.learner.trace == "accumulating"
        traces[state][action] = traces[state][action] + 1.0 if accumulating else 1.0
        step = self.alpha * delta
        for q_row, trace_row in zip(self.q, traces):
            for a, trace in enumerate(trace_row):
                q_row[a] += step * trace
                trace_row[a] = 0.0 if cut else trace * self.decay

    def _remember_and_plan(self, t, state, action, reward, nxt, terminal) -> None:
        if (state, action) not in self.model:
            self.observed.append((state, action))
        self.model[(state, action)] = (nxt, reward, terminal)
        steps = self.learner.planning_steps
        for j in range(steps):
            draw = uniform_at_py(self.planning_key, t * steps + j)
            s, a = self.observed[min(int(draw * len(self.observed)), len(self.observed) - 1)]
            s_next, r, end = self.model[(s, a)]
            target = r if end else r + self.gamma * max(self.q[s_next])
            self.q[s][a] += self.alpha * (target - self.q[s][a])

    def tables(self) -> dict[str, np.ndarray]:
        """``q`` ``(S, A)`` (double Q: the average of A and B) and, for double Q, both ``(2, S, A)``."""
        q = np.asarray(self.q, dtype=np.float64)
        if not self.double:
            return {"q": q}
        q_b = np.asarray(self.q_b, dtype=np.float64)
        return {"q": (q + q_b) * HALF, DOUBLE_Q_TABLES: np.stack((q, q_b))}


def train_run(
    env,
    learner: TabularLearner,
    reward: RewardPattern,
    iterations: int,
    alpha: float,
    gamma: float,
    epsilon: float,
    max_itr: int,
    seed: int,
    run: int,
    on_step=None,
    checkpoint: int = 0,
) -> dict[str, np.ndarray]:
    """Train one run of ``env`` (a step environment with a ``model``, see the module docstring) for
    ``iterations`` steps; the learner brings its update rule, parameters, ``q_init`` and exploration
    (``epsilon`` is the exploration's start value).

    Returns a dict with ``rewards`` (T,) float64, ``outcomes``/``states``/``actions``/``episode_end``
    (T,) of ``env.model.record_dtype``, ``q`` ``(n_states, n_actions)`` float64 (double Q: the average
    of its tables, which are under ``"double_q_tables"``, ``(2, S, A)``), and ``first_learned_at`` and
    ``learned_at`` (int64 0-d arrays), the run's learning times ([`optimality`][tableclean_suite.learners.optimality]).
    ``on_step(t)`` is called after every iteration (progress bars).  ``checkpoint`` in [1, iterations]
    also keeps the Q-table after that many iterations under ``"checkpoint_q"`` ``(S, A)`` (as ``q``).
    """
    key = run_key(seed, run)
    model = env.model
    assistance = _Assistance(learner, model, key) if learner.affordance != "none" or learner.advised else None
    agent = _Agent(learner, model.n_states, model.n_actions, alpha, gamma, epsilon, key, assistance)
    starts, task_next, distance = optimality.task_arrays(model)
    starts = [int(s) for s in starts]
    optimal = agent.greedy_is_optimal(starts, task_next, distance)
    first_learned = 0 if optimal else NOT_LEARNED
    last_not_optimal = -1 if optimal else 0
    dtype = model.record_dtype
    record = {name: np.zeros(iterations, dtype=dtype) for name in ("outcomes", "states", "actions", "episode_end")}
    record["rewards"] = np.zeros(iterations, dtype=np.float64)
    state = previous = pending = NO_STATE
    length = 0
    history: list[int] = []  # the episode's states s_0 .. s_t, for a looping rule that looks further back
    for t in range(iterations):
        if state == NO_STATE:
            state = env.reset(uniform_py(key, t, STREAM_START))
            previous = pending = NO_STATE
            length = 0
            history = []
            agent.begin_episode()
        history.append(state)
        action = pending if pending != NO_STATE else agent.act(state, t)
        nxt, outcome = env.step(state, action, uniform_py(key, t, STREAM_TRANSITION))
        r = reward.reward(outcome, state, nxt, previous, history)
        length += 1
        terminal = outcome == Outcome.TERMINAL
        agent.visits[state] += 1
        if assistance is not None:
            assistance.observe(state, action, outcome)
        pending = agent.act(nxt, t + 1) if agent.choose_first and not terminal else NO_STATE
        agent.learn(t, state, action, r, nxt, pending, terminal)
        record["rewards"][t] = r
        record["outcomes"][t] = outcome
        record["states"][t] = state
        record["actions"][t] = action
        if terminal:
            record["episode_end"][t] = EPISODE_TERMINAL
            state = NO_STATE
        elif length >= max_itr:
            record["episode_end"][t] = EPISODE_TRUNCATED
            state = NO_STATE
        else:
            record["episode_end"][t] = EPISODE_CONTINUES
            previous, state = state, nxt
        optimal = agent.greedy_is_optimal(starts, task_next, distance)
        if not optimal:
            last_not_optimal = t + 1
        elif first_learned == NOT_LEARNED:
            first_learned = t + 1
        if t + 1 == checkpoint:
            record[CHECKPOINT_Q] = agent.tables()["q"]
        if on_step is not None:
            on_step(t)
    record.update(agent.tables())
    record["first_learned_at"] = np.int64(first_learned)
    record["learned_at"] = np.int64(last_not_optimal + 1 if optimal else NOT_LEARNED)
    return record


def oracle_train(learner="q_learning", reward="r4", **kwargs):
    """``train(learner, reward, engine="reference", **kwargs)`` with this module's `train_run` stepping each run."""
    original = stepper.train_run
    stepper.train_run = train_run
    try:
        return train(learner, reward, engine="reference", **kwargs)
    finally:
        stepper.train_run = original
