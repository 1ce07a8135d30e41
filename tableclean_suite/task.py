"""The symbolic table-cleaning task of the paper (Sec. 2, Table 1, Algorithm 1).

Pure Python/NumPy; knows nothing of MuJoCo.  Everything else in the package
(rewards, learners, the robosuite environment's abstraction, the skills) speaks
in the names defined here: :class:`Action`, :class:`Segment`,
:class:`ObjectLocation`, :class:`Outcome`, :class:`TaskState` and
:class:`TaskModel`.
"""

from __future__ import annotations

import enum
from collections import deque
from dataclasses import dataclass
from typing import Iterable, Iterator, Sequence, Union

import numpy as np


class Action(enum.IntEnum):
    """The four task-level actions, in the paper's order.

    The order matters: greedy action selection breaks ties towards the
    lowest value, i.e. MOVE first, as an ``argmax`` over a zero-initialised
    Q-table does.
    """

    MOVE = 0
    PICK = 1
    PLACE = 2
    CLEAN = 3


class Segment(enum.IntEnum):
    """A table segment; the value is the 0-based index, the name the paper's 1-based one."""

    SEGMENT_1 = 0
    SEGMENT_2 = 1

    @property
    def number(self) -> int:
        """The paper's 1-based segment number (1 or 2)."""
        return int(self) + 1

    @property
    def other(self) -> "Segment":
        """The segment the arm reaches by a MOVE from this one."""
        return Segment(1 - int(self))

    @classmethod
    def from_number(cls, number: int) -> "Segment":
        """Segment from the paper's 1-based number; raises ``ValueError`` for anything but 1 or 2."""
        if isinstance(number, bool) or number not in (1, 2):
            raise ValueError(f"segment must be 1 or 2, got {number!r}")
        return cls(int(number) - 1)


class ObjectLocation(enum.IntEnum):
    """Where the single object is: lying on a segment, or held in the gripper."""

    ON_SEGMENT_1 = 0
    ON_SEGMENT_2 = 1
    IN_GRIPPER = 2

    @classmethod
    def on(cls, segment: Segment) -> "ObjectLocation":
        """The location 'lying on ``segment``'."""
        return cls(int(segment))


class Outcome(enum.IntEnum):
    """What an action did; reward patterns assign a value to each outcome.

    - ROUTINE: an effective move, pick or place.
    - INEFFECTIVE: a pick with nothing to pick or a place with nothing held;
      the state does not change.
    - RELEVANT_CLEAN: cleaning an unclean segment that leaves the other one unclean.
    - IRRELEVANT_CLEAN: cleaning an already clean segment.
    - IMPROPER: cleaning while holding the object or where the object lies
      (Algorithm 1's failed state: the state does not change).
    - TERMINAL: the relevant clean that leaves both segments clean.
    """

    ROUTINE = 0
    INEFFECTIVE = 1
    RELEVANT_CLEAN = 2
    IRRELEVANT_CLEAN = 3
    IMPROPER = 4
    TERMINAL = 5


N_ACTIONS = len(Action)
N_OUTCOMES = len(Outcome)
N_SEGMENTS = len(Segment)
N_OBJECT_LOCATIONS = len(ObjectLocation)
_CLEAN_RADIX = 2  # a segment is unclean (0) or clean (1)
N_STATES = _CLEAN_RADIX * _CLEAN_RADIX * N_OBJECT_LOCATIONS * N_SEGMENTS


