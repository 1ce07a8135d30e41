"""The options every benchmark command shares and the parser they all use: every bad value exits 2
with one line naming the flag, the value and what is allowed, before any work."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

# EXIT_INTERRUPTED: Ctrl-C's exit status, also part of this module's interface
from tableclean_suite.bench.startup import EXIT_INTERRUPTED, announce_compiles  # noqa: F401

#: Exit code of a command line used wrongly (argparse's).
EXIT_USAGE = 2
#: Output kinds of [`output_path`][tableclean_suite.bench.cli.output_path]: a folder, or one file.
DIRECTORY, FILE = "directory", "file"
DEFAULT_ROBOT = "Panda"


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a bad flag prints one line (``prog: error: ...``, no usage block) and exits 2,
    a list flag (``nargs="+"`` or a comma-list type) given twice is refused rather than silently
    keeping the last, and help texts show ````x```` as ```x```."""

    def parse_known_args(self, args=None, namespace=None):
        seen = set()
        for text in sys.argv[1:] if args is None else args:
            action = self._option_string_actions.get(str(text).split("=", 1)[0])
            if action is not None and (action.nargs in ("+", "*") or getattr(action.type, "comma_list", False)):
                if action.dest in seen:
                    self.error(f"{text.split('=', 1)[0]} given twice; list every value in one flag "
                               f"(comma separated{' or space separated' if action.nargs else ''})")
                seen.add(action.dest)
        return super().parse_known_args(args, namespace)

    def format_help(self) -> str:
        return super().format_help().replace("``", "`")

    def error(self, message: str):
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def number_type(kind, allowed, what: str):
    """A type: a ``kind`` (``int`` or ``float``) for which ``allowed(value)`` holds, else an error naming ``what``."""
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            value = math.nan
        if value != value or not allowed(value):
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        return value
    return parse


positive_int = number_type(int, lambda v: v >= 1, "a positive integer")
"""A type: an integer >= 1."""
non_negative_int = number_type(int, lambda v: v >= 0, "an integer >= 0")
"""A type: an integer >= 0."""
positive_float = number_type(float, lambda v: 0 < v < math.inf, "a positive number")
"""A type: a finite number > 0."""


def int_in(low: int, high: int, what: str = "an integer"):
    """A type: an integer in ``[low, high]``."""
    return number_type(int, lambda v: low <= v <= high, f"{what} in [{low}, {high}]")


def _names(text) -> tuple[str, ...]:
    return tuple(dict.fromkeys(part.strip() for part in str(text).split(",") if part.strip()))


def choice_list(allowed, what: str):
    """A type: comma-separated names, each one of ``allowed`` (``what`` names them in the error), each once."""
    def parse(text: str) -> tuple[str, ...]:
        chosen = _names(text)
        bad = [name for name in chosen if name not in allowed]
        if bad or not chosen:
            raise argparse.ArgumentTypeError(f"unknown {what} {', '.join(bad) or text!r}; "
                                             f"allowed: {', '.join(allowed)} (comma separated)")
        return chosen
    parse.comma_list = True
    return parse


def name_list(text: str) -> tuple[str, ...]:
    """``"a, b,a,"`` -> ``("a", "b")``: comma-separated names, in order, each once (at least one)."""
    names = _names(text)
    if not names:
        raise argparse.ArgumentTypeError(f"expected at least one comma-separated name, got {text!r}")
    return names


name_list.comma_list = True  # a list flag: given twice, OneLineParser refuses it


def number_list(text: str) -> tuple[float, ...]:
    """``"0.1, 0.3"`` -> ``(0.1, 0.3)``: comma-separated numbers, in order (at least one)."""
    try:
        numbers = tuple(map(float, _names(text)))
    except ValueError:
        numbers = ()
    if not numbers:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}")
    return numbers


def plugin_entries(text: str | None) -> tuple[str, ...]:
    """The ``--plugins`` value: comma-separated module names or ``.py`` paths (made absolute), each once."""
    from tableclean_suite.bench.plugins import portable

    return portable(_names(text or ""))


plugin_entries.comma_list = True


def output_path(kind: str, suffixes: tuple[str, ...] = ()):
    """A type: an output path of ``kind`` (`DIRECTORY` or `FILE`) ending in one of ``suffixes`` (any when
    empty); refused when empty, when it or a parent is an existing file (a directory output), or when it is
    an existing directory (a file output)."""
    def parse(text: str) -> str:
        if not str(text).strip():
            raise argparse.ArgumentTypeError(f"expected a {kind} path, got {text!r} (empty)")
        if suffixes and Path(text).suffix.lower() not in suffixes:
            raise argparse.ArgumentTypeError(f"must end in {' or '.join(suffixes)}, got {text!r}")
        from tableclean_suite.bench.outputs import file_in_the_way

        path = Path(text)
        try:
            if kind == FILE and path.is_dir():
                raise argparse.ArgumentTypeError(f"{text!r} is a directory; give a file name")
            problem = file_in_the_way(path, itself=kind == DIRECTORY)
            if problem:
                raise argparse.ArgumentTypeError(problem)
        except OSError as error:  # a name too long, a parent folder that cannot be searched
            raise argparse.ArgumentTypeError(f"{text!r} cannot be used: {error.strerror or error}") from None
        return str(text)
    return parse


