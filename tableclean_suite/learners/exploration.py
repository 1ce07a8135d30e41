"""Exploration: how a learner picks its action from a Q row, independent of how it learns.

An exploration is a small frozen dataclass registered by name, whose docstring states its schedule:
``epsilon_greedy`` ([`EpsilonGreedy`][tableclean_suite.learners.exploration.EpsilonGreedy], the paper's, the
default), ``linear_decay``, ``exponential_decay``, ``visit_decay`` and ``softmax`` (Boltzmann).

``t`` is the run's iteration (0-based, counted across episodes) at which the action is
taken; ``epsilon`` is ``train(epsilon=...)``, the start value of every epsilon schedule
(softmax does not use it).  ``visits(s)`` is the number of earlier iterations of the run
(all episodes) whose state was ``s``, so the first choice in a state uses ``epsilon``.
Epsilon-greedy random actions are uniform over all the task's actions; ties in the
greedy choice go to the first action.

Draws: epsilon-greedy uses ``STREAM_EXPLORE`` and ``STREAM_RANDOM_ACTION``, softmax the latter
([`rng`][tableclean_suite.learners.rng]).  In the compiled loop an exploration is its `Exploration.code`
and [`kernel_parameters`][tableclean_suite.learners.exploration.Exploration.kernel_parameters].
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields, replace
from typing import ClassVar

import numba
import numpy as np

from tableclean_suite.learners.checks import check_number
from tableclean_suite.registry import Registry

#: Kernel codes of the explorations.
EPSILON_GREEDY_CODE, LINEAR_DECAY_CODE, EXPONENTIAL_DECAY_CODE, VISIT_DECAY_CODE, SOFTMAX_CODE = 0, 1, 2, 3, 4
#: Indices of the kernel parameter array.
P_START, P_FLOOR, P_RATE = 0, 1, 2
N_PARAMETERS = 3
#: Longest linear-decay horizon and largest rates accepted (iterations; per iteration).
MAX_HORIZON = 10**9
MAX_RATE = 1.0e3


# compiled: the exploration parameter at (t, s) and the action
@numba.njit(cache=True)
def greedy_action(q_row):
    """Index of the largest value in ``q_row`` (shape ``(n_actions,)``), ties to the first."""
    best = 0
    for a in range(1, q_row.shape[0]):
        if q_row[a] > q_row[best]:
            best = a
    return best


@numba.njit(cache=True, inline="always")
def exploration_parameter(code, parameters, iteration, visits):
    """Epsilon (or, for softmax, the temperature) at ``iteration`` in a state visited ``visits`` times.

    Args:
        code: the exploration's code (``EPSILON_GREEDY_CODE``, ...).
        parameters: ``(N_PARAMETERS,)`` float64, [`Exploration.kernel_parameters`][tableclean_suite.learners.exploration.Exploration.kernel_parameters].
        iteration: the run's iteration (>= 0) at which the action is taken.
        visits: earlier iterations of the run in this state (>= 0; used by ``visit_decay`` only).
    """
    if code == EPSILON_GREEDY_CODE:
        return parameters[P_START]
    if code == LINEAR_DECAY_CODE:
        fraction = iteration / parameters[P_RATE]
        if fraction >= 1.0:
            return parameters[P_FLOOR]
        return parameters[P_START] + (parameters[P_FLOOR] - parameters[P_START]) * fraction
    if code == EXPONENTIAL_DECAY_CODE or code == SOFTMAX_CODE:
        return max(parameters[P_FLOOR], parameters[P_START] * math.exp(-parameters[P_RATE] * iteration))
    if code == VISIT_DECAY_CODE:
        return parameters[P_START] / (1.0 + parameters[P_FLOOR] * visits)
    return parameters[P_START]


@numba.njit(cache=True)
def epsilon_greedy(q_row, epsilon, explore_draw, action_draw):
    """Epsilon-greedy action: random (uniform over all actions) when ``explore_draw < epsilon``."""
    if explore_draw < epsilon:
        return min(int(action_draw * q_row.shape[0]), q_row.shape[0] - 1)
    return greedy_action(q_row)


@numba.njit(cache=True)
def softmax_action(q_row, temperature, draw):
    """The action of a Boltzmann policy at ``temperature`` (> 0) picked by a uniform ``draw`` in [0, 1).

    The first action whose cumulative weight exceeds ``draw * total``, weights
    ``exp((Q - max Q) / temperature)`` (each in (0, 1], the greedy ones exactly 1).
    """
    best = q_row[greedy_action(q_row)]
    total = 0.0
    for a in range(q_row.shape[0]):
        total += math.exp((q_row[a] - best) / temperature)
    threshold = draw * total
    running = 0.0
    for a in range(q_row.shape[0]):
        running += math.exp((q_row[a] - best) / temperature)
        if threshold < running:
            return a
    return q_row.shape[0] - 1


# the dataclasses
@dataclass(frozen=True)
class Exploration:
    """Base of the explorations: a name, a kernel code and validated parameters."""

    name: ClassVar[str] = ""
    code: ClassVar[int] = -1
    softmax: ClassVar[bool] = False

    def check(self, epsilon: float) -> None:
        """``ValueError`` if this exploration cannot start from ``train(epsilon=epsilon)``."""

    def kernel_parameters(self, epsilon: float) -> np.ndarray:
        """``(N_PARAMETERS,)`` float64 ``[start, floor, rate]`` for the compiled loop."""
        raise NotImplementedError

    def parameter_at(self, epsilon: float, iteration: int, visits: int = 0) -> float:
        """Epsilon (softmax: temperature) at ``iteration`` in a state visited ``visits`` times before (the
        compiled loop's [`exploration_parameter`][tableclean_suite.learners.exploration.exploration_parameter])."""
        return float(exploration_parameter(self.code, self.kernel_parameters(epsilon), int(iteration), int(visits)))

    def to_dict(self) -> dict:
        """``{"name": ..., **parameters}`` (JSON-serialisable; [`as_exploration`][tableclean_suite.learners.exploration.as_exploration] reads it back)."""
        return {"name": self.name, **asdict(self)}

    def parameter_array(self, epsilon: float, iteration: int, visits) -> np.ndarray:
        """[`parameter_at`][tableclean_suite.learners.exploration.Exploration.parameter_at] for every entry of
        ``visits`` (any shape) -> float64 array of that shape (read-only), evaluated once per distinct count."""
        visits = np.asarray(visits)
        if self.code != VISIT_DECAY_CODE:
            return np.broadcast_to(np.float64(self.parameter_at(epsilon, iteration)), visits.shape)
        values, inverse = np.unique(visits, return_inverse=True)
        return np.array([self.parameter_at(epsilon, iteration, int(n)) for n in values])[inverse.reshape(visits.shape)]


def _check_epsilon_floor(exploration, epsilon: float) -> None:
    if exploration.epsilon_min > epsilon:
        raise ValueError(f"exploration {exploration.name!r}: epsilon_min {exploration.epsilon_min!r} must be "
                         f"<= epsilon {epsilon!r} (the schedule decays from epsilon to epsilon_min)")


@dataclass(frozen=True)
class EpsilonGreedy(Exploration):
    """Constant epsilon-greedy (the paper's): epsilon_t = ``train(epsilon=...)``."""

    name: ClassVar[str] = "epsilon_greedy"
    code: ClassVar[int] = EPSILON_GREEDY_CODE

    def kernel_parameters(self, epsilon):
        return np.array([epsilon, 0.0, 0.0], dtype=np.float64)


@dataclass(frozen=True)
class LinearDecay(Exploration):
    """epsilon_t falls linearly from ``epsilon`` at t = 0 to ``epsilon_min`` at t = ``horizon``, then stays.

    Attributes:
        epsilon_min: final epsilon in [0, epsilon].
        horizon: iterations of the decay, integer in [1, 1e9].
    """

    epsilon_min: float = 0.01
    horizon: int = 2000
    name: ClassVar[str] = "linear_decay"
    code: ClassVar[int] = LINEAR_DECAY_CODE

    def __post_init__(self):
        check_number(f"exploration {self.name!r}: epsilon_min", self.epsilon_min, 0, 1)
        check_number(f"exploration {self.name!r}: horizon", self.horizon, 1, MAX_HORIZON, integer=True)
        object.__setattr__(self, "epsilon_min", float(self.epsilon_min))
        object.__setattr__(self, "horizon", int(self.horizon))

    check = _check_epsilon_floor

    def kernel_parameters(self, epsilon):
        return np.array([epsilon, self.epsilon_min, float(self.horizon)], dtype=np.float64)


@dataclass(frozen=True)
class ExponentialDecay(Exploration):
    """epsilon_t = max(epsilon_min, epsilon * exp(-rate * t)).

    Attributes:
        epsilon_min: floor in [0, epsilon].
        rate: decay rate per iteration in [0, 1000] (0: constant epsilon); half-life ln 2 / rate.
    """

    epsilon_min: float = 0.01
    rate: float = 1.0e-3
    name: ClassVar[str] = "exponential_decay"
    code: ClassVar[int] = EXPONENTIAL_DECAY_CODE

    def __post_init__(self):
        check_number(f"exploration {self.name!r}: epsilon_min", self.epsilon_min, 0, 1)
        check_number(f"exploration {self.name!r}: rate", self.rate, 0, MAX_RATE)
        object.__setattr__(self, "epsilon_min", float(self.epsilon_min))
        object.__setattr__(self, "rate", float(self.rate))

    check = _check_epsilon_floor

    def kernel_parameters(self, epsilon):
        return np.array([epsilon, self.epsilon_min, self.rate], dtype=np.float64)


@dataclass(frozen=True)
class VisitDecay(Exploration):
    """Per-state decay: epsilon_t(s) = epsilon / (1 + scale * visits(s)).

    ``visits(s)``: earlier iterations of the run (all episodes) in state s.

    Attributes:
        scale: per-visit factor in [0, 1000] (0: constant epsilon; 0.01: halved after 100 visits).
    """

    scale: float = 0.05
    name: ClassVar[str] = "visit_decay"
    code: ClassVar[int] = VISIT_DECAY_CODE

    def __post_init__(self):
        check_number(f"exploration {self.name!r}: scale", self.scale, 0, MAX_RATE)
        object.__setattr__(self, "scale", float(self.scale))

    def kernel_parameters(self, epsilon):
        return np.array([epsilon, self.scale, 0.0], dtype=np.float64)


@dataclass(frozen=True)
class Softmax(Exploration):
    """Boltzmann exploration: P(a | s) = exp((Q(s, a) - max Q(s)) / T_t) / sum over actions.

    T_t = max(temperature_min, temperature * exp(-rate * t)); ``rate = 0`` keeps
    ``temperature``.  Q values are in reward units, so T is too: at T = 0.05 an action
    0.05 below the best is e ~ 2.7 times less likely.  ``train(epsilon=...)`` is not used.

    Attributes:
        temperature: start temperature, in (0, 1e6].
        temperature_min: floor in (0, temperature].
        rate: decay rate per iteration in [0, 1000].
    """

    temperature: float = 0.05
    temperature_min: float = 0.01
    rate: float = 0.0
    name: ClassVar[str] = "softmax"
    code: ClassVar[int] = SOFTMAX_CODE
    softmax: ClassVar[bool] = True

    def __post_init__(self):
        what = f"exploration {self.name!r}"
        check_number(f"{what}: temperature", self.temperature, 0, 1.0e6, low_open=True)
        check_number(f"{what}: temperature_min", self.temperature_min, 0, self.temperature, low_open=True)
        check_number(f"{what}: rate", self.rate, 0, MAX_RATE)
        for name in ("temperature", "temperature_min", "rate"):
            object.__setattr__(self, name, float(getattr(self, name)))

    def kernel_parameters(self, epsilon):
        return np.array([self.temperature, self.temperature_min, self.rate], dtype=np.float64)


def softmax_probabilities(q: np.ndarray, temperature: float) -> np.ndarray:
    """Boltzmann probabilities ``(..., A)`` of Q rows ``(..., A)`` at ``temperature`` (> 0)."""
    check_number("temperature", temperature, 0, math.inf, low_open=True)
    q = np.asarray(q, dtype=np.float64)
    weights = np.exp((q - q.max(axis=-1, keepdims=True)) / temperature)
    return weights / weights.sum(axis=-1, keepdims=True)


EPSILON_GREEDY = EpsilonGreedy()
_REGISTRY: Registry[Exploration] = Registry(
    "exploration", Exploration, (EPSILON_GREEDY, LinearDecay(), ExponentialDecay(), VisitDecay(), Softmax())
)


def exploration_names() -> list[str]:
    """Registered exploration names (``epsilon_greedy``, ``linear_decay``, ...)."""
    return _REGISTRY.names()


def as_exploration(value: "str | Exploration | Mapping | None" = None, **parameters) -> Exploration:
    """An [`Exploration`][tableclean_suite.learners.exploration.Exploration] from a name (with optional ``parameters``), a mapping or an instance.

    ``None`` is the default constant epsilon-greedy.  A mapping is ``{"name": ..., **parameters}``
    (as [`Exploration.to_dict`][tableclean_suite.learners.exploration.Exploration.to_dict] writes).  ``ValueError`` names unknown names and parameters.
    """
    if value is None:
        value = EPSILON_GREEDY.name
    if isinstance(value, Mapping):
        if "name" not in value:
            raise ValueError(f"an exploration mapping needs a 'name' (one of {', '.join(exploration_names())}), "
                             f"got {dict(value)!r}")
        parameters = {**{k: v for k, v in value.items() if k != "name"}, **parameters}
        value = value["name"]
    exploration = _REGISTRY.get(value)
    if not parameters:
        return exploration
    allowed = [f.name for f in fields(exploration)]
    unknown = sorted(set(parameters) - set(allowed))
    if unknown:
        raise ValueError(f"exploration {exploration.name!r}: unknown parameter(s) {unknown}; "
                         f"allowed: {', '.join(allowed) or 'none'}")
    return replace(exploration, **parameters)


def parse_exploration(text: str) -> Exploration:
    """``"linear_decay:horizon=2000,epsilon_min=0.01"`` -> [`LinearDecay`][tableclean_suite.learners.exploration.LinearDecay] (for command lines)."""
    name, _, rest = text.partition(":")
    parameters = {}
    for item in filter(None, (part.strip() for part in rest.split(","))):
        key, sep, number = item.partition("=")
        if not sep:
            raise ValueError(f"exploration parameter {item!r} must be key=value")
        try:
            parameters[key.strip()] = float(number) if any(c in number for c in ".eE") else int(number)
        except ValueError:
            raise ValueError(f"exploration parameter {key.strip()!r} must be a number, got {number!r}") from None
    return as_exploration(name.strip(), **parameters)