@dataclass(frozen=True, order=True)
class TaskState:
    """One symbolic state: cleanliness of both segments, object location, arm segment.

    Attributes:
        segment1_clean: whether segment 1 is clean.
        segment2_clean: whether segment 2 is clean.
        object_location: where the object is (:class:`ObjectLocation`).
        arm_segment: which segment the arm is above (:class:`Segment`).
    """

    segment1_clean: bool
    segment2_clean: bool
    object_location: ObjectLocation
    arm_segment: Segment

    def __post_init__(self):
        object.__setattr__(self, "segment1_clean", bool(self.segment1_clean))
        object.__setattr__(self, "segment2_clean", bool(self.segment2_clean))
        object.__setattr__(self, "object_location", ObjectLocation(self.object_location))
        object.__setattr__(self, "arm_segment", Segment(self.arm_segment))

    # -- derived facts -------------------------------------------------------
    def is_clean(self, segment: Segment) -> bool:
        """Whether ``segment`` is clean."""
        return self.segment1_clean if Segment(segment) == Segment.SEGMENT_1 else self.segment2_clean

    @property
    def holding(self) -> bool:
        """Whether the gripper holds the object."""
        return self.object_location == ObjectLocation.IN_GRIPPER

    @property
    def object_on_arm_segment(self) -> bool:
        """Whether the object lies on the segment the arm is above."""
        return self.object_location == ObjectLocation.on(self.arm_segment)

    @property
    def is_terminal(self) -> bool:
        """Both segments clean: the episode ends here."""
        return self.segment1_clean and self.segment2_clean

    @property
    def index(self) -> int:
        """The state's integer code (see :func:`encode`)."""
        return encode(self)

    @property
    def name(self) -> str:
        """A readable name, e.g. ``"S1:unclean+obj S2:unclean | arm@S1"``."""
        parts = []
        for segment in Segment:
            status = "clean" if self.is_clean(segment) else "unclean"
            obj = "+obj" if self.object_location == ObjectLocation.on(segment) else ""
            parts.append(f"S{segment.number}:{status}{obj}")
        held = " holding obj" if self.holding else ""
        return f"{' '.join(parts)} | arm@S{self.arm_segment.number}{held}"

    def replace(self, **changes) -> "TaskState":
        """A copy with the given fields changed."""
        fields = dict(
            segment1_clean=self.segment1_clean,
            segment2_clean=self.segment2_clean,
            object_location=self.object_location,
            arm_segment=self.arm_segment,
        )
        fields.update(changes)
        return TaskState(**fields)

    def with_clean(self, segment: Segment) -> "TaskState":
        """A copy in which ``segment`` is clean."""
        key = "segment1_clean" if Segment(segment) == Segment.SEGMENT_1 else "segment2_clean"
        return self.replace(**{key: True})

    def __str__(self) -> str:  # pragma: no cover - trivial
        return self.name


StateLike = Union[TaskState, int, np.integer]


def encode(state: TaskState) -> int:
    """Mixed-radix code of a state, in ``range(N_STATES)`` (24).

    ``((segment1_clean * 2 + segment2_clean) * 3 + object_location) * 2 + arm_segment``
    with booleans as 0/1, ``object_location`` in {0: on segment 1, 1: on segment 2,
    2: in gripper} and ``arm_segment`` in {0: segment 1, 1: segment 2}.
    """
    code = int(state.segment1_clean)
    code = code * _CLEAN_RADIX + int(state.segment2_clean)
    code = code * N_OBJECT_LOCATIONS + int(state.object_location)
    code = code * N_SEGMENTS + int(state.arm_segment)
    return code


def decode(code: int) -> TaskState:
    """Inverse of :func:`encode`; raises ``ValueError`` outside ``range(N_STATES)``."""
    if isinstance(code, (bool, np.bool_)) or not isinstance(code, (int, np.integer)):
        raise TypeError(f"state code must be an int in [0, {N_STATES}), got {code!r}")
    if not 0 <= int(code) < N_STATES:
        raise ValueError(f"state code must be in [0, {N_STATES}), got {code}")
    rest = int(code)
    rest, arm = divmod(rest, N_SEGMENTS)
    rest, obj = divmod(rest, N_OBJECT_LOCATIONS)
    segment1_clean, segment2_clean = divmod(rest, _CLEAN_RADIX)
    return TaskState(bool(segment1_clean), bool(segment2_clean), ObjectLocation(obj), Segment(arm))


def as_state(state: StateLike) -> TaskState:
    """Accept a :class:`TaskState` or its integer code."""
    if isinstance(state, TaskState):
        return state
    return decode(state)


