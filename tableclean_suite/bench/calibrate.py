"""A physics-calibrated transition model: the fidelity executions, counted into a TransitionTable.

    tableclean-bench calibrate --task three_segments --trials 5 --out transitions.json
    tableclean-bench calibrate --from-trials results/fidelity/fidelity_trials.csv --out transitions.json

Every (state, action) pair is executed ``N`` times as ``tableclean-bench fidelity`` does, and the
observed ``(next_state, outcome)`` frequencies become the pair's successor distribution; abstraction
faults are left out and counted in the table's ``source``, pairs never executed keep the model's
successor.  The trials are kept in ``<out>.trials.csv`` (resumable); ``--from-trials`` converts an
existing fidelity trials file without physics.

Train on the result at symbolic speed:

    tableclean-bench run --backend calibrated --transitions transitions.json
    train(backend="calibrated", transitions="transitions.json")
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from pathlib import Path

from tableclean_suite.bench import cli, trial_store
from tableclean_suite.bench.fidelity import (
    FAULT,
    add_execution_arguments,
    check_trial_rows,
    collect,
    parse_task_and_actions,
    read_configuration,
    trials_per_round,
)
from tableclean_suite.learners.transitions import TransitionTable
from tableclean_suite.task import Outcome, TaskModel
from tableclean_suite.task.state import NO_CHANGE_OUTCOMES


class CalibrationError(ValueError):
    """A trial that cannot enter a transition table; the message names the trial and the value."""


def count_transitions(rows, model: TaskModel | None = None) -> tuple[dict, int]:
    """``({(state, action index): {(next_state, outcome): n}}, faults)`` from fidelity trial rows (default ``paper``).

    Raises:
        TrialStoreError: a trial whose state, action, observed state or outcome is not the task's
            ([`check_trial_rows`][tableclean_suite.bench.fidelity.check_trial_rows]).
        CalibrationError: an outcome that does not fit its observed state (TERMINAL exactly with a terminal
            state, no-change outcomes with the same state), so no table ``run --backend calibrated`` refuses
            is written.
    """
    model = model or TaskModel()
    rows = list(rows)
    check_trial_rows(rows, model, "trials")
    counts: dict[tuple[int, int], Counter] = {}
    for position, row in enumerate(rows):
        if row["observed_outcome"] == FAULT:
            continue
        state, next_state = int(row["state"]), int(row["observed_state"])
        outcome = Outcome[row["observed_outcome"].upper()]
        name = outcome.name.lower()
        where = f"trial {position + 1} (round {row.get('round')})"
        if model.decode(next_state).is_terminal != (outcome == Outcome.TERMINAL):
            raise CalibrationError(f"{where}: outcome {name} with observed state {next_state}; TERMINAL goes with, "
                                   "and only with, a terminal state")
        if outcome in NO_CHANGE_OUTCOMES and next_state != state:
            raise CalibrationError(f"{where}: outcome {name} leaves the state unchanged, but the observed state "
                                   f"{next_state} != {state}")
        counts.setdefault((state, model.action_index(row["action"])), Counter())[(next_state, int(outcome))] += 1
    return {key: dict(value) for key, value in counts.items()}, sum(r["observed_outcome"] == FAULT for r in rows)


def measured_with(configuration: dict | None) -> str:
    """The robot and randomisation of recorded trials' configuration, for the table's ``source``."""
    if configuration is None:
        return "scene options unknown (no configuration recorded beside the trials)"
    options = configuration.get("physics_options") or {}
    env = options.get("env_kwargs", {}) if isinstance(options, dict) else {}
    env = env if isinstance(env, dict) else {}
    return f"robot {env.get('robots', 'Panda')}, randomization {env.get('randomization', 'off')}"


def calibrated_table(rows, model: TaskModel | None = None, description: str = "") -> TransitionTable:
    """The empirical [`TransitionTable`][tableclean_suite.learners.transitions.TransitionTable] of fidelity trial
    rows (faults excluded)."""
    model = model or TaskModel()
    counts, faults = count_transitions(rows, model)
    executions = sum(sum(c.values()) for c in counts.values())
    source = f"physics calibration: {executions} executions, {faults} abstraction faults excluded"
    return TransitionTable.from_counts(counts, model, source + (f"; {description}" if description else ""))


def check_trials_task(configuration: dict | None, model: TaskModel, source) -> None:
    """Refuse trials recorded on another task than ``model``'s (naming both); None: nothing recorded."""
    if configuration is None:
        return
    recorded = configuration.get("task")
    if recorded != model.spec.to_dict():
        name = recorded.get("name") if isinstance(recorded, dict) else recorded
        raise CalibrationError(f"{source} holds trials of task {name!r} (its {source.stem}.config.json), not of "
                               f"{model.spec.name!r}; pass --task with that spec")


