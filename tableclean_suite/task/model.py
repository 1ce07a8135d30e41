"""The task model: the rules of a [`TaskSpec`][tableclean_suite.task.spec.TaskSpec], deterministic and pure."""

from __future__ import annotations

import time
from functools import cached_property
from pathlib import Path
from typing import Iterable, Iterator, Sequence, Union

import numpy as np

from tableclean_suite import resources
from tableclean_suite.task import actions as actions_module
from tableclean_suite.task.actions import Action, ActionRule, get_action_rule
from tableclean_suite.task.spec import IneffectiveMode, StartMode, TaskSpec, get_task_spec
from tableclean_suite.task.state import (
    CLEAN_OUTCOMES,
    HELD,
    NO_CHANGE_OUTCOMES,
    Outcome,
    TaskState,
    decode_code,
    encode,
    is_integer,
    unclean_layouts,
)

StateLike = Union[TaskState, int, np.integer]

#: The built-in actions' names in [`Action`][tableclean_suite.task.actions.Action] order (the paper's action list).
_BUILTIN_ORDER = tuple(a.rule_name for a in Action)
#: States whose user action effects a table build times (after a first, warming-up state) to
#: estimate the rest ([`require_effect_seconds`][tableclean_suite.resources.require_effect_seconds]).
EFFECT_TIMING_STATES = 8


class ActionEffectError(resources.ResourceError):
    """A (user) action's effect failed (raised, returned something else than ``(TaskState, Outcome)``)
    or broke the rules an effect must keep; the message names the action and the state."""


class UnlearnableTaskError(resources.ResourceError):
    """No terminal state can be reached from a start state of the task: nothing could be learned."""


