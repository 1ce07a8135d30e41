"""``tableclean-bench run --describe``: what the task model is, as tables and text.

Pure: every function returns a DataFrame or a string; `run` prints.  The Table 1
sections apply to tasks of the paper's sizes (2 segments, 1 object) and actions only.
"""

from __future__ import annotations

import pandas as pd

from tableclean_suite.analysis import exact_success_probability
from tableclean_suite.bench.cli import wrap
from tableclean_suite.bench.tables import PRINT_WIDTH, is_paper_task
from tableclean_suite.learners import get_learner, learner_names
from tableclean_suite.rewards import get_reward_pattern, reward_pattern_names
from tableclean_suite.task import PAPER_OPTIMAL_PLAN, TABLE1_STATES, TaskModel, table1_number

def states_table(model: TaskModel) -> pd.DataFrame:
    """All ``model.n_states`` states: code, name, Table 1 number ("-" where Table 1 omits it or the
    task is not of the paper's sizes), reachable?, terminal?, shortest plan length."""
    reachable = {s.index for s in model.reachable_states()}
    states = model.all_states()
    lengths = model.shortest_plan_lengths(states)
    numbers = [table1_number(state) if is_paper_task(model, extra_actions=True) else None for state in states]
    return pd.DataFrame([{"code": state.index, "name": state.name, "table1": "-" if number is None else number,
                          "reachable": state.index in reachable, "terminal": state.is_terminal,
                          "plan_length": "-" if lengths[state.index] is None else lengths[state.index]}
                         for state, number in zip(states, numbers)]).set_index("code")


def table1_frame(model: TaskModel) -> pd.DataFrame:
    """Table 1 rows 1-18 mapped to the model: code, name, reachable?, shortest plan length."""
    reachable = {s.index for s in model.reachable_states()}
    plans = {n: model.shortest_plan(state) if not state.is_terminal else [] for n, state in TABLE1_STATES.items()}
    return pd.DataFrame([{"table1": n, "code": state.index, "name": state.name, "reachable": state.index in reachable,
                          "plan_length": len(plans[n]) if plans[n] is not None else "-"}
                         for n, state in TABLE1_STATES.items()]).set_index("table1")


def rewards_frame() -> pd.DataFrame:
    """Registered reward patterns as the paper's Table 2 ("-" for no looping penalty)."""
    frame = pd.DataFrame([get_reward_pattern(n).as_row() for n in reward_pattern_names()]).set_index("reward")
    return frame.astype(object).where(frame.notna(), "-")


def learners_frame() -> pd.DataFrame:
    """Registered learners: name, on-policy?, update rule, Cruz et al.'s assistance, description."""
    return pd.DataFrame(
        [{"learner": n, "on_policy": get_learner(n).on_policy, "update": get_learner(n).method_name,
          "assistance": assistance_text(get_learner(n)), "description": get_learner(n).description}
         for n in learner_names()]
    ).set_index("learner")


def assistance_text(learner) -> str:
    """``"affordances: given"``, ``"advisor L=0.5 C=1"``, both, or ``"-"``
    (see [`tableclean_suite.learners.assist`][tableclean_suite.learners.assist])."""
    parts = []
    if learner.affordance != "none":
        parts.append(f"affordances: {learner.affordance}")
    if learner.advised:
        parts.append(f"advisor L={learner.advice_probability:g} C={learner.advice_consistency:g}")
    return ", ".join(parts) or "-"


def _plan_text(model: TaskModel, plan) -> str:
    return ", ".join(model.action_name(a).lower() for a in plan)


def describe(model: TaskModel, epsilon: float = 0.1, max_itr: int = 500) -> str:
    """The full ``--describe`` report as text.

    Raises:
        tableclean_suite.task.model.UnlearnableTaskError: no terminal state is reachable from a start state.
    """
    model.require_learnable()
    reachable = model.reachable_states()
    terminal = [s for s in reachable if s.is_terminal]
    paper_sized = is_paper_task(model, extra_actions=True)
    lines = [f"Task model: {model!r}"] + ([
        f"{model.n_states} states, code = ((segment1_clean * 2 + segment2_clean) * 3 + object_location) * 2 "
        "+ arm_segment",
        "  (object_location: 0 on segment 1, 1 on segment 2, 2 in gripper; arm_segment: 0 segment 1, 1 segment 2)",
    ] if paper_sized else [
        f"{model.n_states} state codes ({model.n_segments} segments, {model.n_objects} "
        f"object{'s' if model.n_objects > 1 else ''}; see tableclean_suite.task.encode)",
    ])
    lines += [
        "",
        "States (table1: Table 1's number, '-' where Table 1 omits the state; plan_length: shortest plan to terminal):",
        states_table(model).to_string(),
        "",
        f"Reachable from the all-unclean starts: {len(reachable)} states = "
        f"{len(reachable) - len(terminal)} non-terminal + {len(terminal)} terminal "
        f"(of {model.n_states}; unreachable codes: "
        f"{', '.join(str(s.index) for s in model.all_states() if s not in set(reachable))})",
        "Episode start(s) of this model: "
        + "; ".join(f"{s.index} ({s.name}, Table 1 state {(table1_number(s) if paper_sized else None) or '-'})"
                    for s in model.start_states()),
        *(_table1_lines(model) if paper_sized else ()),
        "",
        "Reward patterns (the paper's Table 2; an ineffective pick/place is "
        + ("rewarded as irrelevant cleaning):" if model.ineffective.value == "ineffective" else "improper):"),
        rewards_frame().to_string(line_width=PRINT_WIDTH),
        "",
        "Learners:",
        (learners := learners_frame()).drop(columns="description").to_string(line_width=PRINT_WIDTH),
        *(f"  {name}: {text}" for name, text in learners["description"].items()),
        "",
        "Exact success probability of the shortest-plan policy under epsilon-greedy exploration "
        f"(epsilon = {epsilon:g}, max_itr = {max_itr}, this model's start): "
        f"{100 * float(exact_success_probability(model.optimal_policy(), epsilon, max_itr, model=model)):.2f}%",
    ]
    if paper_sized:  # the paper's ~84 % is about its own task
        lines.append("  (the plateau a converged learner's success curve should reach; the paper reports ~84%)")
    return wrap("\n".join(lines))  # the tables fit already; prose is wrapped


def _table1_lines(model: TaskModel) -> list[str]:
    """Shortest and paper plans from Table 1's state 4, and Table 1 mapped to the model."""
    mapping = model.table1_mapping()
    state4 = TABLE1_STATES[4]
    plan4 = model.shortest_plan(state4)
    return [
        f"Shortest plan from Table 1 state 4 (code {state4.index}): {len(plan4)} actions: {_plan_text(model, plan4)}",
        f"The paper's optimal plan (Sec. 2): {len(PAPER_OPTIMAL_PLAN)} actions: "
        f"{_plan_text(model, PAPER_OPTIMAL_PLAN)}",
        "",
        "Table 1 of the paper mapped to the model:",
        table1_frame(model).to_string(),
        "",
        f"Table 1 rows never reachable: {', '.join(map(str, mapping['unreachable_rows']))}",
        "Reachable states Table 1 omits: "
        + "; ".join(f"{c} ({model.decode(c).name})" for c in mapping["omitted_reachable"]),
        "  of which the paper's own optimal plan from state 4 passes through: "
        + "; ".join(f"{c} ({model.decode(c).name})" for c in mapping["omitted_on_paper_plan"]),
    ]