def as_action(action) -> Action:
    """Accept an :class:`Action`, its integer value or its (case-insensitive) name."""
    if isinstance(action, Action):
        return action
    if isinstance(action, str):
        try:
            return Action[action.strip().upper()]
        except KeyError:
            pass
    elif isinstance(action, (int, np.integer)) and not isinstance(action, (bool, np.bool_)):
        if 0 <= int(action) < N_ACTIONS:
            return Action(int(action))
    allowed = ", ".join(f"{a.value}/{a.name.lower()}" for a in Action)
    raise ValueError(f"unknown action {action!r}; allowed: {allowed}")


def all_states() -> list[TaskState]:
    """All 24 states in code order."""
    return [decode(code) for code in range(N_STATES)]


def start_layout(object_segment: int, arm_segment: int) -> TaskState:
    """The both-unclean start with the object on ``object_segment`` and the arm above ``arm_segment`` (1-based)."""
    return TaskState(
        False, False, ObjectLocation.on(Segment.from_number(object_segment)), Segment.from_number(arm_segment)
    )


#: The four both-unclean layouts with the object on the table, as (object segment, arm segment).
START_LAYOUTS = tuple((obj, arm) for obj in (1, 2) for arm in (1, 2))

#: The paper's worked example: object and arm over segment 1, both unclean (Table 1's state 4).
PAPER_START = start_layout(1, 1)


# ---------------------------------------------------------------------------
# Table 1 of the paper
# ---------------------------------------------------------------------------
def _table1_row(seg1_clean, seg2_clean, object_segment, arm_segment, holding):
    location = ObjectLocation.IN_GRIPPER if holding else ObjectLocation.on(Segment.from_number(object_segment))
    return TaskState(seg1_clean, seg2_clean, location, Segment.from_number(arm_segment))


#: Table 1's numbering (1-18) to the model's states.  In Table 1 a held object
#: is written on the segment the arm is over ("Segment 2 holding the object").
TABLE1_STATES: dict[int, TaskState] = {
    1: _table1_row(False, False, 2, 1, False),
    2: _table1_row(False, False, 2, 2, False),
    3: _table1_row(False, False, 2, 2, True),
    4: _table1_row(False, False, 1, 1, False),
    5: _table1_row(False, False, 1, 2, False),
    6: _table1_row(False, False, 1, 1, True),
    7: _table1_row(True, False, 2, 1, False),
    8: _table1_row(True, False, 2, 2, False),
    9: _table1_row(True, False, 2, 2, True),
    10: _table1_row(False, True, 1, 1, False),
    11: _table1_row(False, True, 1, 2, False),
    12: _table1_row(False, True, 1, 1, True),
    13: _table1_row(True, True, 2, 1, False),
    14: _table1_row(True, True, 2, 2, False),
    15: _table1_row(True, True, 2, 2, True),
    16: _table1_row(True, True, 1, 1, False),
    17: _table1_row(True, True, 1, 2, False),
    18: _table1_row(True, True, 1, 1, True),
}


def table1_number(state: StateLike) -> int | None:
    """Table 1's row number of ``state``, or ``None`` when Table 1 omits it."""
    state = as_state(state)
    for number, row in TABLE1_STATES.items():
        if row == state:
            return number
    return None


# ---------------------------------------------------------------------------
# The model
# ---------------------------------------------------------------------------
class IneffectiveMode(str, enum.Enum):
    """How a pick with nothing to pick, or a place with nothing held, counts."""

    INEFFECTIVE = "ineffective"  # nothing changes; rewarded like irrelevant cleaning (default)
    IMPROPER = "improper"  # nothing changes; counts as an improper action (failed state)


class StartMode(str, enum.Enum):
    """How episodes start."""

    FIXED = "fixed"  # one given state (default: the paper's Table 1 state 4)
    UNIFORM_UNCLEAN = "uniform_unclean"  # uniform over the four both-unclean layouts


