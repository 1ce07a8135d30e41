"""The skills on several arms: fidelity and optimal-episode success per robot x gripper x task spec.

    tableclean-bench robots [--robots Panda,Sawyer,UR5e,Kinova3] [--grippers default,RethinkGripper,...]
                            [--tasks paper,three_segments_two_objects] [--fresh] [--episodes E] [--fidelity-trials T]
                            [--seed S] [--out DIR] [--randomize]

For every (robot, gripper, spec) cell (``default``: the gripper the robot's config mounts):

- **fidelity**: ``T`` rounds of ``tableclean-bench fidelity`` (resumable, stored in
  ``<fidelity-dir>/<robot>[_<gripper>]_<spec>[_randomized]/``);
- **episodes**: ``E`` episodes from random start layouts, each executing the model's shortest plan;
  one succeeds when every skill does and the state read back at the end is terminal (seconds:
  wall-clock per episode, reset included).

``--randomize`` runs both with randomised dynamics (the row's ``dynamics``).  Writes ``DIR/robot_table.csv``
(one row per cell, rewritten after each; ``--append`` keeps other runs' cells) and prints counts with
their one-sided 95 % lower bounds.  ``T = 0`` or ``E = 0`` skips that part.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

from tableclean_suite.bench import cli, fidelity, trial_store

#: Default arms: the Panda and the three others with shipped skill configs.
DEFAULT_ROBOTS = ("Panda", "Sawyer", "UR5e", "Kinova3")
#: Default task specs.
DEFAULT_TASKS = ("paper", "three_segments_two_objects")
#: Default output directory of the table, and of the fidelity trials.
DEFAULT_OUT = "results/robots"
DEFAULT_FIDELITY_DIR = "results/fidelity_robots"
#: File name of the table.
TABLE_CSV = "robot_table.csv"
#: Columns of the table, in order.
COLUMNS = ("robot", "gripper", "task", "dynamics", "fidelity_trials", "fidelity_rounds", "fidelity_agreement",
           "fidelity_faults", "episodes", "episode_successes", "episode_success_rate", "seconds_per_episode")
#: ``dynamics`` of a row: the scene as built, or randomised at every reset.
NOMINAL, RANDOMIZED = "nominal", "randomized"
#: Columns that identify a cell (a later run's row replaces an earlier one with the same key).
CELL_KEY = ("robot", "gripper", "task", "dynamics")
#: ``--grippers`` entry for the gripper the robot's config mounts (robosuite's ``gripper_types="default"``).
DEFAULT_GRIPPER = "default"
MARKDOWN_COLUMNS = ("robot", "gripper", "task", "dynamics", "fidelity: agreeing trials", "95 % lower bound", "faults",
                    "optimal episodes: successes", "95 % lower bound", "s / episode")


def gripper_name(robot: str, gripper: str) -> str:
    """robosuite's name of the gripper ``robot`` carries with ``gripper_types=gripper``; ``ValueError`` naming
    a gripper the skills do not drive."""
    from tableclean_suite.environments.robot_registry import scene_gripper_types

    name = scene_gripper_types(robot, gripper)
    if name == DEFAULT_GRIPPER:  # the robot's own default
        import robosuite.models.robots as models

        name = getattr(models, robot)().default_gripper["right"]
    return name


def table_row(robot: str, task: str, fid: dict | None, eps: dict | None, dynamics: str = NOMINAL,
              gripper: str = "") -> dict:
    """One row of the table (`COLUMNS`; ``gripper``: robosuite's name); ``fid``: a fidelity summary, ``eps``:
    [`play_episodes`][tableclean_suite.bench.fidelity.play_episodes]'s tally; empty strings for a skipped part."""
    row = {"robot": robot, "gripper": gripper, "task": task, "dynamics": dynamics}
    if fid is not None:
        row.update(fidelity_trials=fid["trials"], fidelity_rounds=fid["rounds"],
                   fidelity_agreement=round(fid["agreement"], 6), fidelity_faults=fid["faults"])
    if eps is not None and eps["episodes"]:
        row.update(episodes=eps["episodes"], episode_successes=eps["successes"],
                   episode_success_rate=round(eps["successes"] / eps["episodes"], 6),
                   seconds_per_episode=round(eps["seconds"] / eps["episodes"], 3))
    return {column: row.get(column, "") for column in COLUMNS}


class TableFileError(ValueError):
    """An existing robot table that cannot be merged into; the message names the file, line and value."""


def read_table(path: Path) -> list[dict]:
    """The rows (text cells) of an existing table, ``[]`` when there is none; ``TableFileError`` naming the
    file, line and value of a missing column, a row without robot and task, or a non-number."""
    lines = trial_store.read_lines(path, TableFileError, "remove it or leave out --append")
    try:
        reader = csv.DictReader(lines)
        header = reader.fieldnames or []
        missing = [c for c in COLUMNS if c not in header and c not in ("dynamics", "gripper")]
        if missing:
            raise TableFileError(f"{path}: not a robot table (columns {missing} are missing); remove it or leave "
                                 "out --append")
        rows = []
        for line, raw in enumerate(reader, start=2):
            if None in raw or any(raw.get(c) is None for c in header):
                raise TableFileError(f"{path}:{line}: the row does not have the header's {len(header)} columns")
            row = {column: raw.get(column, "") for column in COLUMNS}
            row["dynamics"] = row["dynamics"] or NOMINAL  # tables written before the column
            if not row["robot"] or not row["task"] or row["dynamics"] not in (NOMINAL, RANDOMIZED):
                raise TableFileError(f"{path}:{line}: robot {row['robot']!r}, task {row['task']!r} and dynamics "
                                     f"{row['dynamics']!r} must name a cell")
            for column in COLUMNS:
                try:
                    float(row[column]) if column not in CELL_KEY and row[column] != "" else None
                except ValueError:
                    raise TableFileError(f"{path}:{line}: column {column!r} is {row[column]!r}, not a number") from None
            rows.append(row)
    except csv.Error as error:
        raise TableFileError(f"{path}: not a CSV table ({error}); remove it or leave out --append") from None
    return rows


def merge_rows(path: Path, rows: list[dict]) -> list[dict]:
    """The rows already in ``path`` with the cells of ``rows`` replaced or added, in the file's order."""
    return list({tuple(row[key] for key in CELL_KEY): row for row in [*read_table(path), *rows]}.values())


def markdown(rows: list[dict]) -> str:
    """The table as markdown, one line per cell: agreeing fidelity trials and successful optimal episodes as
    ``count/n = rate`` with their one-sided 95 % lower bounds, faults, seconds per episode; ``-``: skipped."""
    lines = []
    for row in rows:
        number = {key: float(value) for key, value in row.items() if key not in CELL_KEY and value != ""}
        fid = eps = ("-", "-")
        if "fidelity_trials" in number:  # the count from the stored rate (6 decimals: exact below 10^5 trials)
            trials = int(number["fidelity_trials"])
            fid = fidelity.count_cells(round(number["fidelity_agreement"] * trials), trials)
        if "episodes" in number:
            eps = fidelity.count_cells(int(number["episode_successes"]), int(number["episodes"]))
        lines.append((row["robot"], row["gripper"] or "-", row["task"], row["dynamics"], *fid,
                      f"{number['fidelity_faults']:.0f}" if "fidelity_faults" in number else "-", *eps,
                      f"{number['seconds_per_episode']:.2f}" if "seconds_per_episode" in number else "-"))
    return cli.markdown_table(lines, MARKDOWN_COLUMNS)


#: The program name in messages unless the caller gives one.
PROG = "tableclean-bench robots"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line: the shared options of [`cli`][tableclean_suite.bench.cli] and the table's own."""
    parser = cli.command_parser(prog, __doc__.split("\n\n")[0])
    cli.add_robots_argument(parser, many=True, default=",".join(DEFAULT_ROBOTS))
    parser.add_argument("--grippers", type=cli.name_list, default=DEFAULT_GRIPPER, metavar="NAME,...",
                        help="comma-separated robosuite grippers every robot is measured with (gripper_types; "
                             f"'{DEFAULT_GRIPPER}': the one its config mounts; default {DEFAULT_GRIPPER})")
    parser.add_argument("--tasks", type=cli.name_list, default=",".join(DEFAULT_TASKS),
                        help=f"comma-separated task specs (default {','.join(DEFAULT_TASKS)})")
    parser.add_argument("--episodes", type=cli.non_negative_int, default=30,
                        help="optimal-plan episodes from random layouts per cell (default 30; 0 skips)")
    parser.add_argument("--fidelity-trials", type=cli.non_negative_int, default=2,
                        help="fidelity rounds (trials per (state, action) pair) per cell (default 2; 0 skips)")
    cli.add_seed_argument(parser, "the placements and layouts")
    cli.add_out_argument(parser, cli.DIRECTORY, DEFAULT_OUT, f"directory of {TABLE_CSV}")
    parser.add_argument("--fidelity-dir", default=DEFAULT_FIDELITY_DIR,
                        help="directory of the fidelity trials, one <robot>_<task> folder per cell (default "
                             f"{DEFAULT_FIDELITY_DIR})")
    parser.add_argument("--append", action="store_true",
                        help=f"keep the other cells already in {TABLE_CSV} (this run's cells replace theirs)")
    parser.add_argument("--fresh", action="store_true", help="discard the earlier fidelity trials of this run's cells")
    parser.add_argument("--randomize", action="store_true",
                        help="randomised dynamics at every reset (the scene's documented default ranges)")
    parser.add_argument("--quiet", action="store_true", help="print only the table")
    return parser


def main(argv: list[str] | None = None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    parser, args = cli.parse_command(build_parser, argv, prog or PROG)
    robots = cli.parse_robots(parser, args)  # every name checked before anything runs
    models = {task: fidelity.physical_model(parser, task, "--tasks") for task in args.tasks}
    grippers = {}  # (robot, --grippers entry) -> robosuite's name
    for robot in robots:
        for gripper in args.grippers:
            try:
                grippers[robot, gripper] = gripper_name(robot, gripper)
            except ValueError as error:
                parser.error(f"--grippers: {error}")
    if not (args.fidelity_trials or args.episodes):
        parser.error("--fidelity-trials and --episodes are both 0: nothing to measure")
    log = None if args.quiet else print
    table = Path(args.out) / TABLE_CSV
    try:
        if args.append:  # a table that cannot be merged into is refused before anything runs
            read_table(table)
    except TableFileError as error:
        parser.error(f"--append: {error}")
    cells = {}  # (robot, gripper, task) -> (fidelity folder, scene options)
    for robot, gripper in grippers:
        for task in models:
            name = f"{robot}_{task}" if gripper == DEFAULT_GRIPPER else f"{robot}_{gripper}_{task}"
            name += fidelity.RANDOMIZED_SUFFIX if args.randomize else ""
            scene = {**fidelity.scene_env_kwargs(robot, args.randomize),  # as fidelity's, plus gripper_types
                     **({} if gripper == DEFAULT_GRIPPER else {"gripper_types": gripper})}
            cells[robot, gripper, task] = (Path(args.fidelity_dir) / name, {"env_kwargs": scene})
    try:
        if args.fidelity_trials and not args.fresh:  # stored trials of other options: refused before anything runs
            for (robot, gripper, task), (folder, options) in cells.items():
                fidelity.check_configuration(folder / fidelity.TRIALS_CSV,
                                             fidelity.run_configuration(models[task], options, args.plugins))
        rows = []
        started = time.perf_counter()
        for (robot, gripper, task), (folder, options) in cells.items():
            fid = eps = None
            if args.fidelity_trials:
                fid = fidelity.measure(folder, models[task], args.fidelity_trials, args.seed, log=log,
                                       fresh=args.fresh, physics_options=options, plugins=args.plugins)[2]
            if args.episodes:  # from random start layouts, in the scene of the cell's fidelity trials
                eps = fidelity.play_episodes(args.episodes, log=log, label=f"{robot} ({gripper}) {task}",
                                             object_segment=None, arm_segment=None, task=task, seed=args.seed,
                                             **options["env_kwargs"])
            name = grippers[robot, gripper]
            rows.append(table_row(robot, task, fid, eps, RANDOMIZED if args.randomize else NOMINAL, name))
            trial_store.write_rows(table, merge_rows(table, rows) if args.append else rows, COLUMNS)
            if log:
                log(f"{robot} ({name}) x {task} done ({time.perf_counter() - started:.0f} s)")
    except trial_store.TrialStoreError as error:  # e.g. trials of another --seed
        parser.error(f"{error} (robot_table: --fresh, or another --fidelity-dir)")
    print(markdown(merge_rows(table, []) if args.append else rows))
    print(f"\n{table} ({time.perf_counter() - started:.0f} s)")
    return 0


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("robots", "python -m tableclean_suite.bench.robot_table"))
