"""The skills on several arms: fidelity and optimal-episode success per robot x gripper x task spec.

    tableclean-bench robots [--robots Panda,Sawyer,UR5e,Kinova3] [--grippers default,RethinkGripper,...]
                            [--tasks paper,three_segments_two_objects] [--fresh] [--episodes E] [--fidelity-trials T]
                            [--seed S] [--out DIR] [--randomize]

For every (robot, gripper, spec) cell (``default``: the gripper the robot's config mounts; the
``gripper`` column names robosuite's gripper that ran):

- **fidelity**: `tableclean_suite.bench.fidelity.collect` with ``T`` rounds (every action from
  every reachable non-terminal state, ``T`` times; a trial agrees when physics ends in the model's
  successor with the model's outcome); the trials are stored in
  ``<fidelity-dir>/<robot>_<spec>/fidelity_trials.csv`` (``<robot>_<gripper>_<spec>`` for a gripper named
  by ``--grippers``) (resumable, as ``tableclean-bench fidelity``);
- **episodes**: ``E`` episodes from random start layouts (every object and the arm on a segment
  drawn at each reset, all segments dirty, placement noise), each executing the task model's
  shortest plan with the compiled control path; an episode succeeds when every skill succeeds and
  the symbolic state read back at the end is terminal.  Seconds per episode are wall-clock
  (reset and plan).

With ``--randomize`` both run with the scene's randomised dynamics
(`tableclean_suite.environments.randomization.DEFAULT_ON`, drawn at every reset from the
seeded ``env.rng``); the row's ``dynamics`` column says ``randomized`` (else ``nominal``) and its
fidelity trials go to ``<fidelity-dir>/<robot>_<spec>_randomized``.

Writes ``DIR/robot_table.csv`` (one row per cell, rewritten after every cell; ``--append`` keeps
the cells of earlier runs, e.g. of robots measured in another process) and prints a markdown
table: agreeing trials and successful episodes as counts, each with its one-sided 95 % exact
lower bound ([lower_bound][tableclean_suite.bench.fidelity.lower_bound]).  ``T = 0`` or ``E = 0``
skips that part.
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

from tableclean_suite.bench import cli, fidelity, trial_store  # noqa: E402
from tableclean_suite.bench.cli import non_negative_int  # noqa: E402
from tableclean_suite.bench.run import split_list  # noqa: E402

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


def gripper_name(robot: str, gripper: str) -> str:
    """robosuite's name of the gripper ``robot`` carries with ``gripper_types=gripper`` (checked: ``ValueError``
    naming a gripper the skills do not drive)."""
    from tableclean_suite.environments.robot_registry import scene_gripper_types

    name = scene_gripper_types(robot, gripper)
    if name == DEFAULT_GRIPPER:  # the robot's own default
        import robosuite.models.robots as models

        name = getattr(models, robot)().default_gripper["right"]
    return name


def env_kwargs(robot: str, gripper: str, randomize: bool) -> dict:
    """The scene options of a cell: [`scene_env_kwargs`][tableclean_suite.bench.fidelity.scene_env_kwargs] and,
    for a gripper other than `DEFAULT_GRIPPER`, ``gripper_types``."""
    return {**fidelity.scene_env_kwargs(robot, randomize),
            **({} if gripper == DEFAULT_GRIPPER else {"gripper_types": gripper})}


def run_episodes(robot: str, task: str, episodes: int, seed: int = 0, log=print, randomization=None,
                 gripper: str = DEFAULT_GRIPPER) -> dict:
    """``episodes`` optimal-plan episodes of ``task`` on ``robot`` from random start layouts.

    Returns ``{"episodes", "successes", "seconds"}`` (seconds: total wall-clock time of the
    episodes, resets included; the scene build is not counted) and ``"failures"``: up to a few
    ``(episode, reason)`` of failed episodes.  ``randomization``: the scene's ``randomization=``
    (None: nominal dynamics); ``gripper``: the scene's ``gripper_types``.
    """
    from tableclean_suite.controllers import SkillController, make_skill_env

    env = make_skill_env(None, None, robots=robot, task=task, seed=seed, randomization=randomization,
                         gripper_types=gripper)
    failures = []
    successes = 0
    seconds = 0.0
    try:
        controller = SkillController(env)
        model = controller.model
        for episode in range(episodes):
            started = time.perf_counter()
            env.reset()
            try:
                start = env.symbolic_state()
                results = controller.execute_plan(model.shortest_plan(start))
                final = env.symbolic_state()
                ok = all(r.success for r in results) and final.is_terminal
                reason = "; ".join(f"{model.action_name(r.action)}: {r.reason}" for r in results if not r.success)
            except Exception as error:  # an abstraction fault at the start or end: a failed episode
                ok, reason = False, f"{type(error).__name__}: {error}"
            seconds += time.perf_counter() - started
            successes += ok
            if not ok:
                failures.append((episode, reason or "not terminal"))
                if log:
                    log(f"  {robot} ({gripper}) {task} episode {episode}: FAILED ({reason or 'not terminal'})")
    finally:
        env.close()
    return {"episodes": episodes, "successes": successes, "seconds": seconds, "failures": failures}


def run_fidelity(robot: str, task: str, trials: int, seed: int, out: Path, log=print, randomize: bool = False,
                 fresh: bool = False, gripper: str = DEFAULT_GRIPPER) -> dict:
    """Fidelity rounds of ``task`` on ``robot`` (trials stored under ``out``, as ``tableclean-bench fidelity``
    stores them: the same scene options, so either command resumes the other's); the
    [`summary`][tableclean_suite.bench.fidelity.summary] dict.  ``fresh`` discards earlier trials; ``gripper``: the
    scene's ``gripper_types``."""
    from tableclean_suite.task import TaskModel, get_task_spec

    model = TaskModel(spec=get_task_spec(task))
    rows = fidelity.collect(trials, seed, out / fidelity.TRIALS_CSV, fresh=fresh, log=log, model=model,
                            physics_options={"env_kwargs": env_kwargs(robot, gripper, randomize)})
    fidelity.write_csv(out / fidelity.PAIRS_CSV, fidelity.pair_table(rows, model))
    fidelity.write_csv(out / fidelity.SKILLS_CSV, fidelity.skill_table(rows, model))
    return fidelity.summary(rows, model)


def table_row(robot: str, task: str, fid: dict | None, eps: dict | None, dynamics: str = NOMINAL,
              gripper: str = "") -> dict:
    """One row of the table (`COLUMNS`; ``gripper``: robosuite's name); empty strings for a part that was skipped."""
    row = {"robot": robot, "gripper": gripper, "task": task, "dynamics": dynamics}
    if fid is not None:
        row.update(fidelity_trials=fid["trials"], fidelity_rounds=fid["rounds"],
                   fidelity_agreement=round(fid["agreement"], 6), fidelity_faults=fid["faults"])
    if eps is not None and eps["episodes"]:
        row.update(episodes=eps["episodes"], episode_successes=eps["successes"],
                   episode_success_rate=round(eps["successes"] / eps["episodes"], 6),
                   seconds_per_episode=round(eps["seconds"] / eps["episodes"], 3))
    return {column: row.get(column, "") for column in COLUMNS}


def write_table(path: Path, rows: list[dict]) -> None:
    """Write ``rows`` (`COLUMNS`) to ``path`` atomically."""
    trial_store.write_rows(path, rows, COLUMNS)


class TableFileError(ValueError):
    """An existing robot table that cannot be merged into; the message names the file, line and value."""


def read_table(path: Path) -> list[dict]:
    """The rows of an existing table (``[]`` when there is none), each checked: the header holds every
    column of `COLUMNS` (``dynamics`` and ``gripper`` may be missing in tables written before them), a row has a
    robot and a task, and the other cells are numbers or empty.

    Raises:
        TableFileError: naming the file, the line and the bad value (so ``--append`` never
            republishes garbage).
    """
    path = Path(path)
    if not path.exists():
        return []
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise TableFileError(f"{path}: not a UTF-8 text file (byte {error.start}); remove it or leave out "
                             "--append") from None
    except OSError as error:
        raise TableFileError(f"{path}: cannot be read ({error.strerror or error})") from None
    try:
        reader = csv.DictReader(text.splitlines())
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
                if column not in CELL_KEY and row[column] != "":
                    try:
                        float(row[column])
                    except ValueError:
                        raise TableFileError(f"{path}:{line}: column {column!r} is {row[column]!r}, not a "
                                             "number") from None
            rows.append(row)
    except csv.Error as error:
        raise TableFileError(f"{path}: not a CSV table ({error}); remove it or leave out --append") from None
    return rows


def merge_rows(path: Path, rows: list[dict]) -> list[dict]:
    """The rows already in ``path`` (if any; [`read_table`][tableclean_suite.bench.robot_table.read_table]) with the cells of ``rows`` replaced or
    added, in the file's order."""
    merged: dict[tuple, dict] = {}
    for row in read_table(path):
        merged[tuple(row[key] for key in CELL_KEY)] = row
    for row in rows:
        merged[tuple(row[key] for key in CELL_KEY)] = row
    return list(merged.values())


def _number(value):
    """A CSV cell as read back (strings) or as written (numbers): a float, or "" for an empty cell."""
    return "" if value == "" else float(value)


def _count_cells(count: int, n: int) -> tuple[str, str]:
    """``("count/n = rate %", "lower bound %")`` of ``count`` of ``n`` ([`fidelity.lower_bound`][tableclean_suite.bench.fidelity.lower_bound], rounded down)."""
    return f"{count}/{n} = {100 * count / n:.2f} %", fidelity.percent_down(fidelity.lower_bound(count, n))


def markdown(rows: list[dict]) -> str:
    """The table as markdown, one line per cell: agreeing fidelity trials of all (``count/n = rate``) and the
    agreement's one-sided 95 % lower bound, abstraction faults, successful optimal episodes of all and their
    success's lower bound ([lower_bound][tableclean_suite.bench.fidelity.lower_bound], rounded down to 0.1 %),
    and seconds per episode; ``-`` for a part that was skipped."""
    lines = ["| robot | gripper | task | dynamics | fidelity: agreeing trials | 95 % lower bound | faults "
             "| optimal episodes: successes | 95 % lower bound | s / episode |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for row in rows:
        row = {key: (value if key in CELL_KEY else _number(value)) for key, value in row.items()}
        fid = eps = ("-", "-")
        if row["fidelity_trials"] != "":  # the count from the stored rate (6 decimals: exact below 10^5 trials)
            trials = int(row["fidelity_trials"])
            fid = _count_cells(round(row["fidelity_agreement"] * trials), trials)
        if row["episodes"] != "":
            eps = _count_cells(int(row["episode_successes"]), int(row["episodes"]))
        secs = f"{row['seconds_per_episode']:.2f}" if row["seconds_per_episode"] != "" else "-"
        faults = f"{row['fidelity_faults']:.0f}" if row["fidelity_faults"] != "" else "-"
        lines.append(f"| {row['robot']} | {row['gripper'] or '-'} | {row['task']} | {row['dynamics']} | {fid[0]} | {fid[1]} | {faults} "
                     f"| {eps[0]} | {eps[1]} | {secs} |")
    return "\n".join(lines)


def _names(parser, flag: str, text: str) -> list[str]:
    """The comma-separated names of ``text``, in order, each once; exits 2 when there is none."""
    names = list(dict.fromkeys(split_list(text)))
    if not names:
        parser.error(f"{flag}: expected at least one name, got {text!r}")
    return names


#: The program name in messages unless the caller gives one.
PROG = "tableclean-bench robots"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line: the shared options of [`cli`][tableclean_suite.bench.cli] and the table's own."""
    parser = cli.command_parser(prog, __doc__.split("\n\n")[0])
    cli.add_robots_argument(parser, many=True, default=",".join(DEFAULT_ROBOTS))
    parser.add_argument("--grippers", default=DEFAULT_GRIPPER, metavar="NAME,...",
                        help="comma-separated robosuite grippers every robot is measured with (gripper_types; "
                             f"'{DEFAULT_GRIPPER}': the one its config mounts; default {DEFAULT_GRIPPER})")
    parser.add_argument("--tasks", default=",".join(DEFAULT_TASKS),
                        help=f"comma-separated task specs (default {','.join(DEFAULT_TASKS)})")
    parser.add_argument("--episodes", type=non_negative_int, default=30,
                        help="optimal-plan episodes from random layouts per cell (default 30; 0 skips)")
    parser.add_argument("--fidelity-trials", type=non_negative_int, default=2,
                        help="fidelity rounds (trials per (state, action) pair) per cell (default 2; 0 skips)")
    cli.add_seed_argument(parser, "the placements and layouts")
    cli.add_out_argument(parser, cli.DIRECTORY, DEFAULT_OUT, f"directory of {TABLE_CSV}")
    parser.add_argument("--fidelity-dir", default=DEFAULT_FIDELITY_DIR,
                        help=f"directory of the fidelity trials, one <robot>_<task> folder per cell (default {DEFAULT_FIDELITY_DIR})")
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
    from tableclean_suite.physics_backend import check_physical_task
    from tableclean_suite.task import TaskModel, get_task_spec

    robots = cli.parse_robots(parser, args)  # every name checked before anything runs
    tasks = _names(parser, "--tasks", args.tasks)
    grippers = {}  # (robot, --grippers entry) -> robosuite's name, every one checked before anything runs
    for robot in robots:
        for gripper in _names(parser, "--grippers", args.grippers):
            try:
                grippers[robot, gripper] = gripper_name(robot, gripper)
            except ValueError as error:
                parser.error(f"--grippers: {error}")
    for task in tasks:
        try:
            check_physical_task(TaskModel(spec=get_task_spec(task)))
        except (ValueError, OSError) as error:
            parser.error(f"--tasks: {error}")
    if not (args.fidelity_trials or args.episodes):
        parser.error("--fidelity-trials and --episodes are both 0: nothing to measure")
    log = None if args.quiet else print
    randomization, dynamics = ("on", RANDOMIZED) if args.randomize else (None, NOMINAL)
    if args.append:  # a table that cannot be merged into is refused before anything runs
        try:
            read_table(Path(args.out) / TABLE_CSV)
        except TableFileError as error:
            parser.error(f"--append: {error}")

    def fidelity_dir(robot: str, gripper: str, task: str) -> Path:
        cell = f"{robot}_{task}" if gripper == DEFAULT_GRIPPER else f"{robot}_{gripper}_{task}"
        return Path(args.fidelity_dir) / (cell + (fidelity.RANDOMIZED_SUFFIX if args.randomize else ""))

    if args.fidelity_trials and not args.fresh:  # stored trials of other options: refused before anything runs
        for (robot, gripper) in grippers:
            for task in tasks:
                trials_csv = fidelity_dir(robot, gripper, task) / fidelity.TRIALS_CSV
                configuration = fidelity.run_configuration(
                    TaskModel(spec=get_task_spec(task)), {"env_kwargs": env_kwargs(robot, gripper, args.randomize)})
                try:
                    fidelity.check_configuration(trials_csv, configuration, log)
                except fidelity.ResumeError as error:
                    parser.error(f"{error} (robot_table: --fresh, or another --fidelity-dir)")
    rows = []
    started = time.perf_counter()
    for (robot, gripper), name in grippers.items():
        for task in tasks:
            fid = eps = None
            if args.fidelity_trials:
                try:
                    fid = run_fidelity(robot, task, args.fidelity_trials, args.seed, fidelity_dir(robot, gripper, task),
                                       log=log, randomize=args.randomize, fresh=args.fresh, gripper=gripper)
                except fidelity.ResumeError as error:  # e.g. trials of another --seed
                    parser.error(f"{error} (robot_table: --fresh, or another --fidelity-dir)")
            if args.episodes:
                eps = run_episodes(robot, task, args.episodes, args.seed, log=log, randomization=randomization,
                                   gripper=gripper)
            rows.append(table_row(robot, task, fid, eps, dynamics, name))
            table = Path(args.out) / TABLE_CSV
            write_table(table, merge_rows(table, rows) if args.append else rows)
            if log:
                log(f"{robot} ({name}) x {task} done ({time.perf_counter() - started:.0f} s)")
    table = Path(args.out) / TABLE_CSV
    print(markdown(merge_rows(table, []) if args.append else rows))
    print(f"\n{Path(args.out) / TABLE_CSV} ({time.perf_counter() - started:.0f} s)")
    return 0


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("robots", "python -m tableclean_suite.bench.robot_table"))
