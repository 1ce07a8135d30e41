"""Tasks in spawned local processes (``concurrent.futures``), or in this process when ``workers == 1``.

A script using more than one worker needs the ``if __name__ == "__main__":`` guard (workers import
it).  A worker crash charges each task then running one attempt and restarts the pool; workers
exit within a second of their parent's death ([`watch_parent`][tableclean_suite.executors.local.watch_parent]).
"""

from __future__ import annotations

import heapq
import multiprocessing
import os
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Callable, Iterable, Iterator

from tableclean_suite.executors.base import (DEFAULT_MAX_RETRIES, RetryableError, TaskFailedError, check_count,
                                             check_function)

#: Start method of the worker processes: a fresh interpreter (no fork of a threaded parent).
START_METHOD = "spawn"
#: Seconds between a worker's checks that its parent is still alive ([`watch_parent`][tableclean_suite.executors.local.watch_parent]).
PARENT_CHECK_SECONDS = 1.0
#: Exit status of a worker whose parent died.
ORPHAN_EXIT_STATUS = 1


def watch_parent(parent_pid: int, interval: float = PARENT_CHECK_SECONDS) -> None:
    """Worker initializer: a daemon thread ends this worker within ``interval`` seconds of its
    parent's death (the worker is re-parented), so a killed run leaves no worker behind; the worker
    ignores Ctrl-C, which the parent handles by stopping its workers."""
    import signal
    import threading
    import time

    signal.signal(signal.SIGINT, signal.SIG_IGN)

    def watch():
        while os.getppid() == parent_pid:
            time.sleep(interval)
        os._exit(ORPHAN_EXIT_STATUS)

    threading.Thread(target=watch, name="tableclean-parent-watch", daemon=True).start()


def main_guard_hint() -> str:
    """``""``, or why spawned workers die: the main script has no ``if __name__ == "__main__":`` guard,
    so each worker re-runs it on import and tries to start workers of its own."""
    import re
    import sys

    path = getattr(sys.modules.get("__main__"), "__file__", None)
    if not path or not str(path).endswith(".py"):
        return ""
    try:
        source = open(path, encoding="utf-8").read()
    except (OSError, UnicodeDecodeError):
        return ""
    if re.search(r"""if\s+__name__\s*==\s*['"]__main__['"]""", source):
        return ""
    return (f" (likely cause: {path} has no `if __name__ == \"__main__\":` guard; spawned workers import the "
            "script and re-run its top level: put the code that trains under that guard)")


class LocalExecutor:
    """Runs tasks in ``workers`` spawned processes of this machine (in this process if 1).

    Args:
        workers: processes, >= 1; None: one per core (``os.cpu_count()``).
        max_retries: extra runs of a task after [`RetryableError`][tableclean_suite.executors.base.RetryableError] or a worker crash, >= 0.
    """

    def __init__(self, workers: int | None = 1, max_retries: int = DEFAULT_MAX_RETRIES):
        check_count("workers", workers, 1, allow_none=True)
        check_count("max_retries", max_retries, 0)
        self.workers = workers if workers is not None else (os.cpu_count() or 1)
        self.max_retries = max_retries
        self._pool: ProcessPoolExecutor | None = None

    def __repr__(self) -> str:
        return f"LocalExecutor(workers={self.workers}, max_retries={self.max_retries})"

    def start(self) -> None:
        """Start the worker processes (nothing to start in-process); idempotent."""
        if self.workers > 1 and self._pool is None:
            self._pool = ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context(START_METHOD),
                                             initializer=watch_parent, initargs=(os.getpid(),))

    def close(self, wait: bool = True) -> None:
        """Stop the workers; queued tasks are cancelled, running ones are waited for (``wait``) or
        their workers terminated (``wait=False``, e.g. after Ctrl-C)."""
        if self._pool is not None:
            pool, self._pool = self._pool, None
            if not wait:
                for process in list((getattr(pool, "_processes", None) or {}).values()):
                    process.terminate()
            pool.shutdown(wait=wait, cancel_futures=True)

    def __enter__(self) -> "LocalExecutor":
        self.start()
        return self

    def __exit__(self, exc_type, *exc_info) -> None:
        self.close(wait=not (exc_type is not None and issubclass(exc_type, KeyboardInterrupt)))

    def map(self, function: Callable, tasks: Iterable) -> Iterator:
        """``function(task)`` for each task, in task order (see [`Executor`][tableclean_suite.executors.base.Executor])."""
        check_function(function)
        tasks = list(tasks)
        if self.workers == 1:
            return (self._run_here(function, task) for task in tasks)
        return self._run_pool(function, tasks)

    def _run_here(self, function: Callable, task):
        for attempt in range(1, self.max_retries + 2):
            try:
                return function(task)
            except RetryableError as error:
                if attempt > self.max_retries:
                    raise TaskFailedError(task, attempt, error) from error
            except Exception as error:
                raise TaskFailedError(task, attempt, error) from error

    def _run_pool(self, function: Callable, tasks: list) -> Iterator:
        owned = self._pool is None
        self.start()
        waiting = list(range(len(tasks)))  # a heap of task indices not yet submitted, lowest first
        running, finished, attempts = {}, {}, [0] * len(tasks)
        interrupted = False
        try:
            for index in range(len(tasks)):
                while index not in finished:
                    while waiting and len(running) < self.workers:
                        queued = heapq.heappop(waiting)
                        attempts[queued] += 1
                        running[self._pool.submit(function, tasks[queued])] = queued
                    done, _ = wait(running, return_when=FIRST_COMPLETED)
                    broken, failure = self._collect(done, running, finished, waiting, tasks, attempts)
                    if broken:  # every task of the dead pool fails: collect them all, then restart
                        more = self._collect(wait(running).done, running, finished, waiting, tasks, attempts)[1]
                        failure = min(filter(None, (failure, more)), key=lambda f: f[0], default=None)
                        self.close()  # a worker died: a new pool
                        self.start()
                    if failure is not None:
                        raise failure[1]
                yield finished.pop(index)
        except KeyboardInterrupt:
            interrupted = True
            raise
        finally:
            for future in running:
                future.cancel()
            if owned:
                self.close(wait=not interrupted)

    def _collect(self, done, running: dict, finished: dict, waiting: list, tasks: list,
                 attempts: list) -> tuple[bool, tuple[int, TaskFailedError] | None]:
        """Move the ``done`` futures out of ``running``: results to ``finished``, retryable failures
        back to ``waiting``.  Returns whether the pool broke (a worker died) and ``(index, error)`` of
        the lowest-indexed task that failed for good, if any (a crash charges every task of the
        pool; the one named is the first submitted, whatever order the futures end in)."""
        broken, failure = False, None
        for future in sorted(done, key=running.get):
            index = running.pop(future)
            error = future.exception()
            if error is None:
                finished[index] = future.result()
                continue
            crashed = isinstance(error, BrokenProcessPool)
            broken |= crashed
            if not (crashed or isinstance(error, RetryableError)) or attempts[index] > self.max_retries:
                if failure is None:
                    reason = f"a worker process died while running it{main_guard_hint()}" if crashed else error
                    failure = (index, TaskFailedError(tasks[index], attempts[index], reason))
                    failure[1].__cause__ = error
            else:
                heapq.heappush(waiting, index)
        return broken, failure