def _shared_options(prog: str | None = None) -> OneLineParser:
    """A parser of the options every command has: ``--plugins`` and ``--verbose``."""
    from tableclean_suite.bench.plugins import FLAG

    parser = OneLineParser(prog=prog, add_help=False)
    parser.add_argument(FLAG, type=plugin_entries, default=(), metavar="MODULE|FILE.py,...",
                        help="modules (names or .py paths, comma separated) imported first, to register actions, "
                             "learners, rewards, specs, objects or skills by name; executor workers import them too")
    parser.add_argument("--verbose", action="store_true",
                        help="show robosuite's start-up warnings and informational messages (hidden by default)")
    return parser


def command_parser(prog: str, description: str, epilog: str | None = None) -> OneLineParser:
    """A command's parser: one-line errors, and the options every command has (``--plugins``, ``--verbose``)."""
    return OneLineParser(prog=prog, description=description, epilog=epilog, parents=[_shared_options()],
                         formatter_class=argparse.RawDescriptionHelpFormatter)


def add_task_argument(parser, default="paper", **options) -> None:
    """``--task NAME|FILE.json``: a registered task spec or a JSON spec file (checked by the command)."""
    from tableclean_suite.task import task_spec_names

    help_text = options.pop("help", None) or (
        f"task spec: a registered name ({', '.join(task_spec_names())}) or a .json path (default {default})")
    parser.add_argument("--task", default=default, metavar="NAME|FILE.json", help=help_text, **options)


def add_seed_argument(parser, what: str, default=0, **options) -> None:
    """``--seed S``: an integer >= 0 seeding ``what``."""
    shown = "" if default is argparse.SUPPRESS else f" (default {default})"
    parser.add_argument("--seed", type=non_negative_int, default=default, metavar="S",
                        help=f"seed of {what}, an integer >= 0{shown}", **options)


def add_runs_argument(parser, default: int, what: str, **options) -> None:
    """``--runs R``: independent training runs (an integer >= 1), ``what`` they are for."""
    parser.add_argument("--runs", type=positive_int, default=default, metavar="R",
                        help=f"{what}, an integer >= 1 (default {default})", **options)


def add_iterations_argument(parser, default: int, what: str, **options) -> None:
    """``--iterations I``: training iterations per run (an integer >= 1), ``what`` they are for."""
    parser.add_argument("--iterations", type=positive_int, default=default, metavar="I",
                        help=f"{what}, an integer >= 1 (default {default})", **options)


def add_out_argument(parser, kind: str, default, what: str, flags=("--out",), suffixes=(), **options) -> None:
    """``--out PATH``: where the command writes, an
    [`output_path`][tableclean_suite.bench.cli.output_path] of ``kind`` ending in one of ``suffixes``."""
    shown = "" if default is argparse.SUPPRESS else f" (default {default})"
    metavar = "DIR" if kind == DIRECTORY else "FILE"
    parser.add_argument(*flags, dest="out", type=output_path(kind, suffixes), default=default, metavar=metavar,
                        help=f"{what}{shown}", **options)


def check_out(parser: argparse.ArgumentParser, out, command: str, folders=()) -> None:
    """Exit 2 naming ``--out`` when ``command`` could not publish into ``out`` (its sub-``folders`` included;
    [`check_publishable`][tableclean_suite.bench.outputs.check_publishable]); call it before any work."""
    from tableclean_suite.bench.outputs import check_publishable

    problem = check_publishable(out, folders, command)
    if problem:
        parser.error(f"--out {problem}")


def add_robots_argument(parser, many: bool = False, default: str = DEFAULT_ROBOT) -> None:
    """``--robots NAME[,NAME...]``: the arm(s) of the scene, checked by
    [`parse_robots`][tableclean_suite.bench.cli.parse_robots]."""
    what = "comma-separated robot arms" if many else "robot arm"
    parser.add_argument("--robots", type=name_list, default=default, metavar="NAME" + (",..." if many else ""),
                        help=f"{what} with a registered skill config: Panda, Sawyer, UR5e, Kinova3 ship "
                             f"(tableclean_suite.controllers.robot_configs; default {default})")


def parse_robots(parser: argparse.ArgumentParser, args) -> tuple[str, ...]:
    """The checked ``--robots`` names; exits 2 naming the supported robots when one has no skill config."""
    from tableclean_suite.controllers.robot_configs import check_robot

    try:
        return tuple(check_robot(name) for name in args.robots)
    except ValueError as error:
        parser.error(f"--robots: {error}")


