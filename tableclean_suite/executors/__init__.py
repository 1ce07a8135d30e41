"""One interface to run independent tasks: in this process, in local processes, or on Ray.

    from tableclean_suite.executors import make_executor

    with make_executor("local", workers=2) as executor:       # or "ray", address="HOST:PORT"
        for result in executor.map(train_one, tasks):          # results in task order
            ...

The contract ([`Executor`][tableclean_suite.executors.base.Executor]): ``map(function, tasks)`` runs a **module-level**
``function`` on each **picklable task** and yields the results in task order.  Tasks are plain
configurations (a frozen dataclass of numbers, strings and tuples, with the task's own seed);
the function builds its own environment, model or simulator inside the worker, so nothing
unpicklable crosses a process boundary and results are the same on any executor with any
number of workers.  A task whose function raises [`RetryableError`][tableclean_suite.executors.base.RetryableError], or whose worker
dies, is run again up to ``max_retries`` times; then [`TaskFailedError`][tableclean_suite.executors.base.TaskFailedError] names it.

Implementations:

- [`LocalExecutor`][tableclean_suite.executors.local.LocalExecutor] (``"local"``, the default): ``workers`` spawned processes of this
  machine, or this very process when ``workers == 1`` (no pickling, no start-up cost);
- [`RayExecutor`][tableclean_suite.executors.ray_executor.RayExecutor] (``"ray"``): Ray tasks, on a private Ray bound to loopback
  (``address=None``) or on a running cluster (``address="HOST:PORT"`` or ``"auto"``); Ray is
  the optional ``cluster`` extra and is imported only when this executor starts.

How the expensive workloads use it (this package depends on nothing above it: it knows no
simulator and no harness):

- the harness's cells (``python -m benchmarks.run --executor ray``): one task per cell,
  [`tableclean_suite.bench.experiments.train_cell_task`][tableclean_suite.bench.experiments.train_cell_task];
- physics training (``train_physics``): one task per share of runs, e.g.
  ``PhysicsShare(learner, reward, task_spec_name, run_indices, iterations, seed, options)``;
  the function builds its robosuite environment in the worker and returns the share's records;
  counter-based seeds per run keep the records the same whatever the split;
- fidelity and calibration trials: one task per round, ``FidelityRound(round_index, seed,
  task, actions, ...)`` with the round's seed from ``round_seed(seed, round_index)``; the
  function builds its own scene and returns the round's rows, which the caller appends to
  the trials CSV in round order (``map`` yields in task order);
- demo collection (``python -m benchmarks.collect_demos --workers N --executor ray``): one task
  per attempt, ``DemoAttempt(spec, ..., seed, attempt)`` with its start and placement drawn from
  ``(seed, attempt)``; failed attempts are replaced in waves and the demos kept in attempt order.

A physics task whose numbers must match bit for bit runs under
[`single_blas_thread`][tableclean_suite.executors.blas.single_blas_thread]: OpenBLAS's thread count (Ray starts
workers with ``OMP_NUM_THREADS=1``, local processes inherit the caller's) changes the last bits
of a trajectory.

Raise [`RetryableError`][tableclean_suite.executors.base.RetryableError] inside such a function for a failure worth another try (e.g. a
MuJoCo instability); let anything else propagate (it fails the task at once).
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
