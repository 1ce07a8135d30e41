"""Tasks as Ray tasks: on a private Ray bound to loopback, or on a running Ray cluster.

Ray is imported when the executor starts ([`MissingRayError`][tableclean_suite.executors.ray_executor.MissingRayError]
names the ``cluster`` extra).  Retries are Ray's own (a worker or node failure, or
[`RetryableError`][tableclean_suite.executors.base.RetryableError]).  Every machine of a cluster
needs the same version of this package and of any plugin module the tasks use.
"""

from __future__ import annotations

import logging
import os
from typing import Callable, Iterable, Iterator

from tableclean_suite.executors.base import (DEFAULT_MAX_RETRIES, RetryableError, TaskFailedError, check_count,
                                             check_function)

#: Address a private Ray binds to: this machine only.
LOOPBACK = "127.0.0.1"
#: CPUs Ray reserves for each task (a task is single-threaded).
CPUS_PER_TASK = 1
#: Set to 0 for a Ray this executor starts: no usage statistics sent.
USAGE_STATS_VARIABLE = "RAY_USAGE_STATS_ENABLED"
#: Seconds to wait for a cluster's head to accept a connection (Ray itself retries without end).
DEFAULT_CONNECT_TIMEOUT = 30.0
#: Scheme prefix of Ray Client addresses (``ray://HOST:PORT``).
CLIENT_SCHEME = "ray://"


class MissingRayError(ImportError):
    """Ray is not installed; the message says how to install it."""


class ClusterUnreachableError(ConnectionError):
    """The Ray cluster's address does not accept connections; the message names it and the wait."""


def host_and_port(address: str) -> tuple[str, int] | None:
    """``("10.0.0.5", 6379)`` of ``"10.0.0.5:6379"`` or ``"ray://10.0.0.5:10001"``; None for ``"auto"``
    or anything that is not HOST:PORT."""
    text = address[len(CLIENT_SCHEME):] if address.startswith(CLIENT_SCHEME) else address
    host, _, port = text.rpartition(":")
    if not host or not port.isdigit():
        return None
    return host.strip("[]"), int(port)


def check_reachable(address: str, timeout: float = DEFAULT_CONNECT_TIMEOUT) -> None:
    """Raise [`ClusterUnreachableError`][tableclean_suite.executors.ray_executor.ClusterUnreachableError] unless ``address`` (HOST:PORT) accepts a TCP connection
    within ``timeout`` seconds; addresses that are not HOST:PORT (``"auto"``) are left to Ray."""
    import socket

    target = host_and_port(address)
    if target is None:
        return
    try:
        with socket.create_connection(target, timeout=timeout):
            pass
    except OSError as error:
        reason = "timed out" if isinstance(error, TimeoutError) else (error.strerror or str(error))
        raise ClusterUnreachableError(
            f"cannot reach the Ray cluster at {address!r} within {timeout:g} s ({reason}); start its head with "
            "`ray start --head` or pass the address it printed") from None


def import_ray():
    """The ``ray`` module, or [`MissingRayError`][tableclean_suite.executors.ray_executor.MissingRayError] naming the ``cluster`` extra."""
    try:
        import ray
    except ImportError as error:
        raise MissingRayError(
            f"the ray executor needs Ray ({error}); install it with "
            "pip install \"tableclean_suite[cluster]\" (or pip install ray)") from None
    return ray