def parse_robot(parser: argparse.ArgumentParser, args) -> str:
    """The one checked ``--robots`` name of a single-arm command; exits 2 otherwise."""
    robots = parse_robots(parser, args)
    if len(robots) != 1:
        parser.error(f"--robots: this command builds one scene; give one robot, got {','.join(robots)!r}")
    return robots[0]


def add_executor_arguments(parser, tasks: str, helps: dict | None = None, suppress: bool = False) -> None:
    """``--workers``, ``--executor``, ``--ray-address``: where the command's independent ``tasks`` (e.g.
    ``"rounds"``) run; read back by [`executor_from_args`][tableclean_suite.bench.cli.executor_from_args].
    ``helps`` replaces help texts by dest; ``suppress`` leaves an option not given out of the namespace."""
    from tableclean_suite.executors import EXECUTOR_NAMES

    helps, hidden = helps or {}, argparse.SUPPRESS if suppress else None
    parser.add_argument("--workers", type=positive_int, default=hidden or 1,
                        help=helps.get("workers", f"{tasks} run in parallel: processes of this machine, or most Ray "
                                                  "tasks in flight (default 1: this process)"))
    parser.add_argument("--executor", choices=EXECUTOR_NAMES, default=hidden or "local",
                        help=helps.get("executor", f"where {tasks} run: local processes, or Ray (the cluster extra) "
                                                   "(default local)"))
    parser.add_argument("--ray-address", default=hidden, metavar="HOST:PORT|auto",
                        help=helps.get("ray_address", "Ray cluster to join (default: a private Ray on 127.0.0.1); "
                                                      "only with --executor ray"))


def executor_from_args(parser: argparse.ArgumentParser, args):
    """The (not started) executor of the executor options, its workers importing ``--plugins`` first; exits 2
    on ``--ray-address`` without ``--executor ray`` or ``--executor ray`` without Ray installed."""
    from tableclean_suite.bench.plugins import with_plugins
    from tableclean_suite.executors import MissingRayError, make_executor
    from tableclean_suite.executors.ray_executor import import_ray

    if args.ray_address is not None and args.executor != "ray":
        parser.error("--ray-address is only used with --executor ray")
    if args.executor == "ray":
        try:
            import_ray()
        except MissingRayError as error:
            parser.error(f"--executor ray: {error}")
    try:
        executor = make_executor(args.executor, workers=args.workers, address=args.ray_address)
    except ValueError as error:
        parser.error(f"--executor {args.executor}: {error}")
    return with_plugins(executor, getattr(args, "plugins", ()))


def wrap(text: str) -> str:
    """``text`` with each line longer than ``tables.PRINT_WIDTH`` wrapped at words, continuations indented."""
    import textwrap

    from tableclean_suite.bench.tables import PRINT_WIDTH

    return "\n".join(textwrap.fill(line, PRINT_WIDTH, subsequent_indent="    ", break_on_hyphens=False)
                     if len(line) > PRINT_WIDTH else line
                     for line in text.split("\n"))


def say(text: str) -> None:
    """Print ``text`` on stdout [`wrap`][tableclean_suite.bench.cli.wrap]ped to the terminal width."""
    print(wrap(text), flush=True)


def markdown_table(rows, columns=None) -> str:
    """A Markdown table, values as ``str`` shows them: ``rows`` are dicts with the same keys (or a DataFrame)
    whose keys are the header, or, given ``columns`` (headers, repeats allowed), sequences of cells (none: the
    header alone)."""
    if columns is None:
        rows = rows.to_dict("records") if hasattr(rows, "to_dict") else list(rows)
        columns = list(rows[0])
        rows = [[row[column] for column in columns] for row in rows]
    return "\n".join(["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns),
                      *("| " + " | ".join(map(str, row)) + " |" for row in rows)])


def parse_command(build_parser, argv, prog: str, known: bool = False):
    """Apply ``--verbose``, import the ``--plugins`` (exit 2 naming one that fails), then parse ``argv`` with
    ``build_parser(prog)``: ``(parser, args)``, with ``known`` ``(parser, args, unknown arguments)``."""
    from tableclean_suite.bench.plugins import FLAG, PluginError, load_plugins
    from tableclean_suite.robosuite_adapter import apply_verbosity

    argv = list(sys.argv[1:] if argv is None else argv)
    early = _shared_options(prog)
    first = early.parse_known_args(argv)[0]
    apply_verbosity(first.verbose)  # before a plugin imports robosuite
    announce_compiles(prog)
    try:
        load_plugins(first.plugins)
    except PluginError as error:
        early.error(f"{FLAG}: {error}")
    parser = build_parser(prog)
    if known:
        args, rest = parser.parse_known_args(argv)
        return parser, args, rest
    return parser, parser.parse_args(argv)