class TaskModel:
    """The table-cleaning task of a [`TaskSpec`][tableclean_suite.task.spec.TaskSpec] as a deterministic model.

    N >= 2 segments (clean or unclean), M >= 1 objects (on a segment or held), the arm above one
    segment; the goal is every segment clean.  The paper's task is the ``paper`` spec (N = 2, M = 1).

    - Actions: the spec's, in its order (the paper's: 0 MOVE, 1 PICK, 2 PLACE, 3 CLEAN); the order
      breaks greedy ties.  Each follows its registered effect
      ([`ActionRule`][tableclean_suite.task.actions.ActionRule]); an INEFFECTIVE effect counts as
      IMPROPER with ``ineffective="improper"``, and any action that leaves every segment clean is
      TERMINAL.  IMPROPER, INEFFECTIVE and IRRELEVANT_CLEAN leave the state unchanged.
    - States: ``2**N * (N + 1)**M * N`` codes ([`encode`][tableclean_suite.task.state.encode]); for the
      paper 24, of which 20 are reachable from the all-unclean starts
      ([`reachable_states`][tableclean_suite.task.model.TaskModel.reachable_states]).
    - Starts: ``"fixed"`` (the spec's start state; default all unclean, objects and arm on segment 1)
      or ``"uniform_unclean"`` (uniform over the ``N**M * N`` all-unclean layouts, nothing held).

    Args:
        ineffective: ``"ineffective"`` or ``"improper"``; None keeps the spec's.
        start: ``"fixed"`` or ``"uniform_unclean"``; None keeps the spec's.
        start_state: a [`TaskState`][tableclean_suite.task.state.TaskState] or code; only with ``start="fixed"``.
        spec: a registered name (default ``"paper"``), a [`TaskSpec`][tableclean_suite.task.spec.TaskSpec],
            a ``.json`` spec or a ``.pddl`` problem.

    Raises:
        ValueError: an unknown spec, mode or start state (the message names the allowed ones).
    """

    def __init__(self, ineffective: str | None = None, start: str | None = None,
                 start_state: StateLike | None = None, *, spec: "str | Path | TaskSpec | None" = None):
        base = get_task_spec(spec)
        changes = {}
        if ineffective is not None:
            changes["ineffective"] = ineffective
        if start is not None:
            changes["start"] = start
            if start_state is None:
                changes["start_state"] = None  # a new start mode drops the spec's fixed state
        if start_state is not None:
            changes["start_state"] = start_state if isinstance(start_state, TaskState) else \
                decode_code(start_state, base.segments, base.n_objects)
        self.spec: TaskSpec = base.replace(**changes) if changes else base
        self.ineffective = IneffectiveMode(self.spec.ineffective)
        self.start = StartMode(self.spec.start)
        self.start_state: TaskState = self.spec.initial_state
        self.n_segments: int = self.spec.segments
        self.n_objects: int = self.spec.n_objects
        self.actions: tuple[ActionRule, ...] = tuple(get_action_rule(a) for a in self.spec.actions)
        self.action_names: tuple[str, ...] = self.spec.actions
        self.n_actions: int = len(self.actions)
        self.n_states: int = self.spec.n_states
        self._action_index = {name: i for i, name in enumerate(self.action_names)}

    def __repr__(self) -> str:
        start = self.start.value if self.start == StartMode.UNIFORM_UNCLEAN else self.start_state.name
        if self.spec.name == "paper" and self.spec.actions == get_task_spec("paper").actions:
            return f"TaskModel(ineffective={self.ineffective.value!r}, start={start!r})"
        return (f"TaskModel(spec={self.spec.name!r}, segments={self.n_segments}, objects={list(self.spec.objects)}, "
                f"actions={list(self.action_names)}, ineffective={self.ineffective.value!r}, start={start!r})")

    # -- codes -----------------------------------------------------------------------
    def decode(self, code: int) -> TaskState:
        """The state of ``code``; ``ValueError`` outside ``range(n_states)``."""
        return decode_code(code, self.n_segments, self.n_objects)

    def as_state(self, state: StateLike) -> TaskState:
        """Accept a [`TaskState`][tableclean_suite.task.state.TaskState] of this spec's sizes or its code."""
        if isinstance(state, TaskState):
            self._check_sizes(state)
            return state
        return self.decode(state)

    def _check_sizes(self, state: TaskState) -> None:
        if state.n_segments != self.n_segments or state.n_objects != self.n_objects:
            raise ValueError(f"state {state.name} has {state.n_segments} segments and {state.n_objects} objects; "
                             f"task {self.spec.name!r} has {self.n_segments} and {self.n_objects}")

    def all_states(self) -> list[TaskState]:
        """Every code's state, in code order; [`ResourceError`][tableclean_suite.resources.ResourceError]
        for specs too large to list in Python."""
        self._require_python_walk("listing every state")
        return [self.decode(code) for code in range(self.n_states)]

    def _require_python_walk(self, what: str) -> None:
        resources.require_python_steps(self.n_states * self.n_actions,
                                       f"{what} of task {self.spec.name!r} ({self.n_states} states)")

    @property
    def record_dtype(self) -> np.dtype:
        """Smallest signed int dtype that holds every state, action and outcome code."""
        largest = max(self.n_states, self.n_actions, len(Outcome)) - 1  # at most int32's (TaskSpec checks)
        return np.dtype(np.min_scalar_type(-largest - 1))  # a signed type: the smallest holding -largest - 1

    # -- actions -----------------------------------------------------------------------
    def action_index(self, action) -> int:
        """Index of ``action`` (an index, a name, an [`Action`][tableclean_suite.task.actions.Action] or an
        [`ActionRule`][tableclean_suite.task.actions.ActionRule]); ``ValueError`` names the spec's actions."""
        if isinstance(action, Action):
            action = action.rule_name
        if isinstance(action, ActionRule):
            action = action.name
        if isinstance(action, str):
            key = action.strip().lower()
            if key in self._action_index:
                return self._action_index[key]
        elif is_integer(action):
            if 0 <= int(action) < self.n_actions:
                return int(action)
        allowed = ", ".join(f"{i}/{name}" for i, name in enumerate(self.action_names))
        raise ValueError(f"unknown action {action!r} for task {self.spec.name!r}; allowed: {allowed}")

    def action_name(self, action) -> str:
        """The name of ``action`` (index, name or rule)."""
        return self.action_names[self.action_index(action)]

    # -- rules -------------------------------------------------------------------------
    def step(self, state: StateLike, action) -> tuple[TaskState, Outcome]:
        """``(next_state, outcome)`` of ``action`` in ``state`` (the same state for improper and
        ineffective actions); ``ValueError`` for a terminal ``state``."""
        next_state, outcome = self._apply(state, action)
        if outcome == Outcome.INEFFECTIVE and self.ineffective == IneffectiveMode.IMPROPER:
            outcome = Outcome.IMPROPER
        if next_state.is_terminal:
            outcome = Outcome.TERMINAL
        return next_state, outcome

    def _apply(self, state: StateLike, action) -> tuple[TaskState, Outcome]:
        """The action's effect as its rule reports it (before the ineffective and terminal conventions)."""
        state = self.as_state(state)
        index = self.action_index(action)
        if state.is_terminal:
            raise ValueError(f"state {state.index} ({state.name}) is terminal; reset before stepping")
        rule = self.actions[index]
        if rule.effect in actions_module.DIGIT_RULES:  # a built-in rule: read off its table of every code
            next_state, _, raw_outcome = self._transition_arrays
            code = encode(state)
            return self.decode(int(next_state[code, index])), Outcome(int(raw_outcome[code, index]))
        what = f"action {rule.name!r} in state {state.name}"
        try:
            result = rule.effect(state)
        except (KeyboardInterrupt, SystemExit):
            raise
        except BaseException as error:  # a plugin's fault, whatever its kind: one line naming it
            raise ActionEffectError(f"{what}: its effect raised {type(error).__name__}: "
                                    f"{' '.join(str(error).split())[:200]}") from None
        next_state, outcome = result if isinstance(result, tuple) and len(result) == 2 else (result, None)
        if not isinstance(next_state, TaskState) or not isinstance(outcome, (int, np.integer)) \
                or outcome not in Outcome._value2member_map_ \
                or Outcome(outcome) == Outcome.TERMINAL:
            raise ActionEffectError(f"{what}: an effect returns (TaskState, a non-terminal Outcome), got "
                                    f"{' '.join(repr(result).split())[:200]}")
        outcome = Outcome(outcome)
        try:
            self._check_sizes(next_state)
        except ValueError as error:
            raise ActionEffectError(f"{what}: {error}") from None
        if outcome in NO_CHANGE_OUTCOMES and next_state != state:
            raise ActionEffectError(f"{what}: outcome {outcome.name} must leave the state unchanged "
                                    f"({state.name} -> {next_state.name})")
        if next_state.objects.count(HELD) > max(1, state.objects.count(HELD)):  # unused codes may already hold two
            raise ActionEffectError(f"{what}: {next_state.name} holds more than one object")
        return next_state, outcome

    def action_mask(self, state: StateLike) -> np.ndarray:
        """Shape ``(n_actions,)`` int8: 1 where the action is not improper in ``state`` (all 0 at terminal)."""
        state = self.as_state(state)
        if state.is_terminal:
            return np.zeros(self.n_actions, dtype=np.int8)
        return np.array([self.step(state, a)[1] != Outcome.IMPROPER for a in range(self.n_actions)], dtype=np.int8)

    def classify(self, state: StateLike, action, next_state: StateLike) -> Outcome:
        """The outcome of an *observed* transition ``state --action--> next_state`` (physics, where it
        may differ from the model's prediction): IMPROPER as the model says; TERMINAL on reaching a
        terminal state; a cleaning action RELEVANT_CLEAN if some segment became clean, else
        IRRELEVANT_CLEAN; any other action ROUTINE when the state changed, else ineffective."""
        state, next_state = self.as_state(state), self.as_state(next_state)
        if self.step(state, action)[1] == Outcome.IMPROPER:
            return Outcome.IMPROPER
        if next_state.is_terminal and not state.is_terminal:
            return Outcome.TERMINAL
        if self._apply(state, action)[1] in CLEAN_OUTCOMES:
            newly_clean = any(next_state.clean[k] and not state.clean[k] for k in range(self.n_segments))
            return Outcome.RELEVANT_CLEAN if newly_clean else Outcome.IRRELEVANT_CLEAN
        if next_state != state:
            return Outcome.ROUTINE
        return Outcome.IMPROPER if self.ineffective == IneffectiveMode.IMPROPER else Outcome.INEFFECTIVE

    # -- starts ------------------------------------------------------------------------
    def unclean_layouts(self) -> list[TaskState]:
        """Every all-unclean layout with nothing held (code order)."""
        return unclean_layouts(self.n_segments, self.n_objects)

    def start_states(self) -> list[TaskState]:
        """The states an episode can start in (one for ``fixed``, every layout for ``uniform_unclean``)."""
        if self.start == StartMode.UNIFORM_UNCLEAN:
            return self.unclean_layouts()
        return [self.start_state]

    def sample_start(self, uniform: float) -> TaskState:
        """The start state picked by a uniform draw in [0, 1)."""
        starts = self.start_states()
        return starts[min(int(uniform * len(starts)), len(starts) - 1)]

    # -- tables for fast learners ---------------------------------------------------------
    def transition_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """``(next_state, outcome)``, each ``(n_states, n_actions)`` int64 (copies of a table built once);
        terminal states map to themselves with outcome TERMINAL."""
        next_state, outcome, _ = self._transition_arrays
        return next_state.copy(), outcome.copy()

    @cached_property
    def _transition_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Built-in actions from every code at once ([`batch_rules`][tableclean_suite.task.batch_rules]), user
        actions state by state; the third array (int8) is the built-in rules' own outcomes, before the
        model's conventions.  [`ResourceError`][tableclean_suite.resources.ResourceError] before
        allocating when the arrays would not fit in memory or user effects would take too long."""
        from tableclean_suite.task import batch_rules

        what = f"the transition table of task {self.spec.name!r} ({self.n_states} states x {self.n_actions} actions)"
        resources.require_memory(resources.table_memory(self.n_states, self.n_actions), what)
        user = [a for a, rule in enumerate(self.actions) if rule.effect not in actions_module.DIGIT_RULES]
        resources.require_effect_calls(self.n_states * len(user), what)
        next_state = np.empty((self.n_states, self.n_actions), dtype=np.int64)
        outcome = np.empty((self.n_states, self.n_actions), dtype=np.int64)
        raw_outcome = np.zeros((self.n_states, self.n_actions), dtype=np.int8)
        digits = batch_rules.StateDigits(self.n_segments, self.n_objects, self.n_states)
        improper = self.ineffective == IneffectiveMode.IMPROPER
        for a, rule in enumerate(self.actions):
            if a not in user:
                next_state[:, a], outcome[:, a], raw_outcome[:, a] = batch_rules.batch_step(
                    digits, actions_module.DIGIT_RULES[rule.effect], improper)
        terminal = digits.terminal
        del digits
        if user:
            next_state[terminal, :] = np.flatnonzero(terminal)[:, None]
            outcome[terminal, :] = Outcome.TERMINAL
            codes = np.flatnonzero(~terminal)
            for i, code in enumerate(codes):
                if i == 1:
                    started = time.perf_counter()
                elif i == 1 + EFFECT_TIMING_STATES:
                    seconds = (time.perf_counter() - started) / EFFECT_TIMING_STATES * len(codes)
                    resources.require_effect_seconds(seconds, what)
                state = self.decode(int(code))
                for a in user:
                    nxt, out = self.step(state, a)
                    next_state[code, a] = encode(nxt)
                    outcome[code, a] = out
        return next_state, outcome, raw_outcome

    # -- analysis ------------------------------------------------------------------------
    def successors(self, state: StateLike) -> Iterator[tuple[int, TaskState, Outcome]]:
        """``(action index, next_state, outcome)`` for every action from ``state`` (off the transition table)."""
        code = encode(self.as_state(state))
        next_state, outcome, _ = self._transition_arrays
        for a in range(self.n_actions):
            yield a, self.decode(int(next_state[code, a])), Outcome(int(outcome[code, a]))

    def reachable_states(self, starts: Iterable[StateLike] | None = None) -> list[TaskState]:
        """States reachable from ``starts`` (default: every all-unclean layout), sorted by code, terminal
        ones included; [`ResourceError`][tableclean_suite.resources.ResourceError] for specs too large
        to search in Python."""
        self._require_python_walk("the reachable-state search")
        starts = starts if starts is not None else self.unclean_layouts()
        frontier = np.array([encode(self.as_state(s)) for s in starts], dtype=np.int64)
        seen = np.zeros(self.n_states, dtype=bool)
        seen[frontier] = True
        while frontier.size:  # terminal codes map to themselves: already seen
            reached = np.unique(self._transition_arrays[0][frontier])
            frontier = reached[~seen[reached]]
            seen[frontier] = True
        return [self.decode(int(code)) for code in np.flatnonzero(seen)]

    def shortest_plan(self, state: StateLike) -> list[Action | int] | None:
        """A shortest action sequence from ``state`` to a terminal state (``[]`` if terminal), the
        first in the spec's action order among equally short ones; ``None`` if no terminal state is
        reachable.  Actions are [`Action`][tableclean_suite.task.actions.Action] members when the
        spec's actions are the paper's four, else indices."""
        code = encode(self.as_state(state))
        next_state, distance, policy = self._transition_arrays[0], self._distances, self._optimal_policy
        if distance[code] < 0:
            return None
        plan = []
        while distance[code] > 0:
            plan.append(Action(int(policy[code])) if self.action_names == _BUILTIN_ORDER else int(policy[code]))
            code = int(next_state[code, policy[code]])
        return plan

    def shortest_plan_lengths(self, states: Sequence[StateLike] | None = None) -> dict[int, int | None]:
        """Shortest plan length per state code (default: every reachable state), None where no
        terminal state is reachable (from [`distances_to_terminal`][tableclean_suite.task.model.TaskModel.distances_to_terminal])."""
        states = self.reachable_states() if states is None else [self.as_state(s) for s in states]
        distance = self._distances
        return {encode(s): (int(distance[encode(s)]) if distance[encode(s)] >= 0 else None) for s in states}

    def require_learnable(self) -> None:
        """Raise [`UnlearnableTaskError`][tableclean_suite.task.model.UnlearnableTaskError] naming the task and
        the first start state from which no terminal state can be reached (builds the transition table)."""
        distance = self._distances
        stuck = next((s for s in self.start_states() if distance[encode(s)] < 0), None)
        if stuck is not None:
            raise UnlearnableTaskError(f"task {self.spec.name!r}: no terminal state can be reached from its start "
                                       f"state {stuck.name} with the actions {', '.join(self.action_names)}; nothing "
                                       "can be learned")

    def distances_to_terminal(self) -> np.ndarray:
        """``(S,)`` int64: the length of a shortest plan from every state code to a terminal state (0 for
        terminal states, -1 where none is reachable), by a backward breadth-first search."""
        return self._distances.copy()

    @cached_property
    def _distances(self) -> np.ndarray:
        next_state, outcome, _ = self._transition_arrays
        codes = np.arange(self.n_states)
        terminal = (next_state == codes[:, None]).all(axis=1) & (outcome == Outcome.TERMINAL).all(axis=1)
        distance = np.where(terminal, 0, -1).astype(np.int64)
        length = 0
        while True:
            reached = (distance == -1) & (distance[next_state] == length).any(axis=1)
            if not reached.any():
                return distance
            length += 1
            distance[reached] = length

    def optimal_policy(self) -> np.ndarray:
        """``(S,)`` int64: in each state code with a shortest plan of d > 0 steps, the first action in the
        spec's order whose successor is d - 1 steps from a terminal state (so following it is
        [`shortest_plan`][tableclean_suite.task.model.TaskModel.shortest_plan]); action 0 elsewhere."""
        return self._optimal_policy.copy()

    @cached_property
    def _optimal_policy(self) -> np.ndarray:
        distance = self._distances
        closer = (distance[self._transition_arrays[0]] == (distance - 1)[:, None]) & (distance[:, None] > 0)
        return np.where(closer.any(axis=1), np.argmax(closer, axis=1), 0).astype(np.int64)

    def rollout(self, state: StateLike, actions: Iterable) -> list[TaskState]:
        """The states visited by applying ``actions`` from ``state`` (including ``state``)."""
        visited = [self.as_state(state)]
        for action in actions:
            visited.append(self.step(visited[-1], action)[0])
        return visited

    def table1_mapping(self) -> dict:
        """How Table 1 of the paper relates to this model (2 segments, 1 object only): ``{"rows": Table 1
        number -> state code, "unreachable_rows": numbers never reachable from an all-unclean start,
        "omitted_reachable": codes of reachable states Table 1 omits, "omitted_on_paper_plan": those
        the paper's optimal sequence from state 4 passes through}``."""
        from tableclean_suite.task.paper import PAPER_OPTIMAL_PLAN, PAPER_START, TABLE1_STATES

        if (self.n_segments, self.n_objects) != (2, 1):
            raise ValueError(f"Table 1 describes 2 segments and 1 object; task {self.spec.name!r} has "
                             f"{self.n_segments} and {self.n_objects}")
        reachable = set(self.reachable_states())
        listed = set(TABLE1_STATES.values())
        paper_plan_states = set(self.rollout(PAPER_START, [a.rule_name for a in PAPER_OPTIMAL_PLAN]))
        omitted = sorted((s for s in reachable if s not in listed), key=encode)
        return {
            "rows": {number: state.index for number, state in TABLE1_STATES.items()},
            "unreachable_rows": sorted(n for n, s in TABLE1_STATES.items() if s not in reachable),
            "omitted_reachable": [s.index for s in omitted],
            "omitted_on_paper_plan": [s.index for s in omitted if s in paper_plan_states],
        }


def as_task_model(task: "TaskModel | TaskSpec | str | Path | None" = None) -> TaskModel:
    """A model from a model, a spec, a registered name or a ``.json`` path (None: ``paper``)."""
    if isinstance(task, TaskModel):
        return task
    return TaskModel(spec=task)
