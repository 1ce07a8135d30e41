"""Small tasks that exercise an executor (results, retries, crashes) without any simulator:
``executor.map(run_probe, [ProbeTask(i) for i in range(8)])``."""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from tableclean_suite.executors.base import RetryableError

#: Normal draws summed by one probe, and the exit status of a worker a ``crash_*`` probe kills.
PROBE_DRAWS, CRASH_EXIT_CODE = 1000, 17
#: What a probe does: return its number; fail retryably once / always; raise a plain error;
#: kill its worker once / always.
PROBE_MODES = ("ok", "retry_once", "retry_always", "error", "crash_once", "crash_always")


@dataclass(frozen=True)
class ProbeTask:
    """One probe: its ``index`` and ``seed`` (>= 0) determine the result; ``mode`` is one of
    `PROBE_MODES`; ``marker`` is the file the ``*_once`` modes create on their failing first attempt."""

    index: int
    seed: int = 0
    mode: str = "ok"
    marker: str | None = None

    @property
    def label(self) -> str:
        """How errors name the task, e.g. ``probe-3:retry_once``."""
        return f"probe-{self.index}:{self.mode}"


def run_probe(task: ProbeTask) -> float:
    """The sum of `PROBE_DRAWS` standard normal draws seeded by ``(seed, index)``, after
    failing as ``task.mode`` says."""
    if task.mode not in PROBE_MODES:
        raise ValueError(f"unknown probe mode {task.mode!r}; allowed: {', '.join(PROBE_MODES)}")
    first_attempt = task.mode.endswith("_once") and _claim(task.marker)
    if task.mode == "retry_always" or (task.mode == "retry_once" and first_attempt):
        raise RetryableError(f"{task.label} failed on purpose")
    if task.mode == "error":
        raise ValueError(f"{task.label} failed on purpose")
    if task.mode == "crash_always" or (task.mode == "crash_once" and first_attempt):
        os._exit(CRASH_EXIT_CODE)
    return float(np.random.default_rng([task.seed, task.index]).standard_normal(PROBE_DRAWS).sum())


def _claim(marker: str | None) -> bool:
    """Create ``marker``; True if this call created it (the first attempt), False if it existed."""
    if marker is None:
        raise ValueError("the *_once probe modes need a marker file path")
    try:
        os.close(os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except FileExistsError:
        return False
    return True