class TaskModel:
    """The paper's two-segment table-cleaning task as a deterministic model.

    ## Description
    A table has two segments, each clean or unclean, and one object lying on a
    segment or held by the Panda's gripper; the arm is above one segment.  The
    sponge has a fixed home off the table (Sec. 2), so it is not part of the
    state.  The goal is to clean both segments.

    ## Action Space
    ``Action``: 0 MOVE, 1 PICK, 2 PLACE, 3 CLEAN (the order breaks greedy ties).

    ## Observation Space
    24 states, coded ``((segment1_clean * 2 + segment2_clean) * 3 + object_location) * 2 + arm_segment``
    (:func:`encode`).  From the both-unclean starts 20 are reachable: 18
    non-terminal and 2 terminal.  Table 1 of the paper lists 18 states; its
    rows 14, 15, 16 and 18 can never be reached and it omits 6 reachable ones,
    3 of which the paper's own optimal sequence passes through
    (:meth:`table1_mapping`).

    ## Rules
    - MOVE: the arm goes to the other segment; a held object goes along. ROUTINE.
    - PICK: the object lies on the arm's segment -> held. ROUTINE.  Otherwise
      nothing changes: INEFFECTIVE (or IMPROPER with ``ineffective="improper"``).
    - PLACE: holding -> the object lies on the arm's segment. ROUTINE.
      Otherwise as an ineffective pick.
    - CLEAN: IMPROPER when holding the object or when the object lies on the
      arm's segment; the state does not change (Algorithm 1's failed state).
      Otherwise RELEVANT_CLEAN when the arm's segment is unclean (it becomes
      clean; TERMINAL if that makes both clean), IRRELEVANT_CLEAN when it is
      already clean.

    ## Starting State
    ``start="fixed"`` with ``start_state`` (default the paper's example,
    Table 1 state 4: both unclean, object and arm over segment 1), or
    ``start="uniform_unclean"``: uniform over the four both-unclean layouts
    (object on segment 1 or 2, arm over segment 1 or 2).

    ## Episode End
    Terminal when both segments are clean.  Learners also truncate after
    ``max_itr`` iterations.

    ## Arguments
    - ``ineffective``: ``"ineffective"`` (default) or ``"improper"``.
    - ``start``: ``"fixed"`` (default) or ``"uniform_unclean"``.
    - ``start_state``: a :class:`TaskState` or code; only with ``start="fixed"``.

    ## Version History
    - v0: initial version.
    """

    def __init__(self, ineffective: str = "ineffective", start: str = "fixed", start_state: StateLike | None = None):
        try:
            self.ineffective = IneffectiveMode(ineffective)
        except ValueError:
            allowed = ", ".join(m.value for m in IneffectiveMode)
            raise ValueError(f"unknown ineffective mode {ineffective!r}; allowed: {allowed}") from None
        try:
            self.start = StartMode(start)
        except ValueError:
            allowed = ", ".join(m.value for m in StartMode)
            raise ValueError(f"unknown start mode {start!r}; allowed: {allowed}") from None
        if self.start == StartMode.UNIFORM_UNCLEAN and start_state is not None:
            raise ValueError("start_state is only allowed with start='fixed'")
        self.start_state = PAPER_START if start_state is None else as_state(start_state)
        if self.start_state.is_terminal:
            raise ValueError(f"start_state must not be terminal, got {self.start_state.name}")

    def __repr__(self) -> str:
        start = self.start.value if self.start == StartMode.UNIFORM_UNCLEAN else self.start_state.name
        return f"TaskModel(ineffective={self.ineffective.value!r}, start={start!r})"

    # -- rules ---------------------------------------------------------------
    def _ineffective_outcome(self) -> Outcome:
        return Outcome.IMPROPER if self.ineffective == IneffectiveMode.IMPROPER else Outcome.INEFFECTIVE

    def step(self, state: StateLike, action) -> tuple[TaskState, Outcome]:
        """Apply ``action`` to ``state``; returns ``(next_state, outcome)``.

        Improper and ineffective actions return the same state.  Stepping a
        terminal state raises ``ValueError`` (the episode is over).
        """
        state = as_state(state)
        action = as_action(action)
        if state.is_terminal:
            raise ValueError(f"state {state.index} ({state.name}) is terminal; reset before stepping")
        if action == Action.MOVE:
            return state.replace(arm_segment=state.arm_segment.other), Outcome.ROUTINE
        if action == Action.PICK:
            if state.object_on_arm_segment:
                return state.replace(object_location=ObjectLocation.IN_GRIPPER), Outcome.ROUTINE
            return state, self._ineffective_outcome()
        if action == Action.PLACE:
            if state.holding:
                return state.replace(object_location=ObjectLocation.on(state.arm_segment)), Outcome.ROUTINE
            return state, self._ineffective_outcome()
        # CLEAN
        if state.holding or state.object_on_arm_segment:
            return state, Outcome.IMPROPER
        if state.is_clean(state.arm_segment):
            return state, Outcome.IRRELEVANT_CLEAN
        cleaned = state.with_clean(state.arm_segment)
        return cleaned, (Outcome.TERMINAL if cleaned.is_terminal else Outcome.RELEVANT_CLEAN)

    def is_improper(self, state: StateLike, action) -> bool:
        """Whether ``action`` is improper in ``state`` (a failed state, refused by the skills)."""
        return self.step(state, action)[1] == Outcome.IMPROPER

    def action_mask(self, state: StateLike) -> np.ndarray:
        """Shape ``(4,)`` int8: 1 where the action is not improper in ``state``."""
        state = as_state(state)
        if state.is_terminal:
            return np.zeros(N_ACTIONS, dtype=np.int8)
        return np.array([0 if self.is_improper(state, a) else 1 for a in Action], dtype=np.int8)

    def classify(self, state: StateLike, action, next_state: StateLike) -> Outcome:
        """The outcome of an *observed* transition ``state --action--> next_state``.

        Used for physics, where the next state is read back from MuJoCo and may
        differ from the model's prediction.  Improperness depends only on
        ``(state, action)``; cleaning outcomes on which segments became clean;
        any other action is ROUTINE when the state changed, else ineffective.
        """
        state, next_state, action = as_state(state), as_state(next_state), as_action(action)
        _, predicted = self.step(state, action)
        if predicted == Outcome.IMPROPER:
            return Outcome.IMPROPER
        if next_state.is_terminal and not state.is_terminal:
            return Outcome.TERMINAL
        if action == Action.CLEAN:
            newly_clean = any(next_state.is_clean(s) and not state.is_clean(s) for s in Segment)
            return Outcome.RELEVANT_CLEAN if newly_clean else Outcome.IRRELEVANT_CLEAN
        return Outcome.ROUTINE if next_state != state else self._ineffective_outcome()

    # -- starts ----------------------------------------------------------------
    def start_states(self) -> list[TaskState]:
        """The states an episode can start in (one for ``fixed``, four for ``uniform_unclean``)."""
        if self.start == StartMode.UNIFORM_UNCLEAN:
            return self._unclean_layouts()
        return [self.start_state]

    def sample_start(self, uniform: float) -> TaskState:
        """The start state picked by a uniform draw in [0, 1)."""
        starts = self.start_states()
        return starts[min(int(uniform * len(starts)), len(starts) - 1)]

    # -- tables for fast learners ------------------------------------------------
    def transition_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """``(next_state, outcome)`` arrays of shape ``(24, 4)`` (int64).

        Terminal states map to themselves with outcome TERMINAL; learners never
        step them.
        """
        next_state = np.zeros((N_STATES, N_ACTIONS), dtype=np.int64)
        outcome = np.zeros((N_STATES, N_ACTIONS), dtype=np.int64)
        for state in all_states():
            for action in Action:
                if state.is_terminal:
                    nxt, out = state, Outcome.TERMINAL
                else:
                    nxt, out = self.step(state, action)
                next_state[state.index, action] = nxt.index
                outcome[state.index, action] = out
        return next_state, outcome

    # -- analysis ------------------------------------------------------------
    def successors(self, state: StateLike) -> Iterator[tuple[Action, TaskState, Outcome]]:
        """``(action, next_state, outcome)`` for every action from a non-terminal ``state``."""
        state = as_state(state)
        for action in Action:
            nxt, out = self.step(state, action)
            yield action, nxt, out

    def reachable_states(self, starts: Iterable[StateLike] | None = None) -> list[TaskState]:
        """States reachable from ``starts`` (default: the four both-unclean layouts), sorted by code.

        Terminal states are included but not expanded (the episode ends there).
        """
        frontier = deque(as_state(s) for s in (starts if starts is not None else self._unclean_layouts()))
        seen = set(frontier)
        while frontier:
            state = frontier.popleft()
            if state.is_terminal:
                continue
            for _, nxt, _ in self.successors(state):
                if nxt not in seen:
                    seen.add(nxt)
                    frontier.append(nxt)
        return sorted(seen, key=encode)

    @staticmethod
    def _unclean_layouts() -> list[TaskState]:
        return [start_layout(obj, arm) for obj, arm in START_LAYOUTS]

    def shortest_plan(self, state: StateLike) -> list[Action] | None:
        """A shortest action sequence from ``state`` to a terminal state (``[]`` if terminal).

        Breadth-first over the model, trying actions in :class:`Action` order,
        so among equally short plans the first in that order is returned.
        ``None`` if no terminal state is reachable.
        """
        start = as_state(state)
        if start.is_terminal:
            return []
        parent: dict[TaskState, tuple[TaskState, Action] | None] = {start: None}
        frontier = deque([start])
        while frontier:
            current = frontier.popleft()
            for action, nxt, _ in self.successors(current):
                if nxt in parent:
                    continue
                parent[nxt] = (current, action)
                if nxt.is_terminal:
                    plan = []
                    node = nxt
                    while parent[node] is not None:
                        node, act = parent[node]
                        plan.append(act)
                    return plan[::-1]
                frontier.append(nxt)
        return None

    def shortest_plan_lengths(self, states: Sequence[StateLike] | None = None) -> dict[int, int | None]:
        """Shortest plan length per state code (default: every reachable state)."""
        states = self.reachable_states() if states is None else [as_state(s) for s in states]
        lengths = {}
        for state in states:
            plan = self.shortest_plan(state)
            lengths[state.index] = None if plan is None else len(plan)
        return lengths

    def rollout(self, state: StateLike, actions: Iterable) -> list[TaskState]:
        """The states visited by applying ``actions`` from ``state`` (including ``state``)."""
        visited = [as_state(state)]
        for action in actions:
            visited.append(self.step(visited[-1], action)[0])
        return visited

    def table1_mapping(self) -> dict:
        """How Table 1 of the paper relates to this model.

        Returns a dict with
        - ``"rows"``: Table 1 number -> model state code,
        - ``"unreachable_rows"``: Table 1 numbers never reachable from a both-unclean start,
        - ``"omitted_reachable"``: codes of reachable states Table 1 does not list,
        - ``"omitted_on_paper_plan"``: those among them that the paper's optimal
          sequence from state 4 passes through.
        """
        reachable = set(self.reachable_states())
        listed = set(TABLE1_STATES.values())
        paper_plan_states = set(self.rollout(PAPER_START, PAPER_OPTIMAL_PLAN))
        omitted = sorted((s for s in reachable if s not in listed), key=encode)
        return {
            "rows": {number: state.index for number, state in TABLE1_STATES.items()},
            "unreachable_rows": sorted(n for n, s in TABLE1_STATES.items() if s not in reachable),
            "omitted_reachable": [s.index for s in omitted],
            "omitted_on_paper_plan": [s.index for s in omitted if s in paper_plan_states],
        }


#: The paper's optimal sequence from state 4 (Sec. 2): move, clean, move, pick, move, place, move, clean.
PAPER_OPTIMAL_PLAN = (
    Action.MOVE,
    Action.CLEAN,
    Action.MOVE,
    Action.PICK,
    Action.MOVE,
    Action.PLACE,
    Action.MOVE,
    Action.CLEAN,
)
