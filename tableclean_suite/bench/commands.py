"""``tableclean-bench COMMAND``: one entry point for every benchmark command.

    tableclean-bench                       # the paper's run (as `tableclean-bench run`)
    tableclean-bench fidelity --task three_segments --trials 2
    tableclean-bench COMMAND --help
    python -m tableclean_suite.bench COMMAND ...   # the same, without the console script

Each command's module has ``build_parser(prog)`` and ``main(argv=None, prog=None) -> int``; `COMMANDS`
names them.  Flags without a command (``tableclean-bench --runs 5``) go to ``run``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
from dataclasses import dataclass
from pathlib import Path

from tableclean_suite.bench.cli import EXIT_INTERRUPTED, EXIT_USAGE, OneLineParser
from tableclean_suite.bench.startup import catch_ctrl_c

CONSOLE_SCRIPT = "tableclean-bench"
#: The command a bare ``tableclean-bench`` (or one given only flags) runs.
DEFAULT_COMMAND = "run"
HELP_FLAGS = ("-h", "--help")


@dataclass(frozen=True)
class Command:
    """One command of `COMMANDS`: its ``module``, a one-line ``summary``, and whether it builds MuJoCo scenes
    (``physics``: ``MUJOCO_GL`` defaults to ``egl`` before the import)."""

    module: str
    summary: str
    physics: bool = False


#: Every command, in the order ``--help`` lists them.
COMMANDS: dict[str, Command] = {
    "run": Command("tableclean_suite.bench.run", "reproduce the paper's Tables 3-4 and Figures 3-7 (the default)"),
    "scaling": Command("tableclean_suite.bench.scaling.command",
                       "scaling study: N segments x M objects, learners x rewards, growth exponents"),
    "tune": Command("tableclean_suite.bench.tune", "search a learner's hyperparameters with Optuna"),
    "interventions": Command("tableclean_suite.bench.interventions",
                             "change one factor of a cell: the causal checks behind the findings"),
    "coverage": Command("tableclean_suite.bench.coverage",
                        "how often each published interval holds a many-run reference's value"),
    "window-invariance": Command("tableclean_suite.bench.window_invariance",
                                 "do Table 3's iteration figures move with the training window?"),
    "fidelity": Command("tableclean_suite.bench.fidelity",
                        "does physics do what the task model says, from every reachable state?", physics=True),
    "calibrate": Command("tableclean_suite.bench.calibrate",
                         "a physics-calibrated transition table (for run --backend calibrated)", physics=True),
    "rollout": Command("tableclean_suite.bench.rollout", "video of a learned policy executed by the skills",
                       physics=True),
    "render": Command("tableclean_suite.bench.render_scene", "render the TableClean scene to a PNG", physics=True),
    "demos": Command("tableclean_suite.bench.collect_demos", "collect skill demonstrations (robomimic hdf5)",
                     physics=True),
    "robots": Command("tableclean_suite.bench.robot_table",
                      "fidelity and episode success per robot arm x task spec", physics=True),
    "objects": Command("tableclean_suite.bench.object_table", "the skills on every registered object type",
                       physics=True),
    "speed": Command("tableclean_suite.bench.speed",
                     "measured speed: learners, skills, cold start", physics=True),
    "policy-analysis": Command("tableclean_suite.bench.policy_analysis",
                               "measured plateaus against exact values of the learned policies"),
    "pddl": Command("tableclean_suite.bench.pddl_check",
                    "classical planners' plans for a task spec in PDDL, checked against the model's"),
}


class CommandUnavailable(RuntimeError):
    """A registered command whose module is not part of this installation."""


def _module(name: str):
    """The module of command ``name``;
    [`CommandUnavailable`][tableclean_suite.bench.commands.CommandUnavailable] when it is not installed."""
    command = COMMANDS[name]
    if command.physics:
        os.environ.setdefault("MUJOCO_GL", "egl")
    try:
        return importlib.import_module(command.module)
    except ModuleNotFoundError as error:
        if error.name != command.module:
            raise
        raise CommandUnavailable(f"command {name!r} is not available in this installation "
                                 f"({command.module} is missing)") from None


def invoked_as() -> str:
    """The program name users typed: the console script's name, or ``python -m tableclean_suite.bench``."""
    name = Path(sys.argv[0] if sys.argv else "").name
    return CONSOLE_SCRIPT if name in ("", "-c", "__main__.py", "-m") else name


def command_parser(name: str, prog: str = CONSOLE_SCRIPT) -> argparse.ArgumentParser:
    """The fully built parser of command ``name``, as ``prog name`` (for ``--help`` and the docs)."""
    return _module(name).build_parser(f"{prog} {name}")


def command_parsers(prog: str = CONSOLE_SCRIPT) -> dict[str, argparse.ArgumentParser]:
    """``{command: its parser}`` for every available command (the generated command reference)."""
    parsers = {}
    for name in COMMANDS:
        try:
            parsers[name] = command_parser(name, prog)
        except CommandUnavailable:
            continue
    return parsers