class RayExecutor:
    """Runs tasks as Ray tasks.

    Args:
        address: None starts a private Ray on this machine, bound to loopback
            (`LOOPBACK`), stopped by [`close`][tableclean_suite.executors.ray_executor.RayExecutor.close]; ``"HOST:PORT"`` (a head started with
            ``ray start --head``) or ``"auto"`` (the cluster this machine belongs to) connects
            to a running cluster and only disconnects on [`close`][tableclean_suite.executors.ray_executor.RayExecutor.close].
        workers: most tasks in flight at once, >= 1; None: all (Ray queues them and runs as
            many as the cluster has CPUs, `CPUS_PER_TASK` each).
        max_retries: extra runs of a task after [`RetryableError`][tableclean_suite.executors.base.RetryableError] or a worker crash, >= 0.
        num_cpus: CPUs of a private Ray (``address=None``), >= 1; None: every core.
        connect_timeout: seconds to wait for ``address`` to accept a connection before
            [`ClusterUnreachableError`][tableclean_suite.executors.ray_executor.ClusterUnreachableError] (which names the address), > 0.
    """

    def __init__(self, address: str | None = None, workers: int | None = None,
                 max_retries: int = DEFAULT_MAX_RETRIES, num_cpus: int | None = None,
                 connect_timeout: float = DEFAULT_CONNECT_TIMEOUT):
        if address is not None and (not isinstance(address, str) or not address.strip()):
            raise ValueError(f"address must be HOST:PORT, 'auto' or None, got {address!r}")
        check_count("workers", workers, 1, allow_none=True)
        check_count("max_retries", max_retries, 0)
        check_count("num_cpus", num_cpus, 1, allow_none=True)
        self.address = address.strip() if address else None
        self.workers = workers
        self.max_retries = max_retries
        self.num_cpus = num_cpus
        if isinstance(connect_timeout, bool) or not isinstance(connect_timeout, (int, float)) \
                or not 0 < connect_timeout < float("inf"):
            raise ValueError(f"connect_timeout must be a number of seconds > 0, got {connect_timeout!r}")
        self.connect_timeout = float(connect_timeout)
        self._ray = None
        self._in_context = False

    def __repr__(self) -> str:
        return (f"RayExecutor(address={self.address!r}, workers={self.workers}, "
                f"max_retries={self.max_retries})")

    def start(self) -> None:
        """Start or join Ray (idempotent; a Ray already initialised in this process is used as is)."""
        if self._ray is not None:
            return
        ray = import_ray()
        if not ray.is_initialized():
            if self.address is None:
                os.environ.setdefault(USAGE_STATS_VARIABLE, "0")
                ray.init(num_cpus=self.num_cpus, include_dashboard=False, _node_ip_address=LOOPBACK)
            else:
                check_reachable(self.address, self.connect_timeout)
                try:
                    ray.init(address=self.address, logging_level=logging.WARNING)  # no INFO lines
                except (ConnectionError, TimeoutError, RuntimeError) as error:  # something listens, not a Ray head
                    reason = (str(error).strip().splitlines() or [type(error).__name__])[0]
                    raise ClusterUnreachableError(f"cannot join the Ray cluster at {self.address!r}: {reason}") from None
            self._owned = True
        else:
            self._owned = False
        self._ray = ray

    def close(self) -> None:
        """Stop the private Ray, or disconnect from the cluster (a Ray initialised by the caller is kept)."""
        if self._ray is not None and self._owned:
            self._ray.shutdown()
        self._ray = None

    def __enter__(self) -> "RayExecutor":
        """Ray starts (or is joined) on the first ``map``, so a run with nothing to do costs nothing."""
        self._in_context = True
        return self

    def __exit__(self, *exc_info) -> None:
        self._in_context = False
        self.close()

    def map(self, function: Callable, tasks: Iterable) -> Iterator:
        """``function(task)`` for each task, in task order (see [`Executor`][tableclean_suite.executors.base.Executor])."""
        check_function(function)
        return self._run(function, list(tasks))

    def _run(self, function: Callable, tasks: list) -> Iterator:
        owned = self._ray is None and not self._in_context
        self.start()
        ray = self._ray
        remote = ray.remote(num_cpus=CPUS_PER_TASK, max_retries=self.max_retries,
                            retry_exceptions=[RetryableError])(function)
        limit = self.workers or len(tasks)
        refs, submitted = {}, 0
        try:
            for index in range(len(tasks)):
                while submitted < len(tasks) and submitted - index < limit:
                    refs[submitted] = remote.remote(tasks[submitted])
                    submitted += 1
                try:
                    result = ray.get(refs.pop(index))
                except ray.exceptions.RayError as error:
                    raise TaskFailedError(tasks[index], _attempts(error, self.max_retries),
                                          _reason(error)) from error
                yield result
        finally:
            for ref in refs.values():
                ray.cancel(ref)
            if owned:
                self.close()


def _attempts(error, max_retries: int) -> int:
    """Runs behind a failure Ray reports: all of them if it retries that kind, else one."""
    cause = getattr(error, "cause", None)
    retried = isinstance(cause, RetryableError) or not isinstance(cause, Exception)
    return max_retries + 1 if retried else 1


def _reason(error) -> str:
    """The task's own exception if Ray wraps one, else Ray's error (e.g. the worker died)."""
    cause = getattr(error, "cause", None)
    if isinstance(cause, Exception):
        return f"{type(cause).__name__}: {cause}"
    return f"{type(error).__name__}: {str(error).splitlines()[0] if str(error) else ''}"
