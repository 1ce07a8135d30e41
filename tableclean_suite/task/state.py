"""Symbolic states of the table-cleaning task for any number of segments and objects.

A [`TaskState`][tableclean_suite.task.state.TaskState] knows its own sizes, so its integer code
needs no spec.  Indices are 0-based here; names and the user-facing API number from 1.
"""

from __future__ import annotations

import dataclasses
import enum
import itertools
from dataclasses import dataclass

import numpy as np

#: Location code of an object held in the gripper (`TaskState.objects`).
HELD = -1

#: A segment is unclean (0) or clean (1): the radix of each clean flag in the state code.
CLEAN_RADIX = 2


class Outcome(enum.IntEnum):
    """What an action did; reward patterns assign a value to each outcome.

    - ROUTINE: an effective move, pick or place (or another action that changed the state).
    - INEFFECTIVE: a pick with nothing to pick or a place with nothing held (no change).
    - RELEVANT_CLEAN: cleaning an unclean segment that leaves another one unclean.
    - IRRELEVANT_CLEAN: cleaning an already clean segment.
    - IMPROPER: cleaning while holding an object or where an object lies (Algorithm 1's failed
      state; no change).
    - TERMINAL: the action that leaves every segment clean.
    """

    ROUTINE = 0
    INEFFECTIVE = 1
    RELEVANT_CLEAN = 2
    IRRELEVANT_CLEAN = 3
    IMPROPER = 4
    TERMINAL = 5


N_OUTCOMES = len(Outcome)
#: Outcomes of a cleaning action (used to classify observed transitions).
CLEAN_OUTCOMES = (Outcome.RELEVANT_CLEAN, Outcome.IRRELEVANT_CLEAN)
#: Outcomes after which the state must be unchanged.
NO_CHANGE_OUTCOMES = (Outcome.INEFFECTIVE, Outcome.IRRELEVANT_CLEAN, Outcome.IMPROPER)


def is_integer(value) -> bool:
    """Whether ``value`` is a Python or numpy integer (a bool is not)."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


@dataclass(frozen=True, order=True)
class TaskState:
    """One symbolic state (0-based indices).

    Attributes:
        clean: ``(N,)`` bools, whether segment ``k`` (0-based) is clean; N >= 1.
        objects: ``(M,)`` ints, where object ``j`` is: a segment index in ``[0, N)``, or
            `HELD` (-1) in the gripper.  Several objects may lie on one segment.
        arm: the segment index in ``[0, N)`` the arm is above.

    The task's rules allow at most one held object; a state holding two is a valid
    value (it has a code) that no rule produces.
    """

    clean: tuple[bool, ...]
    objects: tuple[int, ...]
    arm: int

    def __post_init__(self):
        clean = tuple(bool(c) for c in self.clean)
        if not clean:
            raise ValueError("a state needs at least one segment")
        n = len(clean)
        objects = tuple(self.objects)
        if not objects:
            raise ValueError("a state needs at least one object")
        for j, where in enumerate(objects):
            if not is_integer(where) or not (where == HELD or 0 <= where < n):
                raise ValueError(f"object {j + 1} location must be a segment index in [0, {n}) or HELD (-1), got {where!r}")
        if not is_integer(self.arm) or not 0 <= self.arm < n:
            raise ValueError(f"arm must be a segment index in [0, {n}), got {self.arm!r}")
        object.__setattr__(self, "clean", clean)
        object.__setattr__(self, "objects", tuple(int(o) for o in objects))
        object.__setattr__(self, "arm", int(self.arm))

    # -- sizes and derived facts --------------------------------------------------
    @property
    def n_segments(self) -> int:
        """N, the number of segments."""
        return len(self.clean)

    @property
    def n_objects(self) -> int:
        """M, the number of objects."""
        return len(self.objects)

    def is_clean(self, segment: int) -> bool:
        """Whether segment ``segment`` (0-based) is clean."""
        return self.clean[int(segment)]

    @property
    def held_object(self) -> int | None:
        """The lowest-numbered held object's index, or None when the gripper is empty."""
        for j, where in enumerate(self.objects):
            if where == HELD:
                return j
        return None

    @property
    def holding(self) -> bool:
        """Whether the gripper holds an object."""
        return HELD in self.objects

    def objects_on(self, segment: int) -> tuple[int, ...]:
        """Indices of the objects lying on ``segment`` (0-based), in object order."""
        return tuple(j for j, where in enumerate(self.objects) if where == segment)

    @property
    def is_terminal(self) -> bool:
        """Every segment clean: the episode ends here."""
        return all(self.clean)

    @property
    def index(self) -> int:
        """The state's integer code (see [`encode`][tableclean_suite.task.state.encode])."""
        return encode(self)

    @property
    def name(self) -> str:
        """A readable name, e.g. ``"S1:unclean+obj S2:unclean | arm@S1"`` (objects ``o1``, ``o2``, ...
        when there are several)."""
        label = object_labels(self.n_objects)
        parts = []
        for k in range(self.n_segments):
            status = "clean" if self.clean[k] else "unclean"
            parts.append(f"S{k + 1}:{status}" + "".join(f"+{label[j]}" for j in self.objects_on(k)))
        held = "".join(f" holding {label[j]}" for j, where in enumerate(self.objects) if where == HELD)
        return f"{' '.join(parts)} | arm@S{self.arm + 1}{held}"

    # -- copies -------------------------------------------------------------------
    def replace(self, **changes) -> "TaskState":
        """A validated copy with the given fields (``clean``, ``objects``, ``arm``) changed."""
        return dataclasses.replace(self, **changes)

    def with_object(self, obj: int, where: int) -> "TaskState":
        """A copy in which object ``obj`` (0-based) is at ``where`` (a segment index or HELD)."""
        objects = list(self.objects)
        objects[int(obj)] = int(where)
        return self.replace(objects=tuple(objects))

    def __str__(self) -> str:  # pragma: no cover - trivial
        return self.name


