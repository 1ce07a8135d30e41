"""Reward patterns r1-r4 of the paper's Table 2, as data, plus a registry for user patterns.

A pattern maps each [`Outcome`][tableclean_suite.task.state.Outcome] to a value and may add
the looping penalty of r4.  Everything here is pure: ``RewardPattern.reward`` is a
function of (outcome, state, next state, state before the previous step).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from tableclean_suite.registry import NAME_PATTERN, Registry
from tableclean_suite.task import N_OUTCOMES, Outcome, is_integer

#: Table 2 reward levels, named.
TERMINAL_REWARD = 1.0
RELEVANT_CLEAN_REWARD = 1.0
SMALL_PENALTY = -0.01
SMALL_INCENTIVE = 0.01
IMPROPER_PENALTY = -1.0

#: Largest reward magnitude a pattern (and a Q-table's initial value) may have: far above any
#: task's scale, far below where sums of rewards overflow float64 into inf and NaN.
MAX_REWARD = 10**6

#: Outcomes of routine actions (move/pick/place) that the looping penalty can hit.
LOOPABLE_OUTCOMES = (Outcome.ROUTINE, Outcome.INEFFECTIVE)


#: How a special reward combines with the base value it applies to: given instead of it, or added to it.
COMBINE_MODES = ("replace", "add")

#: Integer codes of the looping rule for compiled learners.
LOOPING_OFF, LOOPING_REPLACE, LOOPING_ADD = 0, 1, 2

#: The paper's looping memory: a routine step is looping when its next state is one of the last
#: two states of the episode, s_t (staying put) or s_{t-1} (switching back).
PAPER_LOOPING_MEMORY = 2
#: ``looping_memory`` meaning the whole episode so far: any routine step that returns to a state
#: the episode already visited (it completes a cycle, of any length).
EPISODE_LOOPING_MEMORY = 0


@dataclass(frozen=True)
class RewardPattern:
    """One row of Table 2 (a reward per outcome), plus the optional looping penalty.

    Attributes:
        name: registry key, lower_snake (e.g. ``"r4"``).
        terminal: reward for the clean that makes both segments clean.
        relevant_clean: reward for cleaning an unclean segment.
        irrelevant_clean: reward for cleaning an already clean segment.
        routine: reward for an effective move, pick or place.
        improper: reward for an improper action (Algorithm 1's failed state).
        ineffective: reward for a pick with nothing to pick or a place with nothing
            held; ``None`` means "as irrelevant cleaning" (the default rule).
        looping_penalty: reward for a routine action (move/pick/place) whose result
            equals the state before the previous step (s_{t+1} = s_{t-1}) or leaves
            the state unchanged; ``None`` disables it.
        looping_mode: ``"replace"`` (default: the penalty is given instead of the
            routine/ineffective value) or ``"add"`` (added to it).
        looping_memory: how far back the looping rule looks, in states of the episode: a
            routine/ineffective step is looping when its next state is one of the episode's last
            ``looping_memory`` states s_t, s_{t-1}, ..., s_{t-k+1} (an int >= 2; 2, the default,
            is the paper's rule), or any state the episode visited (``EPISODE_LOOPING_MEMORY``, 0:
            also catches MOVE round the ring of N >= 3 segments).
        terminal_mode: ``"replace"`` (default: the terminal reward replaces the
            relevant-cleaning reward on the final clean) or ``"add"``.
        description: one line for tables and ``--describe``.

    All values must be finite floats in [-`MAX_REWARD`, `MAX_REWARD`].
    """

    name: str
    terminal: float
    relevant_clean: float
    irrelevant_clean: float
    routine: float
    improper: float
    ineffective: float | None = None
    looping_penalty: float | None = None
    looping_mode: str = COMBINE_MODES[0]
    terminal_mode: str = COMBINE_MODES[0]
    description: str = field(default="", compare=False)
    looping_memory: int = PAPER_LOOPING_MEMORY

    def __post_init__(self):
        if not isinstance(self.name, str) or not NAME_PATTERN.match(self.name):
            raise ValueError(f"reward pattern name must be lower_snake (e.g. 'r5' or 'my_reward'), got {self.name!r}")
        for f in fields(self):
            if f.name in ("name", "description", "looping_mode", "terminal_mode", "looping_memory"):
                continue
            value = getattr(self, f.name)
            if value is None and f.name in ("ineffective", "looping_penalty"):
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
                raise ValueError(f"reward pattern {self.name!r}: {f.name} must be a number, got {value!r}")
            if not math.isfinite(float(value)) or abs(float(value)) > MAX_REWARD:
                raise ValueError(f"reward pattern {self.name!r}: {f.name} must be finite and in [-{MAX_REWARD}, "
                                 f"{MAX_REWARD}], got {value!r}")
            object.__setattr__(self, f.name, float(value))
        for mode_field in ("looping_mode", "terminal_mode"):
            value = getattr(self, mode_field)
            if value not in COMBINE_MODES:
                raise ValueError(f"reward pattern {self.name!r}: unknown {mode_field} {value!r}; "
                                 f"allowed: {', '.join(COMBINE_MODES)}")
        memory = self.looping_memory
        if not is_integer(memory) or not (
                memory == EPISODE_LOOPING_MEMORY or memory >= PAPER_LOOPING_MEMORY):
            raise ValueError(f"reward pattern {self.name!r}: looping_memory must be an integer >= "
                             f"{PAPER_LOOPING_MEMORY} (states of the episode) or {EPISODE_LOOPING_MEMORY} (the whole "
                             f"episode), got {memory!r}")
        object.__setattr__(self, "looping_memory", int(memory))
        object.__setattr__(self, "_values", tuple(self._compute_outcome_values()))

    # -- values ---------------------------------------------------------------
    def outcome_values(self) -> np.ndarray:
        """Reward per outcome, shape ``(len(Outcome),)`` float64, indexed by ``Outcome``.

        The looping penalty is not included (it depends on the state history).
        """
        return np.array(self._values, dtype=np.float64)

    def _compute_outcome_values(self) -> np.ndarray:
        values = np.zeros(N_OUTCOMES, dtype=np.float64)
        values[Outcome.ROUTINE] = self.routine
        values[Outcome.INEFFECTIVE] = self.irrelevant_clean if self.ineffective is None else self.ineffective
        values[Outcome.RELEVANT_CLEAN] = self.relevant_clean
        values[Outcome.IRRELEVANT_CLEAN] = self.irrelevant_clean
        values[Outcome.IMPROPER] = self.improper
        terminal = self.terminal
        if self.terminal_mode == "add":
            terminal += self.relevant_clean
        values[Outcome.TERMINAL] = terminal
        return values

    @property
    def looping_code(self) -> int:
        """``LOOPING_OFF``, ``LOOPING_REPLACE`` or ``LOOPING_ADD`` for compiled learners."""
        if self.looping_penalty is None:
            return LOOPING_OFF
        return LOOPING_ADD if self.looping_mode == "add" else LOOPING_REPLACE

    @property
    def paper_looping(self) -> bool:
        """Whether the looping rule (if any) is the paper's: memory of s_t and s_{t-1} only."""
        return self.looping_memory == PAPER_LOOPING_MEMORY

    def reward(self, outcome: int, state: int, next_state: int, previous_state: int = -1, history=None) -> float:
        """The reward of one transition (pure).  A routine or ineffective step loops when its next state is
        among the episode's last ``looping_memory`` states (all of them for ``EPISODE_LOOPING_MEMORY``).

        Args:
            outcome: the [`Outcome`][tableclean_suite.task.state.Outcome] of the action.
            state, next_state: state codes s_t and s_{t+1}.
            previous_state: s_{t-1}, or -1 at an episode's first step.
            history: the episode's states s_0 .. s_t (s_t last); needed when the pattern's
                ``looping_memory`` is not the paper's (which ``previous_state`` covers).
        """
        value = self._values[int(outcome)]
        if self.looping_penalty is None:
            return value
        if history is None:
            if not self.paper_looping:
                raise ValueError(f"reward pattern {self.name!r} looks back {self.looping_memory or 'the whole episode'} "
                                 "states for its looping penalty: pass history= (the episode's states so far)")
            history = (state,) if previous_state < 0 else (previous_state, state)
        recent = history if self.looping_memory == EPISODE_LOOPING_MEMORY else history[-self.looping_memory:]
        if int(outcome) in LOOPABLE_OUTCOMES and next_state in recent:
            value = value + self.looping_penalty if self.looping_code == LOOPING_ADD else self.looping_penalty
        return value

    def step_reward_bounds(self) -> tuple[float, float]:
        """``(low, high)``: bounds on one step's reward, every component that can combine added (the
        negative ones for ``low``, the positive ones for ``high``), so an average reward per step of
        any behaviour lies within them."""
        components = [self.terminal, self.relevant_clean, self.irrelevant_clean, self.routine, self.improper,
                      self.ineffective or 0.0, self.looping_penalty or 0.0]
        return sum(min(0.0, v) for v in components), sum(max(0.0, v) for v in components)

    def as_row(self) -> dict:
        """A Table 2 style row (``None`` for a disabled looping penalty)."""
        return {
            "reward": self.name,
            "terminal_state": self.terminal,
            "relevant_cleaning": self.relevant_clean,
            "irrelevant_cleaning": self.irrelevant_clean,
            "pick_place_move": self.routine,
            "improper_actions": self.improper,
            "looping_penalty": self.looping_penalty,
            "looping_rule": self.looping_rule_text() if self.looping_penalty is not None else None,
        }

    def looping_rule_text(self) -> str:
        """What the looping rule compares s_{t+1} with: ``"s_t, s_t-1"`` (the paper's),
        ``"last k states"`` or ``"the episode"``."""
        if self.paper_looping:
            return "s_t, s_t-1"
        if self.looping_memory == EPISODE_LOOPING_MEMORY:
            return "the episode"
        return f"last {self.looping_memory} states"


PAPER_REWARD_PATTERNS = (
    RewardPattern(
        "r1", TERMINAL_REWARD, SMALL_PENALTY, SMALL_PENALTY, SMALL_PENALTY, IMPROPER_PENALTY,
        description="reward only at the terminal state (as in Cruz et al.)",
    ),
    RewardPattern(
        "r2", TERMINAL_REWARD, RELEVANT_CLEAN_REWARD, SMALL_PENALTY, SMALL_PENALTY, IMPROPER_PENALTY,
        description="r1 plus a reward for each relevant clean (intermediate success)",
    ),
    RewardPattern(
        "r3", TERMINAL_REWARD, RELEVANT_CLEAN_REWARD, SMALL_PENALTY, SMALL_INCENTIVE, IMPROPER_PENALTY,
        description="r2 with a small incentive for routine actions",
    ),
    RewardPattern(
        "r4", TERMINAL_REWARD, RELEVANT_CLEAN_REWARD, SMALL_PENALTY, SMALL_INCENTIVE, IMPROPER_PENALTY,
        looping_penalty=SMALL_PENALTY,
        description="r3 plus a looping penalty relating two consecutive states",
    ),
)

#: r4 with the looping rule for any N: the penalty for every routine step that returns to a state
#: the episode already visited (a MOVE round the ring of N >= 3 segments too).
R4_CYCLE = RewardPattern(
    "r4_cycle", TERMINAL_REWARD, RELEVANT_CLEAN_REWARD, SMALL_PENALTY, SMALL_INCENTIVE, IMPROPER_PENALTY,
    looping_penalty=SMALL_PENALTY, looping_memory=EPISODE_LOOPING_MEMORY,
    description="r4 with the looping penalty for any return to a state visited in the episode (any N)",
)

_REGISTRY: Registry[RewardPattern] = Registry("reward pattern", RewardPattern, (*PAPER_REWARD_PATTERNS, R4_CYCLE))


def register_reward_pattern(pattern: RewardPattern, overwrite: bool = False) -> RewardPattern:
    """Add a user pattern to the registry so ``train(reward="name")`` and the CLI find it."""
    return _REGISTRY.register(pattern, overwrite)


def reward_pattern_names() -> list[str]:
    """Registered pattern names, in registration order."""
    return _REGISTRY.names()


def get_reward_pattern(reward: str | RewardPattern) -> RewardPattern:
    """A pattern by registered name, or the pattern itself; clear error otherwise."""
    return _REGISTRY.get(reward)
