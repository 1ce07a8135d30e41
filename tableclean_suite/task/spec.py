"""Task specifications: how many segments, which objects, which actions, how episodes start.

A [`TaskSpec`][tableclean_suite.task.spec.TaskSpec] is a frozen, validated, JSON-serialisable value.  Named specs live
in a registry ([`get_task_spec`][tableclean_suite.task.spec.get_task_spec], [`register_task_spec`][tableclean_suite.task.spec.register_task_spec]); ``paper`` is the
default everywhere.  A spec can also be read from a JSON file ([`load_task_spec`][tableclean_suite.task.spec.load_task_spec],
the layout of [`TaskSpec.to_dict`][tableclean_suite.task.spec.TaskSpec.to_dict]), where segments and objects are
numbered from 1 and an object's location is a segment number or ``"held"``.
"""

from __future__ import annotations

import enum
import json
import math
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any, Sequence

from tableclean_suite.registry import NAME_PATTERN, Registry
from tableclean_suite.resources import bounded_product
from tableclean_suite.task.actions import get_action_rule
from tableclean_suite.task.state import HELD, TaskState, state_count

#: Object type of the paper's single object (the physical side builds a box for it).
DEFAULT_OBJECT_TYPE = "box"
#: The paper's action list, in its order.
PAPER_ACTIONS = ("move", "pick", "place", "clean")
#: Largest number of state codes a spec may have: codes and Q-table indices stay in int32.
MAX_STATE_CODES = 2**31 - 1
#: The JSON spelling of a held object's location.
HELD_JSON = "held"
#: Bump when the JSON layout changes.
SPEC_FORMAT_VERSION = 1


class IneffectiveMode(str, enum.Enum):
    """How a pick with nothing to pick, or a place with nothing held, counts."""

    INEFFECTIVE = "ineffective"  # nothing changes; rewarded like irrelevant cleaning (default)
    IMPROPER = "improper"  # nothing changes; counts as an improper action (failed state)


class StartMode(str, enum.Enum):
    """How episodes start."""

    FIXED = "fixed"  # one given state (default: all unclean, objects and arm on segment 1)
    UNIFORM_UNCLEAN = "uniform_unclean"  # uniform over every all-unclean layout with nothing held


def _enum_value(enum_type, value, what: str) -> str:
    try:
        return enum_type(value).value
    except ValueError:
        allowed = ", ".join(m.value for m in enum_type)
        raise ValueError(f"unknown {what} {value!r}; allowed: {allowed}") from None


def check_spec_size(segments: int, objects: int, what: str = "task") -> int:
    """The state codes ``2**N * (N + 1)**M * N`` of N ``segments`` and M ``objects`` (integers >= 1), or
    ``ValueError`` naming them and `MAX_STATE_CODES` when there are more, decided on logarithms
    ([`bounded_product`][tableclean_suite.resources.bounded_product]): a size of ``10**30`` costs no arithmetic."""
    codes = bounded_product([(2, segments), (segments + 1, objects), (segments, 1)], MAX_STATE_CODES)
    if codes is None:
        shown = [n if n < 10**100 else f"10^{math.log10(n):.0f}" for n in (segments, objects)]
        raise ValueError(f"{what}: {shown[0]} segments and {shown[1]} objects give more state codes "
                         f"(2**N * (N + 1)**M * N) than the {MAX_STATE_CODES} supported")
    return codes


