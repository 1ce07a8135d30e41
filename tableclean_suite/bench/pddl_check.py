"""Task specs solved by classical planners: each plan's length against the model's optimum, replayed in the model.

    tableclean-bench pddl --task all --planners pyperplan --states 50 --out results/pddl

Each task (``--task``: names or ``.json`` paths, or ``all``) is exported to PDDL
([`tableclean_suite.task.pddl`][tableclean_suite.task.pddl]) and solved by optimal planners (unified-planning,
the ``planning`` extra) from every reachable non-terminal state or a seeded sample (``--states``).  A state
fails when no plan is found, the plan's length is not the model's optimum, or its replay in the model does
not end terminal; failures are listed and the exit code is 1.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from tableclean_suite.bench import cli, outputs
from tableclean_suite.task import Outcome, TaskModel, get_task_spec, task_spec_names
from tableclean_suite.task import pddl

PROG = "tableclean-bench pddl"
#: Planner name -> the unified-planning engine (its optimal configuration: A* with LM-cut).
PLANNERS = {"pyperplan": "pyperplan-opt", "fast-downward": "fast-downward-opt"}
#: Below this many reachable non-terminal states every one is solved by default; else a sample.
ALL_STATES_BELOW, DEFAULT_SAMPLE = 2000, 200
INSTALL = 'pip install -e ".[planning]"'


def states_count(text: str) -> int | None:
    """``all`` (None) or a positive number of sampled states."""
    if text.strip().lower() == "all":
        return None
    try:
        return cli.positive_int(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"expected 'all' or a positive integer, got {text!r}") from None


def engines(planners) -> None:
    """Refuse planners that are not installed; the message names the extra to install."""
    try:
        from unified_planning.shortcuts import get_environment
    except ImportError:
        raise RuntimeError(f"the planners need unified-planning: {INSTALL}") from None
    environment = get_environment()
    environment.credits_stream = None
    missing = [p for p in planners if PLANNERS[p] not in environment.factory.engines]
    if missing:
        raise RuntimeError(f"planner(s) {', '.join(missing)} not installed: {INSTALL}")


def check_states(model: TaskModel, count: int | None, seed: int) -> list:
    """The reachable non-terminal states, or a seeded sample of ``count`` in code order (None: all below
    `ALL_STATES_BELOW`, else `DEFAULT_SAMPLE`)."""
    starts = list(dict.fromkeys(model.unclean_layouts() + model.start_states()))
    states = [s for s in model.reachable_states(starts) if not s.is_terminal]
    if count is None and len(states) < ALL_STATES_BELOW:
        return states
    count = DEFAULT_SAMPLE if count is None else count
    if count >= len(states):
        return states
    chosen = np.random.default_rng(seed).choice(len(states), size=count, replace=False)
    return [states[i] for i in sorted(chosen)]


def replay(model: TaskModel, state, actions) -> bool:
    """Whether ``actions`` (names) lead from ``state`` to the terminal state at the last one, none improper."""
    for i, action in enumerate(actions):
        state, outcome = model.step(state, action)
        if outcome == Outcome.IMPROPER or state.is_terminal != (i == len(actions) - 1):
            return False
    return bool(actions)


def solve(model: TaskModel, planner: str, states) -> pd.DataFrame:
    """One row per state: code, name, plan length (None: unsolved), optimum, replay_terminal, seconds."""
    from unified_planning.io import PDDLReader
    from unified_planning.shortcuts import OneshotPlanner

    spec = model.spec
    base = PDDLReader().parse_problem_string(pddl.domain_pddl(spec), pddl.problem_pddl(spec, states[0]))
    optimum = model.distances_to_terminal()
    rows = []
    with warnings.catch_warnings(), OneshotPlanner(name=PLANNERS[planner]) as engine:
        warnings.simplefilter("ignore", UserWarning)  # "cannot establish whether ... can solve": it can
        for state in states:
            problem = base.clone()
            for fact in base.explicit_initial_values:
                problem.set_initial_value(fact, False)
            for name, *args in pddl.init_facts(state):
                problem.set_initial_value(problem.fluent(name)(*map(problem.object, args)), True)
            started = time.perf_counter()
            result = engine.solve(problem)
            seconds = time.perf_counter() - started
            actions = None if result.plan is None else [a.action.name for a in result.plan.actions]
            rows.append({"code": state.index, "name": state.name, "length": None if actions is None else len(actions),
                         "optimum": int(optimum[state.index]), "seconds": seconds,
                         "replay_terminal": actions is not None and replay(model, state, actions)})
    return pd.DataFrame(rows)


def failures(task: str, planner: str, frame: pd.DataFrame) -> list[str]:
    """One line per failed state of ``solve``'s frame."""
    lines = []
    for row in frame.itertuples():
        where = f"{task}, {planner}, state {row.code} ({row.name})"
        if pd.isna(row.length) and row.optimum >= 0:
            lines.append(f"{where}: no plan found (optimum {row.optimum})")
        elif pd.isna(row.length):
            continue  # no plan exists, and none was found
        elif row.length != row.optimum:
            lines.append(f"{where}: plan of {int(row.length)} actions, optimum {row.optimum}")
        elif not row.replay_terminal:
            lines.append(f"{where}: the plan does not end in the terminal state when replayed")
    return lines


