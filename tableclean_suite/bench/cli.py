"""Argument types shared by the benchmark command lines (argparse turns their errors into exit code 2)."""

from __future__ import annotations

import argparse

from tableclean_suite.task import Action, as_action


def positive_int(text: str) -> int:
    """An integer >= 1."""
    return _bounded_int(text, 1, "a positive integer")


def non_negative_int(text: str) -> int:
    """An integer >= 0."""
    return _bounded_int(text, 0, "an integer >= 0")


def _bounded_int(text: str, minimum: int, what: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
    if value < minimum:
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
    return value


def add_executor_arguments(parser: argparse.ArgumentParser, tasks: str) -> None:
    """``--workers``, ``--executor``, ``--ray-address``: where the command's independent ``tasks``
    (e.g. ``"rounds"``, ``"episodes"``) run (:mod:`tableclean_suite.executors`); read them back
    with :func:`executor_from_args`."""
    from tableclean_suite.executors import EXECUTOR_NAMES

    parser.add_argument("--workers", type=positive_int, default=1,
                        help=f"{tasks} run in parallel: processes of this machine, or most Ray tasks in flight "
                             "(default 1: this process)")
    parser.add_argument("--executor", choices=EXECUTOR_NAMES, default="local",
                        help=f"where {tasks} run: local processes, or Ray (the cluster extra) (default local)")
    parser.add_argument("--ray-address", default=None, metavar="HOST:PORT|auto",
                        help="Ray cluster to join (default: a private Ray on 127.0.0.1); only with --executor ray")


def executor_from_args(parser: argparse.ArgumentParser, args):
    """The executor of :func:`add_executor_arguments`' options (not started yet).

    Exits 2 (``parser.error``) on ``--ray-address`` without ``--executor ray``, or on
    ``--executor ray`` where Ray is not installed (the message names the ``cluster`` extra).
    """
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
        return make_executor(args.executor, workers=args.workers, address=args.ray_address)
    except ValueError as error:
        parser.error(f"--executor {args.executor}: {error}")


def action_list(text: str) -> tuple[Action, ...]:
    """``"move,pick"`` -> ``(Action.MOVE, Action.PICK)``, in the given order, without repeats."""
    chosen = []
    for name in (part.strip() for part in text.split(",")):
        if not name:
            continue
        try:
            action = as_action(name)
        except ValueError as error:
            raise argparse.ArgumentTypeError(str(error)) from None
        if action not in chosen:
            chosen.append(action)
    if not chosen:
        raise argparse.ArgumentTypeError("expected at least one action")
    return tuple(chosen)


#: Exit code of a command line used wrongly (argparse's).
EXIT_USAGE = 2


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a bad flag prints one line (``prog: error: ...``, no usage block) and exits 2."""

    def error(self, message: str):
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")
