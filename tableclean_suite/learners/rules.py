"""Tabular learners: one temporal-difference target per algorithm, and their registry.

Q-learning and SARSA differ only in the target of equation (2) of the paper; the
shared loop (epsilon-greedy, episodes, recording) lives in :mod:`.kernel` and
:mod:`.reference`.  A learner is data: a name, a compiled target function and
whether it picks the next action before updating (on-policy, as SARSA does).

Users add a learner by writing a ``numba.njit`` target with the signature of
:func:`q_learning_target` and calling :func:`register_learner`.

The built-in targets are also reachable by an integer code (:func:`builtin_td_target`),
so the compiled training loop that uses them takes no function argument and numba's
disk cache serves it to every new process; a user target is compiled into its own
copy of the loop once per process.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numba

from tableclean_suite.registry import Registry


@numba.njit(cache=True)
def greedy_action(q_row):
    """Index of the largest value in ``q_row`` (shape ``(n_actions,)``), ties to the first."""
    best = 0
    for a in range(1, q_row.shape[0]):
        if q_row[a] > q_row[best]:
            best = a
    return best


@numba.njit(cache=True)
def q_learning_target(q_next, next_action, reward, gamma, epsilon, terminal):
    """Q-learning (Algorithm 1): ``r + gamma * max_a Q(s', a)``; ``r`` at a terminal state.

    Args:
        q_next: ``Q[s', :]``, shape ``(n_actions,)``.
        next_action: the action chosen in s' (on-policy learners only; -1 otherwise).
        reward: r_{t+1}.
        gamma: discount in [0, 1].
        epsilon: exploration rate of the behaviour policy, in [0, 1].
        terminal: whether s' is terminal (no bootstrap).
    """
    if terminal:
        return reward
    return reward + gamma * q_next[greedy_action(q_next)]


@numba.njit(cache=True)
def sarsa_target(q_next, next_action, reward, gamma, epsilon, terminal):
    """SARSA: ``r + gamma * Q(s', a')`` with a' the next action actually chosen."""
    if terminal:
        return reward
    return reward + gamma * q_next[next_action]


@numba.njit(cache=True)
def expected_sarsa_target(q_next, next_action, reward, gamma, epsilon, terminal):
    """Expected SARSA: ``r + gamma * E_pi[Q(s', .)]`` under the epsilon-greedy policy."""
    if terminal:
        return reward
    n_actions = q_next.shape[0]
    expected = 0.0
    for a in range(n_actions):
        expected += q_next[a]
    expected *= epsilon / n_actions
    expected += (1.0 - epsilon) * q_next[greedy_action(q_next)]
    return reward + gamma * expected


#: Target codes of the built-in learners (:func:`builtin_td_target`); USER_TARGET for any other.
Q_LEARNING_TARGET, SARSA_TARGET, EXPECTED_SARSA_TARGET = 0, 1, 2
USER_TARGET = -1


@numba.njit(cache=True)
def builtin_td_target(code, q_next, next_action, reward, gamma, epsilon, terminal):
    """The built-in target of ``code`` (``Q_LEARNING_TARGET``, ...), same arguments as the targets."""
    if code == SARSA_TARGET:
        return sarsa_target(q_next, next_action, reward, gamma, epsilon, terminal)
    if code == EXPECTED_SARSA_TARGET:
        return expected_sarsa_target(q_next, next_action, reward, gamma, epsilon, terminal)
    return q_learning_target(q_next, next_action, reward, gamma, epsilon, terminal)


_NAME_PATTERN = re.compile(r"^[a-z][a-z0-9_]*$")


@dataclass(frozen=True)
class TabularLearner:
    """A tabular TD learner.

    Attributes:
        name: registry key, lower_snake.
        td_target: ``numba.njit`` function ``(q_next, next_action, reward, gamma,
            epsilon, terminal) -> float`` (see :func:`q_learning_target`).
        on_policy: True if the next action is chosen (epsilon-greedy on Q before
            the update) and then taken, as SARSA does; False if the next action
            is chosen afresh after the update, as Algorithm 1 does.
        description: one line for tables.
        target_code: the built-in target's code (``Q_LEARNING_TARGET``, ...) when
            ``td_target`` is that built-in; ``USER_TARGET`` (default) otherwise.
    """

    name: str
    td_target: object
    on_policy: bool = False
    description: str = field(default="", compare=False)
    target_code: int = USER_TARGET

    def __post_init__(self):
        if not isinstance(self.name, str) or not _NAME_PATTERN.match(self.name):
            raise ValueError(f"learner name must be lower_snake, got {self.name!r}")
        if not isinstance(self.td_target, numba.core.registry.CPUDispatcher):
            raise TypeError(
                f"learner {self.name!r}: td_target must be a numba.njit function "
                f"(q_next, next_action, reward, gamma, epsilon, terminal) -> float, got {self.td_target!r}"
            )
        object.__setattr__(self, "on_policy", bool(self.on_policy))
        builtin = _BUILTIN_TARGETS.get(self.target_code)
        if self.target_code != USER_TARGET and builtin is not self.td_target:
            raise ValueError(f"learner {self.name!r}: target_code {self.target_code} is not the code of its td_target; "
                             f"leave it at USER_TARGET ({USER_TARGET}) for a user target")

    def target(self, q_next, next_action, reward, gamma, epsilon, terminal) -> float:
        """The TD target in plain Python (the reference loop's path)."""
        return self.td_target.py_func(q_next, next_action, reward, gamma, epsilon, terminal)


_BUILTIN_TARGETS = {
    Q_LEARNING_TARGET: q_learning_target,
    SARSA_TARGET: sarsa_target,
    EXPECTED_SARSA_TARGET: expected_sarsa_target,
}

Q_LEARNING = TabularLearner(
    "q_learning", q_learning_target, False, "Q-learning (off-policy, max target)", Q_LEARNING_TARGET
)
SARSA = TabularLearner("sarsa", sarsa_target, True, "SARSA (on-policy, target uses the next action taken)", SARSA_TARGET)
EXPECTED_SARSA = TabularLearner(
    "expected_sarsa", expected_sarsa_target, False, "Expected SARSA (expectation over the epsilon-greedy policy)",
    EXPECTED_SARSA_TARGET,
)

_REGISTRY: Registry[TabularLearner] = Registry("learner", TabularLearner, (Q_LEARNING, SARSA, EXPECTED_SARSA))


def register_learner(learner: TabularLearner, overwrite: bool = False) -> TabularLearner:
    """Add a user learner so ``train(learner="name")`` and the CLI find it."""
    return _REGISTRY.register(learner, overwrite)


def learner_names() -> list[str]:
    """Registered learner names."""
    return _REGISTRY.names()


def get_learner(learner: str | TabularLearner) -> TabularLearner:
    """A learner by registered name, or the learner itself; clear error otherwise."""
    return _REGISTRY.get(learner)