def summary(task: str, planner: str, frame: pd.DataFrame) -> dict:
    """The table's row of one task and planner."""
    return {"task": task, "states": len(frame), "planner": planner, "solved": int(frame["length"].notna().sum()),
            "equal_length": int(((frame["length"] == frame["optimum"])
                                 | (frame["length"].isna() & (frame["optimum"] < 0))).sum()),
            "replay_terminal": int(frame["replay_terminal"].sum()), "solve_s": round(frame["seconds"].sum(), 1),
            "ms_per_state": round(1000 * frame["seconds"].mean(), 1)}


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line."""
    parser = cli.command_parser(prog, __doc__.split("\n\n")[0])
    parser.add_argument("--task", type=cli.name_list, default=("paper",), metavar="NAME|FILE.json,...|all",
                        help="task specs, comma separated, or 'all' registered ones (default paper)")
    parser.add_argument("--planners", type=cli.choice_list(tuple(PLANNERS), "planner"), default=tuple(PLANNERS),
                        metavar="NAME,...", help=f"optimal planners: {', '.join(PLANNERS)} (default both)")
    parser.add_argument("--states", type=states_count, default=None, metavar="all|N",
                        help=f"solve from every reachable non-terminal state, or a sample of N (default: all below "
                             f"{ALL_STATES_BELOW}, else {DEFAULT_SAMPLE})")
    cli.add_seed_argument(parser, "the sample of states")
    cli.add_out_argument(parser, cli.DIRECTORY, argparse.SUPPRESS,
                         "also write the table, every state's row and the PDDL here (default: print only)")
    return parser


def main(argv=None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    parser, args = cli.parse_command(build_parser, argv, prog or PROG)
    names = task_spec_names() if args.task == ("all",) else args.task
    try:
        specs = [get_task_spec(name) for name in names]
        for spec in specs:
            pddl.domain_pddl(spec)  # refuses an action without PDDL
        engines(args.planners)
    except (ValueError, RuntimeError) as error:
        parser.error(str(error))
    out = getattr(args, "out", None)
    problem = outputs.check_writable(out) if out is not None else None
    if problem:
        parser.error(f"--out: {problem}")
    rows, frames, failed = [], [], []
    for spec in specs:
        model = TaskModel(spec=spec)
        states = check_states(model, args.states, args.seed)
        for planner in args.planners:
            frame = solve(model, planner, states)
            rows.append(summary(spec.name, planner, frame))
            frames.append(frame.assign(task=spec.name, planner=planner))
            failed += failures(spec.name, planner, frame)
            print(cli.markdown_table(rows[-1:]).splitlines()[-1], file=sys.stderr, flush=True)  # progress
    table = pd.DataFrame(rows)
    print(cli.markdown_table(table))
    if out is not None:
        out = Path(out)
        outputs.atomic_write(out / "pddl_check.csv", lambda path: table.to_csv(path, index=False))
        outputs.atomic_write(out / "pddl_states.csv", lambda path: pd.concat(frames).to_csv(path, index=False))
        for spec in specs:
            pddl.write_pddl(spec, out / spec.name)
        print(f"written: {out}")
    for line in failed:
        print(f"FAIL {line}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("pddl", "python -m tableclean_suite.bench.pddl_check"))