@dataclass(frozen=True)
class TaskSpec:
    """A table-cleaning task.

    Attributes:
        name: registry key, lower_snake.
        segments: N >= 2, the table's segments (numbered 1..N to users).
        objects: the M >= 1 objects' type names (lower_snake, e.g. ``"box"``); the
            physical side builds each from its object registry.  An int M gives M boxes.
        actions: registered action names in learner order (default the paper's four).
        start: ``"fixed"`` (episodes start in ``start_state``) or ``"uniform_unclean"``
            (uniform over every all-unclean layout with nothing held).
        start_state: a non-terminal [`TaskState`][tableclean_suite.task.state.TaskState] for ``start="fixed"``; None means
            the default (all unclean, objects and arm on segment 1).  Must be None with
            ``"uniform_unclean"``.
        ineffective: ``"ineffective"`` or ``"improper"`` (how a pick with nothing to
            pick / a place with nothing held counts).
        description: one line for listings.
    """

    name: str
    segments: int = 2
    objects: Any = (DEFAULT_OBJECT_TYPE,)
    actions: Sequence[str] = PAPER_ACTIONS
    start: str = StartMode.FIXED.value
    start_state: TaskState | None = None
    ineffective: str = IneffectiveMode.INEFFECTIVE.value
    description: str = field(default="", compare=False)

    def __post_init__(self):
        if not isinstance(self.name, str) or not NAME_PATTERN.match(self.name):
            raise ValueError(f"task spec name must be lower_snake (e.g. 'three_segments'), got {self.name!r}")
        if isinstance(self.segments, bool) or not isinstance(self.segments, int) or self.segments < 2:
            raise ValueError(f"task {self.name!r}: segments must be an integer >= 2, got {self.segments!r}")
        objects = self.objects
        if isinstance(objects, int) and not isinstance(objects, bool):
            if objects < 1:
                raise ValueError(f"task {self.name!r}: objects must be >= 1 (or a list of type names), got {objects}")
            check_spec_size(self.segments, objects, f"task {self.name!r}")
            objects = (DEFAULT_OBJECT_TYPE,) * objects
        if isinstance(objects, str) or not isinstance(objects, (list, tuple)) or not objects:
            raise ValueError(f"task {self.name!r}: objects must be an int >= 1 or a non-empty list of type names, "
                             f"got {self.objects!r}")
        for kind in objects:
            if not isinstance(kind, str) or not NAME_PATTERN.match(kind):
                raise ValueError(f"task {self.name!r}: object type names must be lower_snake, got {kind!r}")
        object.__setattr__(self, "objects", tuple(objects))
        actions = tuple(self.actions) if isinstance(self.actions, (list, tuple)) else None
        if not actions:
            raise ValueError(f"task {self.name!r}: actions must be a non-empty list of action names, got {self.actions!r}")
        for action in actions:
            get_action_rule(action)  # ValueError names the registered actions
        if len(set(actions)) != len(actions):
            raise ValueError(f"task {self.name!r}: actions must not repeat, got {list(actions)}")
        object.__setattr__(self, "actions", actions)
        object.__setattr__(self, "start", _enum_value(StartMode, self.start, "start mode"))
        object.__setattr__(self, "ineffective", _enum_value(IneffectiveMode, self.ineffective, "ineffective mode"))
        check_spec_size(self.segments, len(objects), f"task {self.name!r}")
        if self.start_state is not None:
            if self.start == StartMode.UNIFORM_UNCLEAN.value:
                raise ValueError(f"task {self.name!r}: start_state is only allowed with start='fixed'")
            self._check_state(self.start_state, "start_state")

    def _check_state(self, state, what: str) -> None:
        if not isinstance(state, TaskState):
            raise TypeError(f"task {self.name!r}: {what} must be a TaskState, got {type(state).__name__}")
        if state.n_segments != self.segments or state.n_objects != self.n_objects:
            raise ValueError(f"task {self.name!r}: {what} has {state.n_segments} segments and {state.n_objects} "
                             f"objects; the spec has {self.segments} and {self.n_objects}")
        if state.is_terminal:
            raise ValueError(f"task {self.name!r}: {what} must not be terminal, got {state.name}")
        if state.objects.count(HELD) > 1:
            raise ValueError(f"task {self.name!r}: {what} holds more than one object ({state.name})")

    # -- derived ---------------------------------------------------------------------
    @property
    def n_objects(self) -> int:
        """M, the number of objects."""
        return len(self.objects)

    @property
    def n_actions(self) -> int:
        """A, the number of actions."""
        return len(self.actions)

    @property
    def n_states(self) -> int:
        """Number of state codes, ``2**N * (N + 1)**M * N`` (reachable ones are fewer)."""
        return state_count(self.segments, self.n_objects)

    @property
    def initial_state(self) -> TaskState:
        """The fixed start state; when ``start_state`` is None, every segment unclean and the objects and the
        arm on segment 1."""
        return self.start_state or TaskState((False,) * self.segments, (0,) * self.n_objects, 0)

    def replace(self, **changes) -> "TaskSpec":
        """A validated copy with some fields changed."""
        return replace(self, **changes)

    # -- JSON --------------------------------------------------------------------------
    def to_dict(self) -> dict:
        """A JSON-serialisable dict: ``format_version`` and the fields, ``start_state`` as
        [`state_to_json`][tableclean_suite.task.spec.state_to_json] writes it."""
        data = asdict(self)
        data["objects"] = list(self.objects)
        data["actions"] = list(self.actions)
        data["start_state"] = None if self.start_state is None else state_to_json(self.start_state)
        return {"format_version": SPEC_FORMAT_VERSION, **data}

    @classmethod
    def from_dict(cls, data: dict, source: str = "task spec") -> "TaskSpec":
        """The spec of [`to_dict`][tableclean_suite.task.spec.TaskSpec.to_dict]'s layout; ``ValueError`` names the bad field."""
        if not isinstance(data, dict):
            raise ValueError(f"{source}: a task spec must be a JSON object, got {type(data).__name__}")
        data = dict(data)
        version = data.pop("format_version", SPEC_FORMAT_VERSION)
        if version != SPEC_FORMAT_VERSION:
            raise ValueError(f"{source}: unsupported format_version {version!r}; expected {SPEC_FORMAT_VERSION}")
        allowed = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - allowed)
        if unknown:
            raise ValueError(f"{source}: unknown field(s) {unknown}; allowed: {', '.join(sorted(allowed))}")
        if "name" not in data:
            raise ValueError(f"{source}: a task spec needs a 'name'")
        if not isinstance(data.get("description", ""), str):
            raise ValueError(f"{source}: description must be a string, got {data['description']!r}")
        start_state = data.pop("start_state", None)
        try:
            spec = cls(**data)
            if start_state is None:
                return spec
            return spec.replace(start_state=state_from_json(start_state, spec.segments, "start_state"))
        except (TypeError, ValueError) as error:
            raise ValueError(f"{source}: {error}") from None

    def to_json(self, path: str | Path) -> None:
        """Write the spec as JSON, atomically ([`atomic_write_text`][tableclean_suite.atomic_files.atomic_write_text])."""
        from tableclean_suite.atomic_files import atomic_write_text

        atomic_write_text(path, json.dumps(self.to_dict(), indent=2) + "\n")


