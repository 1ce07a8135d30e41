"""One interface to run independent tasks: in this process, in local processes, or on Ray.

    from tableclean_suite.executors import make_executor

    with make_executor("local", workers=2) as executor:       # or "ray", address="HOST:PORT"
        for result in executor.map(train_one, tasks):          # results in task order
            ...

``map(function, tasks)`` ([`Executor`][tableclean_suite.executors.base.Executor]) runs a
module-level ``function`` on each picklable task and yields the results in task order, the same on
any executor with any number of workers; failures are retried as
[`tableclean_suite.executors.base`][tableclean_suite.executors.base] says.  Executors:
[`LocalExecutor`][tableclean_suite.executors.local.LocalExecutor] (``"local"``) and
[`RayExecutor`][tableclean_suite.executors.ray_executor.RayExecutor] (``"ray"``, the ``cluster`` extra).
"""

from __future__ import annotations

from tableclean_suite.executors.base import (DEFAULT_MAX_RETRIES, Executor, RetryableError, TaskFailedError,
                                             task_name)
from tableclean_suite.executors.local import LocalExecutor
from tableclean_suite.executors.ray_executor import ClusterUnreachableError, MissingRayError, RayExecutor

#: Executor names accepted by [`make_executor`][tableclean_suite.executors.make_executor] (and ``--executor``).
EXECUTOR_NAMES = ("local", "ray")

__all__ = ["ClusterUnreachableError", "DEFAULT_MAX_RETRIES", "EXECUTOR_NAMES", "Executor", "LocalExecutor",
           "MissingRayError", "RayExecutor", "RetryableError", "TaskFailedError", "make_executor", "task_name"]


def make_executor(name: str = "local", workers: int | None = None, address: str | None = None,
                  max_retries: int = DEFAULT_MAX_RETRIES) -> Executor:
    """The executor called ``name`` (one of `EXECUTOR_NAMES`).

    Args:
        name: ``"local"`` or ``"ray"``.
        workers: local: processes (>= 1; None: one per core; 1: in this process); ray: most
            tasks in flight (None: as many as the cluster runs).
        address: ray only: None (a private Ray on loopback), ``"HOST:PORT"`` or ``"auto"``.
        max_retries: extra runs of a failed task, >= 0.

    Raises:
        ValueError: an unknown name, an address for the local executor, or a bad count.
    """
    if name == "local":
        if address is not None:
            raise ValueError("an address is only used by the ray executor")
        return LocalExecutor(workers=workers, max_retries=max_retries)
    if name == "ray":
        return RayExecutor(address=address, workers=workers, max_retries=max_retries)
    raise ValueError(f"unknown executor {name!r}; allowed: {', '.join(EXECUTOR_NAMES)}")