def build_parser(prog: str = CONSOLE_SCRIPT) -> argparse.ArgumentParser:
    """The whole command line: one subcommand per available command, each with its own options."""
    parser = OneLineParser(
        prog=prog, formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Benchmarks of task-level RL for table cleaning. Without a command: run.",
        epilog=f"'{prog} COMMAND --help' lists a command's options.")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=OneLineParser)
    for name, parser_of_command in command_parsers(prog).items():
        commands.add_parser(name, parents=[parser_of_command], add_help=False, help=COMMANDS[name].summary,
                            description=parser_of_command.description,
                            formatter_class=argparse.RawDescriptionHelpFormatter)
    return parser


def _usage_error(prog: str, message: str) -> int:
    print(f"{prog}: error: {message}", file=sys.stderr)
    return EXIT_USAGE


def _exit_code(code) -> int:
    """A ``SystemExit`` code as an exit status (None -> 0, a message -> 1 after printing it)."""
    if code is None:
        return 0
    if isinstance(code, int):
        return code
    print(code, file=sys.stderr)
    return 1


def main(argv=None, prog: str | None = None) -> int:
    """Run ``prog COMMAND ARGS...`` (default ``sys.argv[1:]``); returns the exit code.

    No command, or flags first: ``run``.  ``-h``/``--help`` alone lists the commands.  Ctrl-C at
    any moment, imports included, is one line and exit `EXIT_INTERRUPTED`.
    """
    prog, entry = prog or invoked_as(), argv is None
    try:
        with catch_ctrl_c():
            argv = list(sys.argv[1:] if entry else argv)
            if argv and argv[0] in HELP_FLAGS:
                build_parser(prog).print_help()
                return 0
            if not argv or argv[0].startswith("-"):
                name, rest, command_prog = DEFAULT_COMMAND, argv, prog
            else:
                name, rest, command_prog = argv[0], argv[1:], f"{prog} {argv[0]}"
            if name not in COMMANDS:
                return _usage_error(prog, f"unknown command {name!r}; allowed: {', '.join(COMMANDS)} "
                                          f"(or no command: {DEFAULT_COMMAND})")
            return _run(name, rest, command_prog, unavailable_prog=prog, entry=entry)
    except BaseException as error:  # noqa: BLE001 - Ctrl-C outside _run (parsing, --help); the rest re-raised
        return _interrupted(prog, error, entry)


def run_alias(name: str, prog: str, argv=None) -> int:
    """Run command ``name`` as an old entry point (``python -m benchmarks.X``) called ``prog``."""
    return _run(name, argv, prog, entry=argv is None)


def _run(name: str, argv, prog: str, unavailable_prog: str | None = None, entry: bool = False) -> int:
    """``main(argv, prog=prog)`` of command ``name``'s module as an exit status: the one place where its
    ``SystemExit``, refusals and file-system errors (one line, exit 2) and Ctrl-C (exit 130, imports
    included) become exit codes."""
    try:
        with catch_ctrl_c():
            return _exit_code(_module(name).main(argv, prog=prog))
    except CommandUnavailable as error:
        return _usage_error(unavailable_prog or prog, str(error))
    except SystemExit as stop:
        return _exit_code(stop.code)
    except (KeyboardInterrupt, RuntimeError) as error:
        return _interrupted(prog, error, entry)
    except _refusals() as error:  # the resource guard, an unusable output folder: one line, exit 2
        return _usage_error(prog, str(error))
    except OSError as error:  # a name too long, a folder that cannot be read: the path and the reason
        where = f"{str(error.filename)[:120]!r}: " if error.filename is not None else ""
        return _usage_error(prog, f"{where}{error.strerror or error}")


def _interrupted(prog: str, error: BaseException, entry: bool = False) -> int:
    """One line and `EXIT_INTERRUPTED` when ``error`` is or was caused by Ctrl-C (e.g. a ``RuntimeError`` from
    a class body during an import); re-raises anything else.  At the process's ``entry`` point Ctrl-C is
    ignored from here on (a quiet exit)."""
    cause = error
    while cause is not None and not isinstance(cause, KeyboardInterrupt):
        cause = cause.__cause__ or cause.__context__
    if cause is None:
        raise error
    if entry:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    print(f"{prog}: interrupted", file=sys.stderr)
    return EXIT_INTERRUPTED


def _refusals() -> tuple:
    """Errors a command reports as one line with exit 2: the resource guard's, the output folder's and an
    unreachable Ray cluster."""
    from tableclean_suite.bench.outputs import OutputError
    from tableclean_suite.executors.ray_executor import ClusterUnreachableError
    from tableclean_suite.resources import ResourceError

    return ResourceError, OutputError, ClusterUnreachableError