def state_to_json(state: TaskState) -> dict:
    """``{"clean": [...], "objects": [segment number or "held", ...], "arm": segment number}``."""
    return {
        "clean": list(state.clean),
        "objects": [HELD_JSON if where == HELD else where + 1 for where in state.objects],
        "arm": state.arm + 1,
    }


def state_from_json(data, segments: int, source: str) -> TaskState:
    """Inverse of [`state_to_json`][tableclean_suite.task.spec.state_to_json]; ``ValueError`` names what is wrong."""
    if not isinstance(data, dict) or set(data) != {"clean", "objects", "arm"}:
        raise ValueError(f"{source}: expected {{'clean': [...], 'objects': [...], 'arm': k}}, got {data!r}")

    def segment_index(value, what):
        if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= segments:
            raise ValueError(f"{source}: {what} must be a segment number in 1..{segments}, got {value!r}")
        return value - 1

    clean = data["clean"]
    if not isinstance(clean, list) or not all(isinstance(c, bool) for c in clean):
        raise ValueError(f"{source}: clean must be a list of true/false, got {clean!r}")
    objects = data["objects"]
    if not isinstance(objects, list):
        raise ValueError(f"{source}: objects must be a list, got {objects!r}")
    locations = [HELD if o == HELD_JSON else segment_index(o, f"objects[{j}]") for j, o in enumerate(objects)]
    return TaskState(tuple(clean), tuple(locations), segment_index(data["arm"], "arm"))