def object_labels(n_objects: int) -> list[str]:
    """Display names of ``n_objects`` objects: ``["obj"]`` for one, else ``["o1", "o2", ...]``."""
    return ["obj"] if n_objects == 1 else [f"o{j + 1}" for j in range(n_objects)]


def state_count(n_segments: int, n_objects: int) -> int:
    """Number of codes of the mixed radix: ``2**N * (N + 1)**M * N``."""
    return CLEAN_RADIX**n_segments * (n_segments + 1) ** n_objects * n_segments


def radices(n_segments: int, n_objects: int) -> tuple[int, ...]:
    """Radices of a state code's digits, most significant first: the clean flags of segments 1..N
    (2), the locations of objects 1..M (N + 1: a segment index, or N for held), the arm's segment (N)."""
    return (CLEAN_RADIX,) * n_segments + (n_segments + 1,) * n_objects + (n_segments,)


def encode(state: TaskState) -> int:
    """The state's code in ``range(state_count(N, M))``, the mixed radix of
    [`radices`][tableclean_suite.task.state.radices]."""
    n, code = state.n_segments, 0
    digits = (*state.clean, *(n if where == HELD else where for where in state.objects), state.arm)
    for digit, radix in zip(digits, radices(n, state.n_objects)):  # np.ravel_multi_index is 6x slower here
        code = code * radix + digit
    return code


def decode_code(code: int, n_segments: int, n_objects: int) -> TaskState:
    """Inverse of [`encode`][tableclean_suite.task.state.encode] for N segments and M objects; ``TypeError``
    for a non-integer, ``ValueError`` outside ``range(state_count(N, M))``."""
    total = state_count(n_segments, n_objects)
    if not is_integer(code):
        raise TypeError(f"state code must be an int in [0, {total}), got {code!r}")
    if not 0 <= int(code) < total:
        raise ValueError(f"state code must be in [0, {total}), got {code}")
    digits = np.unravel_index(int(code), radices(n_segments, n_objects))
    objects = tuple(HELD if where == n_segments else where for where in digits[n_segments:-1])
    return TaskState(digits[:n_segments], objects, digits[-1])


def unclean_layouts(n_segments: int, n_objects: int) -> list[TaskState]:
    """Every all-unclean state with nothing held (``N ** M * N`` of them), in code order."""
    clean = (False,) * n_segments
    return [
        TaskState(clean, objects, arm)
        for objects in itertools.product(range(n_segments), repeat=n_objects)
        for arm in range(n_segments)
    ]

