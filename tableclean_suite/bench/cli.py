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
