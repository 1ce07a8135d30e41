"""Task-level actions as data: a name and a symbolic effect, in a registry users extend.

An action's *effect* is a pure function ``TaskState -> (TaskState, Outcome)`` written
for any number of segments and objects.  It reports INEFFECTIVE when nothing happens
for lack of an object (the model turns that into IMPROPER under
``ineffective="improper"``) and never reports TERMINAL: the model does, whenever an
effect leaves every segment clean.  A [`TaskSpec`][tableclean_suite.task.spec.TaskSpec] lists
its actions by registered name, in the order learners index them.

Adding an action from outside the package:

    from tableclean_suite.task import ActionRule, Outcome, register_action

    def move_back(state):
        return state.replace(arm=(state.arm - 1) % state.n_segments), Outcome.ROUTINE

    register_action(ActionRule("move_back", move_back, "the arm goes to the previous segment"))
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from tableclean_suite.registry import NAME_PATTERN, Registry
from tableclean_suite.task import batch_rules
from tableclean_suite.task.state import Outcome, TaskState, decode_code, encode

Effect = Callable[[TaskState], "tuple[TaskState, Outcome]"]


class Action(enum.IntEnum):
    """The four built-in actions, in the paper's order (their indices in the ``paper`` spec; greedy
    ties break towards the lowest).  In a spec with another action list, use
    ``TaskModel.action_index(name)`` for indices."""

    MOVE = 0
    PICK = 1
    PLACE = 2
    CLEAN = 3

    @property
    def rule_name(self) -> str:
        """The registered [`ActionRule`][tableclean_suite.task.actions.ActionRule] name (``"move"``, ...)."""
        return self.name.lower()


def _apply_digit_rule(rule, state: TaskState) -> tuple[TaskState, Outcome]:
    """A built-in rule of [`batch_rules`][tableclean_suite.task.batch_rules] applied to one state."""
    n_segments, n_objects = state.n_segments, state.n_objects
    digits = batch_rules.StateDigits(n_segments, n_objects, 1, codes=np.array([encode(state)]))
    next_code, outcome = rule(digits)
    return decode_code(int(next_code[0]), n_segments, n_objects), Outcome(int(outcome[0]))


def move_effect(state: TaskState) -> tuple[TaskState, Outcome]:
    """MOVE: the arm goes to the next segment, k -> k + 1 (N -> 1); a held object goes along."""
    return _apply_digit_rule(batch_rules.move, state)


def pick_effect(state: TaskState) -> tuple[TaskState, Outcome]:
    """PICK: with nothing held, the lowest-numbered object on the arm's segment is held."""
    return _apply_digit_rule(batch_rules.pick, state)


def place_effect(state: TaskState) -> tuple[TaskState, Outcome]:
    """PLACE: the held object comes to lie on the arm's segment."""
    return _apply_digit_rule(batch_rules.place, state)


def clean_effect(state: TaskState) -> tuple[TaskState, Outcome]:
    """CLEAN: improper when holding or when any object lies on the arm's segment; else the
    arm's segment becomes clean (relevant) or already was (irrelevant)."""
    return _apply_digit_rule(batch_rules.clean, state)


#: The built-in effects and their rules on code digits, by identity (another effect registered under
#: a built-in name is stepped state by state, as a user's).
DIGIT_RULES = {move_effect: batch_rules.move, pick_effect: batch_rules.pick, place_effect: batch_rules.place,
               clean_effect: batch_rules.clean}


@dataclass(frozen=True)
class ActionRule:
    """A task-level action.

    Attributes:
        name: registry key, lower_snake (``"move"``, ``"move_back"``).
        effect: pure ``TaskState -> (TaskState, Outcome)`` for any N and M; the outcome
            is one of ROUTINE, INEFFECTIVE, RELEVANT_CLEAN, IRRELEVANT_CLEAN, IMPROPER
            (INEFFECTIVE, IRRELEVANT_CLEAN and IMPROPER must leave the state unchanged).
        description: one line for ``--describe`` and the docs.
        pddl: the action's PDDL schema ``"(:action NAME ...)"`` in the vocabulary of
            [`tableclean_suite.task.pddl`][tableclean_suite.task.pddl], or ``{"strips": ..., "adl": ...}``
            when the two forms differ; None: a spec with this action is refused at export.
    """

    name: str
    effect: Effect
    description: str = field(default="", compare=False)
    pddl: "str | dict | None" = field(default=None, compare=False)

    def __post_init__(self):
        if not isinstance(self.name, str) or not NAME_PATTERN.match(self.name):
            raise ValueError(f"action name must be lower_snake (e.g. 'move_back'), got {self.name!r}")
        if not callable(self.effect):
            raise TypeError(f"action {self.name!r}: effect must be callable TaskState -> (TaskState, Outcome)")
        if not (self.pddl is None or isinstance(self.pddl, str)
                or (isinstance(self.pddl, dict) and set(self.pddl) == {"strips", "adl"})):
            raise ValueError(f"action {self.name!r}: pddl must be a schema string or {{'strips': ..., 'adl': ...}}, "
                             f"got {self.pddl!r}")


BUILTIN_ACTIONS = (
    ActionRule("move", move_effect, "the arm goes to the next segment (N -> 1); a held object goes along"),
    ActionRule("pick", pick_effect, "grasp the lowest-numbered object on the arm's segment"),
    ActionRule("place", place_effect, "put the held object down on the arm's segment"),
    ActionRule("clean", clean_effect, "wipe the arm's segment (improper when holding or an object lies there)"),
)

_REGISTRY: Registry[ActionRule] = Registry("action", ActionRule, BUILTIN_ACTIONS)


def register_action(rule: ActionRule, overwrite: bool = False) -> ActionRule:
    """Add a user action so task specs can list it by name."""
    return _REGISTRY.register(rule, overwrite)


def action_names() -> list[str]:
    """Registered action names, in registration order."""
    return _REGISTRY.names()


def get_action_rule(action: str | ActionRule) -> ActionRule:
    """An action by registered name (or the rule itself); ``ValueError`` names the allowed ones."""
    if isinstance(action, Action):
        action = action.rule_name
    return _REGISTRY.get(action)
