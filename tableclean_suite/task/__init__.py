"""The symbolic table-cleaning task (pure Python/NumPy, no MuJoCo): specifications
([`TaskSpec`][tableclean_suite.task.spec.TaskSpec]), states ([`TaskState`][tableclean_suite.task.state.TaskState],
[`Outcome`][tableclean_suite.task.state.Outcome]), actions ([`ActionRule`][tableclean_suite.task.actions.ActionRule],
[`register_action`][tableclean_suite.task.actions.register_action]), the model
([`TaskModel`][tableclean_suite.task.model.TaskModel]) and the paper's Table 1, start and optimal plan
([`paper`][tableclean_suite.task.paper]).
"""

from __future__ import annotations

from tableclean_suite.task.actions import (  # noqa: F401
    BUILTIN_ACTIONS,
    Action,
    ActionRule,
    action_names,
    clean_effect,
    get_action_rule,
    move_effect,
    pick_effect,
    place_effect,
    register_action,
)
from tableclean_suite.task.model import (  # noqa: F401
    ActionEffectError,
    StateLike,
    TaskModel,
    UnlearnableTaskError,
    as_task_model,
)
from tableclean_suite.task.paper import (  # noqa: F401
    PAPER_OPTIMAL_PLAN,
    PAPER_START,
    START_LAYOUTS,
    TABLE1_STATES,
    start_layout,
    table1_number,
)
from tableclean_suite.task.spec import (  # noqa: F401
    BUILTIN_SPECS,
    PAPER_SPEC,
    IneffectiveMode,
    StartMode,
    TaskSpec,
    check_spec_size,
    get_task_spec,
    load_task_spec,
    register_task_spec,
    state_from_json,
    state_to_json,
    task_spec_names,
    unique_keys,
)
from tableclean_suite.task import pddl  # noqa: F401,E402 (registers the .pddl spec reader)
from tableclean_suite.task.state import (  # noqa: F401
    CLEAN_OUTCOMES,
    HELD,
    NO_CHANGE_OUTCOMES,
    N_OUTCOMES,
    Outcome,
    TaskState,
    decode_code,
    encode,
    is_integer,
    state_count,
    unclean_layouts,
)


def decode(code: int, task: "TaskModel | TaskSpec | str | None" = None) -> TaskState:
    """The state of ``code`` in ``task``'s encoding (default the ``paper`` spec)."""
    spec = task.spec if isinstance(task, TaskModel) else get_task_spec(task)
    return decode_code(code, spec.segments, spec.n_objects)


def as_state(state: "StateLike", task: "TaskModel | TaskSpec | str | None" = None) -> TaskState:
    """Accept a [`TaskState`][tableclean_suite.task.state.TaskState] or its code in ``task``'s encoding (default ``paper``)."""
    return state if isinstance(state, TaskState) else decode(state, task)


def as_action(action) -> Action:
    """A built-in [`Action`][tableclean_suite.task.actions.Action] from itself, its index in the paper's order or its (case-insensitive) name."""
    if isinstance(action, Action):
        return action
    if isinstance(action, str):
        try:
            return Action[action.strip().upper()]
        except KeyError:
            pass
    elif is_integer(action):
        if 0 <= int(action) < len(Action):
            return Action(int(action))
    allowed = ", ".join(f"{a.value}/{a.rule_name}" for a in Action)
    raise ValueError(f"unknown action {action!r}; allowed: {allowed}")
