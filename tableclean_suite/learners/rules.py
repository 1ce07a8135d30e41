"""Tabular learners: one temporal-difference target per algorithm, an update rule, and their registry.

A learner is data: a name, a compiled TD target (equation (2) of the paper), whether it picks the next
action before updating (on-policy, as SARSA does), an update rule (`METHODS`) with its parameters, the
initial Q value and the exploration it acts with.  The loop that uses them is
[`kernel`][tableclean_suite.learners.kernel]; the built-in learners:

| learner | update rule | target |
|---|---|---|
| `q_learning` | one step | r + gamma max_a Q(s', a) |
| `sarsa` | one step, on-policy | r + gamma Q(s', a') |
| `expected_sarsa` | one step | r + gamma E_pi Q(s', .) (pi: the behaviour policy) |
| `double_q_learning` | double (tables A and B) | r + gamma Q_B(s', argmax Q_A(s')) into A, or A<->B |
| `q_lambda` | traces, Watkins's cut | r + gamma max_a Q(s', a) |
| `sarsa_lambda` | traces, on-policy | r + gamma Q(s', a') |
| `dyna_q` | one step + n planning steps | r + gamma max_a Q(s', a), also on modelled steps |
| `affordance_q_learning` | one step, given affordances | r + gamma max_{a afforded} Q(s', a) |
| `learned_affordance_q_learning` | one step, learned affordances | r + gamma max_{a afforded} Q(s', a) |
| `interactive_q_learning` | one step + advisor (L = 0.5, C = 1) | r + gamma max_a Q(s', a) |

Every learner also takes Cruz et al.'s assistance ([`assist`][tableclean_suite.learners.assist]) through
``learner_options`` ([`TabularLearner`][tableclean_suite.learners.rules.TabularLearner] lists them).

Users add a learner by writing a ``numba.njit`` target with the signature of
[`q_learning_target`][tableclean_suite.learners.rules.q_learning_target] and calling
[`register_learner`][tableclean_suite.learners.rules.register_learner]; it may use the one-step or the trace
update rule.  The built-in targets are picked by code
([`builtin_td_target`][tableclean_suite.learners.rules.builtin_td_target]), so the disk-cached loop takes no function.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numba
import numpy as np

from tableclean_suite.learners.assist import AFFORD_NONE, AFFORDANCES
from tableclean_suite.learners.checks import check_number
from tableclean_suite.learners.exploration import EPSILON_GREEDY, Exploration, greedy_action
from tableclean_suite.registry import NAME_PATTERN, Registry
from tableclean_suite.rewards import MAX_REWARD


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
    """Expected SARSA: ``r + gamma * E_pi[Q(s', .)]`` under the epsilon-greedy policy.

    (Under ``softmax`` exploration the loop uses [`softmax_expected_sarsa_target`][tableclean_suite.learners.rules.softmax_expected_sarsa_target] instead.)
    """
    if terminal:
        return reward
    n_actions = q_next.shape[0]
    expected = 0.0
    for a in range(n_actions):
        expected += q_next[a]
    expected *= epsilon / n_actions
    expected += (1.0 - epsilon) * q_next[greedy_action(q_next)]
    return reward + gamma * expected


@numba.njit(cache=True)
def softmax_expected_sarsa_target(q_next, reward, gamma, temperature, terminal):
    """Expected SARSA under a Boltzmann policy at ``temperature``: ``r + gamma * sum_a P(a) Q(s', a)``."""
    if terminal:
        return reward
    best = q_next[greedy_action(q_next)]
    total = 0.0
    weighted = 0.0
    for a in range(q_next.shape[0]):
        weight = math.exp((q_next[a] - best) / temperature)
        total += weight
        weighted += weight * q_next[a]
    return reward + gamma * (weighted / total)


#: Target codes of the built-in learners ([`builtin_td_target`][tableclean_suite.learners.rules.builtin_td_target]); USER_TARGET for any other.
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


#: Update rules (``TabularLearner.method``): one-step TD, double Q, eligibility traces, Dyna planning.
METHOD_ONE_STEP, METHOD_DOUBLE_Q, METHOD_TRACES, METHOD_DYNA = 0, 1, 2, 3
METHODS = {"one_step": METHOD_ONE_STEP, "double_q": METHOD_DOUBLE_Q, "traces": METHOD_TRACES, "dyna": METHOD_DYNA}
#: Learner options (``train(learner_options=...)``) each update rule takes.
METHOD_OPTIONS = {METHOD_ONE_STEP: (), METHOD_DOUBLE_Q: (), METHOD_TRACES: ("lambda_", "trace"),
                  METHOD_DYNA: ("planning_steps",)}
TRACE_KINDS = ("replacing", "accumulating")
#: Learner options every update rule takes: Cruz et al.'s affordances and simulated advisor ([`assist`][tableclean_suite.learners.assist])
#: and the greedy choice's tie rule.
ASSIST_OPTIONS = ("affordance", "advice_probability", "advice_consistency", "ties")
#: Tie rules of the greedy choice (``TabularLearner.ties``) and their kernel codes: the first tied action
#: in the task's order (the paper's) or a uniform pick among the tied ones ([`optimality`][tableclean_suite.learners.optimality]).
TIES = {"first": 0, "random": 1}
TIES_FIRST, TIES_RANDOM = TIES["first"], TIES["random"]
#: Cruz et al.'s advice probability L (their interactive RL row) and the consistency C assumed here.
CRUZ_ADVICE_PROBABILITY = 0.5
DEFAULT_ADVICE_CONSISTENCY = 1.0
MAX_PLANNING_STEPS = 10_000
#: Indices of the kernel's learner-parameter array ([`TabularLearner.kernel_parameters`][tableclean_suite.learners.rules.TabularLearner.kernel_parameters]).
PARAM_LAMBDA, PARAM_ACCUMULATE, PARAM_PLANNING = 0, 1, 2
N_LEARNER_PARAMETERS = 3



@dataclass(frozen=True)
class TabularLearner:
    """A tabular TD learner: target, update rule and its parameters, initial values, exploration.

    Attributes:
        name: registry key, lower_snake.
        td_target: ``numba.njit`` function ``(q_next, next_action, reward, gamma,
            epsilon, terminal) -> float`` (see [`q_learning_target`][tableclean_suite.learners.rules.q_learning_target]).  ``epsilon`` is the
            behaviour policy's parameter at s' for the next step: epsilon at that iteration
            (and state, for ``visit_decay``), or the temperature under ``softmax``.
        on_policy: True if the next action is chosen (by the exploration, on Q before
            the update) and then taken, as SARSA does; False if the next action
            is chosen afresh after the update, as Algorithm 1 does.  (Trace learners
            always choose it first, to know whether to cut; off-policy ones cut.)
        description: one line for tables.
        target_code: the built-in target's code (``Q_LEARNING_TARGET``, ...) when
            ``td_target`` is that built-in; ``USER_TARGET`` (default) otherwise.
        method: update rule, one of `METHODS`' codes (default one-step TD).
            ``METHOD_DOUBLE_Q`` and ``METHOD_DYNA`` need the Q-learning target, off-policy.
        lambda_: trace decay lambda in [0, 1] (``METHOD_TRACES``; traces decay by gamma * lambda_).
        trace: ``"replacing"`` (e = 1 on a visit, default) or ``"accumulating"`` (e += 1).
        planning_steps: Dyna planning updates per real step, integer in [0, 10000] (``METHOD_DYNA``).
        q_init: initial value of every Q entry, in [-1e6, 1e6] (``rewards.MAX_REWARD``; above the best return it is optimistic).
        exploration: the behaviour policy ([`exploration`][tableclean_suite.learners.exploration]; default constant epsilon-greedy).
        affordance: ``"none"`` (default), ``"given"`` (the task model's ``action_mask``) or
            ``"learned"`` (an action observed improper in a state is not afforded there from then
            on); actions not afforded are never taken ([`assist`][tableclean_suite.learners.assist]).  Needs the one-step
            update rule and the built-in Q-learning or SARSA target.
        advice_probability: L in [0, 1], per-step probability that the simulated advisor advises
            the action (0 = no advisor, default).
        advice_consistency: C in [0, 1], probability that advice is the advisor's own (optimal)
            action rather than a uniformly random one (default 1).
        ties: the greedy choice's tie rule, ``"first"`` (default: the first tied action in the
            task's order, the paper's) or ``"random"`` (uniform among the tied actions, from the
            random numbers' ties lane).  Softmax exploration has no greedy choice to break.

    ``train()`` sets the last nine from ``learner_options=``, ``q_init=`` and ``exploration=``
    ([`configured`][tableclean_suite.learners.rules.TabularLearner.configured]).
    """

    name: str
    td_target: object
    on_policy: bool = False
    description: str = field(default="", compare=False)
    target_code: int = USER_TARGET
    method: int = METHOD_ONE_STEP
    lambda_: float = 0.0
    trace: str = TRACE_KINDS[0]
    planning_steps: int = 0
    q_init: float = 0.0
    exploration: Exploration = EPSILON_GREEDY
    affordance: str = "none"
    advice_probability: float = 0.0
    advice_consistency: float = DEFAULT_ADVICE_CONSISTENCY
    ties: str = "first"

    def __post_init__(self):
        if not isinstance(self.name, str) or not NAME_PATTERN.match(self.name):
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
        self._check_method()
        self._check_parameters()
        self._check_assistance()

    def _check_method(self) -> None:
        if self.method not in METHOD_OPTIONS:
            raise ValueError(f"learner {self.name!r}: unknown method {self.method!r}; allowed codes: "
                             + ", ".join(f"{code} ({name})" for name, code in METHODS.items()))
        needs_max = self.method in (METHOD_DOUBLE_Q, METHOD_DYNA)
        if needs_max and (self.target_code != Q_LEARNING_TARGET or self.on_policy):
            raise ValueError(f"learner {self.name!r}: the {self.method_name} update rule needs the built-in "
                             f"Q-learning target (target_code {Q_LEARNING_TARGET}) and on_policy=False")

    def _check_parameters(self) -> None:
        what = f"learner {self.name!r}"
        check_number(f"{what}: lambda_", self.lambda_, 0, 1)
        if self.ties not in TIES:
            raise ValueError(f"{what}: unknown ties {self.ties!r}; allowed: {', '.join(TIES)}")
        if self.trace not in TRACE_KINDS:
            raise ValueError(f"{what}: trace must be one of {', '.join(TRACE_KINDS)}, got {self.trace!r}")
        check_number(f"{what}: planning_steps", self.planning_steps, 0, MAX_PLANNING_STEPS, integer=True)
        check_number(f"{what}: q_init", self.q_init, -MAX_REWARD, MAX_REWARD)
        if not isinstance(self.exploration, Exploration):
            raise TypeError(f"{what}: exploration must be an Exploration, got {self.exploration!r}")
        object.__setattr__(self, "lambda_", float(self.lambda_))
        object.__setattr__(self, "planning_steps", int(self.planning_steps))
        object.__setattr__(self, "q_init", float(self.q_init) + 0.0)  # -0.0 -> 0.0

    def _check_assistance(self) -> None:
        what = f"learner {self.name!r}"
        if self.affordance not in AFFORDANCES:
            raise ValueError(f"{what}: affordance must be one of {', '.join(AFFORDANCES)}, got {self.affordance!r}")
        if self.affordance != "none" and (self.method != METHOD_ONE_STEP
                                          or self.target_code not in (Q_LEARNING_TARGET, SARSA_TARGET)):
            raise ValueError(f"{what}: affordance {self.affordance!r} needs the one_step update rule and the built-in "
                             f"Q-learning or SARSA target, not the {self.method_name} rule with target code "
                             f"{self.target_code}")
        check_number(f"{what}: advice_probability", self.advice_probability, 0, 1)
        check_number(f"{what}: advice_consistency", self.advice_consistency, 0, 1)
        object.__setattr__(self, "advice_probability", float(self.advice_probability))
        object.__setattr__(self, "advice_consistency", float(self.advice_consistency))

    @property
    def affordance_code(self) -> int:
        """The kernel code of `affordance` (``assist.AFFORD_*``)."""
        return AFFORDANCES[self.affordance]

    @property
    def advised(self) -> bool:
        """Whether a simulated advisor ever advises (``advice_probability > 0``)."""
        return self.advice_probability > 0.0

    def advice_parameters(self) -> np.ndarray:
        """``(N_ADVICE_PARAMETERS,)`` float64 ``[advice_probability, advice_consistency]``."""
        return np.array([self.advice_probability, self.advice_consistency], dtype=np.float64)

    @property
    def method_name(self) -> str:
        """The update rule's name (a key of `METHODS`)."""
        return next(name for name, code in METHODS.items() if code == self.method)

    def configured(self, options: dict | None = None, q_init: float | None = None,
                   exploration: Exploration | None = None) -> "TabularLearner":
        """A copy with ``options`` (this update rule's parameters, see `METHOD_OPTIONS`),
        ``q_init`` and ``exploration`` replaced (``None``: keep).  ``ValueError`` names
        options this learner does not take and out-of-range values."""
        options = dict(options or {})
        allowed = METHOD_OPTIONS[self.method] + ASSIST_OPTIONS
        unknown = sorted(set(options) - set(allowed))
        if unknown:
            takes = f"takes {', '.join(allowed)}"
            raise ValueError(f"learner {self.name!r} ({self.method_name} update) {takes}; got {unknown}")
        if q_init is not None:
            options["q_init"] = q_init
        if exploration is not None:
            options["exploration"] = exploration
        return replace(self, **options) if options else self

    def kernel_parameters(self) -> np.ndarray:
        """``(N_LEARNER_PARAMETERS,)`` float64 ``[lambda_, accumulate (0/1), planning_steps]``."""
        return np.array([self.lambda_, float(self.trace == "accumulating"), float(self.planning_steps)])

    def settings(self) -> dict:
        """What besides name and target changes the numbers (JSON-serialisable), e.g. for cache keys."""
        settings = {"method": self.method_name, "q_init": self.q_init, "exploration": self.exploration.to_dict()}
        settings.update({name: getattr(self, name) for name in METHOD_OPTIONS[self.method]})
        if self.affordance_code != AFFORD_NONE:
            settings["affordance"] = self.affordance
        if self.advised:
            settings.update(advice_probability=self.advice_probability, advice_consistency=self.advice_consistency)
        if self.ties != "first":
            settings["ties"] = self.ties
        return settings


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
    "expected_sarsa", expected_sarsa_target, False, "Expected SARSA (expectation over the behaviour policy)",
    EXPECTED_SARSA_TARGET,
)
DOUBLE_Q_LEARNING = TabularLearner(
    "double_q_learning", q_learning_target, False,
    "Double Q-learning (two tables; a draw picks the one updated, the other evaluates)", Q_LEARNING_TARGET,
    method=METHOD_DOUBLE_Q,
)
Q_LAMBDA = TabularLearner(
    "q_lambda", q_learning_target, False, "Watkins's Q(lambda) (eligibility traces, cut after exploratory actions)",
    Q_LEARNING_TARGET, method=METHOD_TRACES, lambda_=0.9,
)
SARSA_LAMBDA = TabularLearner(
    "sarsa_lambda", sarsa_target, True, "SARSA(lambda) (on-policy, eligibility traces)", SARSA_TARGET,
    method=METHOD_TRACES, lambda_=0.9,
)
DYNA_Q = TabularLearner(
    "dyna_q", q_learning_target, False, "Dyna-Q (Q-learning + planning on a learned deterministic model)",
    Q_LEARNING_TARGET, method=METHOD_DYNA, planning_steps=5,
)

AFFORDANCE_Q_LEARNING = TabularLearner(
    "affordance_q_learning", q_learning_target, False,
    "Affordance-based Q-learning (Cruz et al.): the task model's affordances, improper actions never taken",
    Q_LEARNING_TARGET, affordance="given",
)
LEARNED_AFFORDANCE_Q_LEARNING = TabularLearner(
    "learned_affordance_q_learning", q_learning_target, False,
    "Affordance-based Q-learning, affordances learned: an action seen improper in a state is not taken there again",
    Q_LEARNING_TARGET, affordance="learned",
)
INTERACTIVE_Q_LEARNING = TabularLearner(
    "interactive_q_learning", q_learning_target, False,
    "Interactive Q-learning (Cruz et al.): an optimal simulated advisor advises with L = 0.5, consistency C = 1",
    Q_LEARNING_TARGET, advice_probability=CRUZ_ADVICE_PROBABILITY, advice_consistency=DEFAULT_ADVICE_CONSISTENCY,
)

_REGISTRY: Registry[TabularLearner] = Registry(
    "learner", TabularLearner,
    (Q_LEARNING, SARSA, EXPECTED_SARSA, DOUBLE_Q_LEARNING, Q_LAMBDA, SARSA_LAMBDA, DYNA_Q,
     AFFORDANCE_Q_LEARNING, LEARNED_AFFORDANCE_Q_LEARNING, INTERACTIVE_Q_LEARNING),
)


def register_learner(learner: TabularLearner, overwrite: bool = False) -> TabularLearner:
    """Add a user learner so ``train(learner="name")`` and the CLI find it."""
    return _REGISTRY.register(learner, overwrite)


def learner_names() -> list[str]:
    """Registered learner names."""
    return _REGISTRY.names()


def get_learner(learner: str | TabularLearner) -> TabularLearner:
    """A learner by registered name, or the learner itself; clear error otherwise."""
    return _REGISTRY.get(learner)