# ---------------------------------------------------------------------------
# Registry of named specs
# ---------------------------------------------------------------------------
PAPER_SPEC = TaskSpec("paper", description="the paper's task: 2 segments, 1 object (Table 1's state 4 start)")

BUILTIN_SPECS = (
    PAPER_SPEC,
    TaskSpec("three_segments", segments=3, description="3 segments, 1 object"),
    TaskSpec("two_objects", segments=2, objects=2, description="2 segments, 2 objects"),
    TaskSpec("three_segments_two_objects", segments=3, objects=("box", "cylinder"),
             description="3 segments, a box and a cylinder"),
    TaskSpec("four_segments_two_objects", segments=4, objects=2, description="4 segments, 2 objects"),
)

_REGISTRY: Registry[TaskSpec] = Registry("task spec", TaskSpec, BUILTIN_SPECS)


def register_task_spec(spec: TaskSpec, overwrite: bool = False) -> TaskSpec:
    """Add a spec so ``TaskModel(spec="name")``, ``train(task="name")`` and ``--task name`` find it."""
    return _REGISTRY.register(spec, overwrite)


def task_spec_names() -> list[str]:
    """Registered spec names, in registration order."""
    return _REGISTRY.names()


def unique_keys(pairs) -> dict:
    """``json.loads``' ``object_pairs_hook``: the object as a dict; ``ValueError`` names a key given twice."""
    data = {}
    for key, value in pairs:
        if key in data:
            raise ValueError(f"key {key!r} is given twice")
        data[key] = value
    return data


def load_task_spec(path: str | Path) -> TaskSpec:
    """Read a spec from a JSON file; ``ValueError`` names the file and the problem (a key given twice too)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"), object_pairs_hook=unique_keys)
    except FileNotFoundError:
        raise ValueError(f"task spec file {str(path)!r} does not exist") from None
    except RecursionError:
        raise ValueError(f"task spec file {str(path)!r} is nested too deeply to be a task spec") from None
    except (OSError, ValueError) as error:
        raise ValueError(f"task spec file {str(path)!r} is not readable JSON ({error})") from None
    return TaskSpec.from_dict(data, source=str(path))


#: Readers of spec files by suffix: ``.json`` here, ``.pddl`` added by [tableclean_suite.task.pddl][].
SPEC_FILE_READERS: dict = {".json": load_task_spec}


def get_task_spec(task: "str | Path | TaskSpec | None" = None) -> TaskSpec:
    """A spec from a registered name, a ``.json`` spec file, a ``.pddl`` problem or a spec (None: ``paper``).

    A path is read by the reader `SPEC_FILE_READERS` names for its suffix (``.pddl``:
    [`read_problem`][tableclean_suite.task.pddl.read_problem], which registers itself there).
    Raises ``ValueError`` naming the registered specs when ``task`` is none of these.
    """
    if task is None:
        return PAPER_SPEC
    if isinstance(task, TaskSpec):
        return task
    reader = SPEC_FILE_READERS.get(Path(str(task)).suffix.lower()) if isinstance(task, (str, Path)) else None
    if reader is not None or isinstance(task, Path):  # a Path of another suffix is read as JSON
        return (reader or load_task_spec)(Path(task))
    if isinstance(task, str) and task in _REGISTRY.names():
        return _REGISTRY.get(task)
    allowed = ", ".join(_REGISTRY.names())
    raise ValueError(f"unknown task spec {task!r}; allowed: {allowed}, a TaskSpec, or a path to a .json spec or a .pddl problem")
