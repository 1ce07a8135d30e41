"""The executor interface, its errors and the checks every executor shares.

A task function that raises [`RetryableError`][tableclean_suite.executors.base.RetryableError], or
whose worker dies, is run again up to ``max_retries`` more times, then
[`TaskFailedError`][tableclean_suite.executors.base.TaskFailedError] names the task; any other
exception fails the task at once (chained as ``__cause__``).
"""

from __future__ import annotations

import numbers
from typing import Any, Callable, Iterable, Iterator, Protocol, runtime_checkable

#: Retries of a failed task unless the caller says otherwise (so up to 3 attempts in all).
DEFAULT_MAX_RETRIES = 2
#: Longest task description in an error message (characters); longer ones are cut.
MAX_TASK_NAME_CHARS = 200


class RetryableError(RuntimeError):
    """Raised by a task function for a transient failure: the executor runs the task again."""


class TaskFailedError(RuntimeError):
    """A task failed for good; the message names it, its attempts and the last error.

    Attributes:
        task: the task that failed (as given to ``map``).
        attempts: how many times it was run, >= 1.
        reason: the last error, ``"TypeName: message"``.
    """

    def __init__(self, task, attempts: int, error: BaseException | str):
        self.task = task
        self.attempts = attempts
        self.reason = error if isinstance(error, str) else f"{type(error).__name__}: {error}"
        times = "attempt" if attempts == 1 else "attempts"
        super().__init__(f"task {task_name(task)} failed after {attempts} {times}: {self.reason}")

    def __reduce__(self):
        return TaskFailedError, (self.task, self.attempts, self.reason)


def task_name(task) -> str:
    """How errors name a task: its ``label`` attribute if it has one, else its ``repr`` (cut to
    `MAX_TASK_NAME_CHARS`)."""
    label = getattr(task, "label", None)
    text = str(label) if isinstance(label, str) else repr(task)
    return text if len(text) <= MAX_TASK_NAME_CHARS else text[:MAX_TASK_NAME_CHARS - 3] + "..."


def check_function(function: Callable) -> None:
    """``function`` must be callable and importable by name (not a lambda or a nested function).

    Raises:
        TypeError: naming the function and what to do instead.
    """
    if not callable(function):
        raise TypeError(f"the task function must be callable, got {function!r}")
    qualname = getattr(function, "__qualname__", "")
    if "<lambda>" in qualname or "<locals>" in qualname:
        raise TypeError(f"the task function {qualname!r} must be defined at module level, so that other "
                        "processes can import it by name")


def check_count(name: str, value, minimum: int, allow_none: bool = False) -> None:
    """An integer option (``workers``, ``max_retries``) must be an int >= ``minimum`` (or None if allowed).

    Raises:
        ValueError: naming the option, the allowed range and the value.
    """
    if value is None and allow_none:
        return
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")


@runtime_checkable
class Executor(Protocol):
    """Runs module-level functions over picklable tasks; a context manager that starts and stops
    its workers (``with executor: ...``).  ``map`` also works outside ``with``: it then starts
    the workers itself and stops them when its iterator is exhausted or closed."""

    #: Extra runs of a task after a retryable failure or a worker crash, >= 0.
    max_retries: int

    def map(self, function: Callable[[Any], Any], tasks: Iterable) -> Iterator:
        """``function(task)`` for each task, yielded in task order.

        Raises:
            TaskFailedError: a task failed for good (named in the message).
        """
        ...

    def __enter__(self) -> "Executor":
        ...

    def __exit__(self, *exc_info) -> None:
        ...
