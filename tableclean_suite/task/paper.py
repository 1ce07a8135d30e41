"""The paper's task as data: Table 1's states, its start (state 4) and its optimal plan (Sec. 2).

These are the published facts the ``paper`` spec is checked against; they hold for
2 segments and 1 object only.  Segments are 1-based here, as in the paper.
"""

from __future__ import annotations

from tableclean_suite.task.actions import Action
from tableclean_suite.task.state import HELD, TaskState, decode_code, unclean_layouts

#: The paper's table has two segments and one object.
PAPER_SEGMENTS = 2
PAPER_OBJECTS = 1


def start_layout(object_segment: int, arm_segment: int) -> TaskState:
    """The paper's all-unclean start with the object on ``object_segment`` and the arm above
    ``arm_segment`` (1-based, 1 or 2); ``ValueError`` otherwise."""
    for name, value in (("object_segment", object_segment), ("arm_segment", arm_segment)):
        if isinstance(value, bool) or value not in range(1, PAPER_SEGMENTS + 1):
            raise ValueError(f"{name} must be 1 or 2, got {value!r}")
    return TaskState((False,) * PAPER_SEGMENTS, (object_segment - 1,), arm_segment - 1)


#: The four both-unclean layouts with the object on the table, as (object segment, arm segment), 1-based.
START_LAYOUTS = tuple((s.objects[0] + 1, s.arm + 1) for s in unclean_layouts(PAPER_SEGMENTS, PAPER_OBJECTS))

#: The paper's worked example: object and arm over segment 1, both unclean (Table 1's state 4).
PAPER_START = start_layout(1, 1)

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


def _table1_row(seg1_clean, seg2_clean, object_segment, arm_segment, holding):
    location = HELD if holding else object_segment - 1
    return TaskState((seg1_clean, seg2_clean), (location,), arm_segment - 1)


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


def table1_number(state: TaskState | int) -> int | None:
    """Table 1's row number of ``state`` (a paper-spec state or code), or ``None`` when Table 1 omits it."""
    if not isinstance(state, TaskState):
        state = decode_code(state, PAPER_SEGMENTS, PAPER_OBJECTS)
    return next((number for number, row in TABLE1_STATES.items() if row == state), None)