#: The program name in messages unless the caller gives one.
PROG = "tableclean-bench calibrate"
DEFAULT_OUT = "transitions.json"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line: fidelity's execution options and calibrate's own."""
    parser = cli.command_parser(prog, __doc__.split("\n\n")[0])
    add_execution_arguments(parser)  # pairs of actions not executed keep the model's successor
    cli.add_out_argument(parser, cli.FILE, DEFAULT_OUT, "JSON file to write", suffixes=(".json",))
    parser.add_argument("--fresh", action="store_true", help="discard earlier trials in <out>.trials.csv")
    parser.add_argument("--from-trials", metavar="CSV", help="build from an existing fidelity_trials.csv, no physics")
    return parser


def main(argv: list[str] | None = None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    parser, args = cli.parse_command(build_parser, argv, prog or PROG)
    model, actions = parse_task_and_actions(parser, args)
    out = Path(args.out)
    started = time.perf_counter()
    log = None if args.quiet else print
    try:
        if args.from_trials:
            source = Path(args.from_trials)
            if not source.exists():
                parser.error(f"--from-trials: no such file {source}")
            configuration = read_configuration(source)
            check_trials_task(configuration, model, source)
            rows = trial_store.read_rows(source, log)
            check_trial_rows(rows, model, source)  # before rounds are counted by their actions
            measured_actions = {row["action"] for row in rows}  # a file may hold a subset of the actions
            rows = trial_store.complete_rounds(rows, trials_per_round(model, measured_actions), log)
            if not rows:
                parser.error(f"--from-trials: {source} holds no complete round of task {model.spec.name!r}")
            description = f"from {source.name}; {measured_with(configuration)}"
        else:
            with cli.executor_from_args(parser, args) as executor:
                trials_csv = out.with_suffix(".trials.csv")
                rows = collect(args.trials, args.seed, trials_csv, fresh=args.fresh, log=log,
                               actions=actions, model=model, executor=executor, plugins=args.plugins)
            description = f"{args.trials} round(s), seed {args.seed}; {measured_with(read_configuration(trials_csv))}"
        table = calibrated_table(rows, model, description=description)
    except (trial_store.TrialStoreError, CalibrationError) as error:
        parser.error(str(error))
    out.parent.mkdir(parents=True, exist_ok=True)
    table.to_json(out)
    model_next, model_outcome = model.transition_arrays()
    stochastic = []
    for (state, action) in sorted({(int(r["state"]), model.action_index(r["action"])) for r in rows}):
        successors = table.successors(state, action)
        if len(successors) > 1 or successors[0][:2] != (model_next[state, action], model_outcome[state, action]):
            stochastic.append(table.describe_pair(state, action))
    print(f"wrote {out}: {table.source}")
    print("\n  ".join([f"{len(stochastic)} pair(s) differ from the task model:", *stochastic]) if stochastic
          else "every measured pair matches the task model")
    print(f"({time.perf_counter() - started:.0f} s)")
    return 0


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("calibrate", "python -m tableclean_suite.bench.calibrate"))
