"""Does the compiled learner keep its speed on large task specs, and how fast is a cold start?

The ``specs`` and ``cold-start`` sections of ``tableclean-bench speed`` (:mod:`.speed`;
``python -m benchmarks.spec_speed`` is their alias):

    tableclean-bench speed --sections specs,cold-start   # ~1 minute
    tableclean-bench speed --sections specs              # only the per-update rates

Per-update rate
    ``train()`` of the compiled Q-learning (r4) with the same runs and iterations on the
    paper's spec (24 codes) and on the scaling study's largest spec (N = 5 segments, M = 3
    objects: 34 560 codes), measured in one process after a warm-up call per spec (each record
    dtype compiles or loads its own kernel).  Each spec is timed ``--repeats`` times, the
    specs' calls interleaved (the cores are shared, so load changes hit both alike), and the
    fastest is kept; the rate is updates (runs x iterations) per second of wall time of the
    whole ``train()`` call (allocating the ``(R, S, A)`` Q-tables and records included).  The
    goal is a largest/paper rate ratio of at least ``1 / TARGET_SLOWDOWN``.

Cold start
    Wall time of the README's run command, ``--no-progress --out DIR`` (defaults,
    figures included) in three fresh processes sharing one numba cache directory
    (``NUMBA_CACHE_DIR``), new and empty at the start:

    1. *first process*: empty numba cache and empty result caches (a new ``DIR``): it compiles
       the kernels, trains every cell, bootstraps, draws;
    2. *second process, warm caches*: the same ``DIR`` again, so the cells, the comparisons and
       the figures come from its result caches (``DIR/cells``) and the kernels from numba's
       (the README's second run; goal: at most :data:`TARGET_SECOND_PROCESS` s);
    3. *second process, result caches off*: a new ``DIR`` (numba's cache only), so it
       retrains, bootstraps and draws everything, as ``--fresh`` would.

    Each process runs with ``NUMBA_DEBUG_CACHE=1``; the summary counts the kernels it compiled
    and saved to numba's disk cache ("data saved") and those it loaded ("data loaded"), and
    the cells it resumed from ``DIR/cells``: only the first process should compile anything.
"""

from __future__ import annotations

import math
import re
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

#: The learner's per-update rate on the largest spec should stay within this factor of the paper spec's.
TARGET_SLOWDOWN = 2.0
DEFAULT_RUNS = 64
DEFAULT_ITERATIONS = 50_000
DEFAULT_REPEATS = 9
LEARNER, REWARD = "q_learning", "r4"
#: The harness command timed for the cold start (``--out`` is appended): the README's run command (figures
#: included), through the module entry point so that it runs from an installed package too.
COLD_START_COMMAND = ("-m", "tableclean_suite.bench", "run", "--no-progress")
#: The cold-start processes, in order: (label, output directory name; the same name = the same result caches).
COLD_START_PROCESSES = (
    ("first process (empty numba and result caches)", "run1"),
    ("second process (warm numba and result caches)", "run1"),
    ("second process, result caches off (numba cache only)", "run2"),
)
#: The process of :data:`COLD_START_PROCESSES` the 3 s goal is checked on (warm numba and result caches).
WARM_PROCESS = COLD_START_PROCESSES[1][0]
#: Goal for the README's command from the second process on (warm caches), wall seconds on 2 cores.
TARGET_SECOND_PROCESS = 3.0
#: Lines numba prints with ``NUMBA_DEBUG_CACHE=1`` when it saves / loads a compiled kernel.
_CACHE_SAVED = re.compile(r"\[cache\] data saved")
_CACHE_LOADED = re.compile(r"\[cache\] data loaded")
#: The harness's line saying how many cells it resumed from its cell cache.
_RESUMED = re.compile(r"resumed (\d+) cells")


@dataclass(frozen=True)
class Rate:
    """One spec's measured rate.

    Attributes:
        spec: spec name.
        codes: state codes of the spec.
        updates: learner updates per timed call (runs x iterations).
        seconds: fastest wall time of one ``train()`` call, in seconds (> 0).
    """

    spec: str
    codes: int
    updates: int
    seconds: float

    @property
    def per_second(self) -> float:
        """Updates per second."""
        return self.updates / self.seconds


@dataclass(frozen=True)
class ColdStart:
    """One fresh process of the cold-start command.

    Attributes:
        seconds: wall time of the process, in seconds.
        compiled: kernels compiled and saved to numba's disk cache (>= 0).
        loaded: kernels loaded from numba's disk cache (>= 0).
        returncode: the process's exit code (0 on success).
        label: which process it was (see :data:`COLD_START_PROCESSES`).
        resumed: cells it loaded from its cell cache (None if its output does not say).
    """

    seconds: float
    compiled: int
    loaded: int
    returncode: int
    label: str = ""
    resumed: int | None = None


def largest_study_spec():
    """The scaling study's largest default spec."""
    from tableclean_suite.bench.scaling.family import largest_default_spec

    return largest_default_spec()


def _timed_call(model, runs: int, iterations: int) -> float:
    """Wall time (seconds) of one ``train()`` call on ``model``."""
    from tableclean_suite.learners import train

    started = time.perf_counter()
    train(learner=LEARNER, reward=REWARD, runs=runs, iterations=iterations, task=model)
    return time.perf_counter() - started


def measure_rates(specs, runs: int, iterations: int, repeats: int) -> list[Rate]:
    """The fastest of ``repeats`` timed ``train()`` calls per spec, after one warm-up call each.

    The specs' calls are interleaved (spec 1, spec 2, spec 1, ...) so a change in the machine's
    load (the cores are shared) affects every spec alike.
    """
    from tableclean_suite.task import TaskModel

    models = [TaskModel(spec=spec) for spec in specs]
    for model in models:
        model.transition_arrays()  # build the model's tables outside the timing
        _timed_call(model, runs, iterations)
    best = [math.inf] * len(models)
    for _ in range(repeats):
        for index, model in enumerate(models):
            best[index] = min(best[index], _timed_call(model, runs, iterations))
    return [Rate(spec.name, model.n_states, runs * iterations, seconds)
            for spec, model, seconds in zip(specs, models, best)]


def count_cache_events(log: str) -> tuple[int, int]:
    """``(compiled, loaded)``: numba disk-cache saves and loads in a ``NUMBA_DEBUG_CACHE=1`` log."""
    return len(_CACHE_SAVED.findall(log)), len(_CACHE_LOADED.findall(log))


def time_cold_start(out: Path, cwd: Path, cache_dir: Path, label: str = "") -> ColdStart:
    """Run the cold-start command once in a fresh process writing to ``out``; its wall time and cache use.

    ``cache_dir`` becomes the process's numba cache (``NUMBA_CACHE_DIR``): an empty one makes the
    first process compile, and a second process on the same directory shows whether the cache hits.
    ``out``'s own result caches (``out/cells``) serve whatever an earlier process left there.
    """
    from tableclean_suite.bench.tree_ratio import child_environment, timed_python

    environment = child_environment(NUMBA_DEBUG_CACHE="1", NUMBA_CACHE_DIR=str(cache_dir))
    seconds, finished = timed_python([*COLD_START_COMMAND, "--out", str(out)], cwd, environment)
    compiled, loaded = count_cache_events(finished.stdout + finished.stderr)
    resumed = _RESUMED.search(finished.stdout)
    return ColdStart(seconds, compiled, loaded, finished.returncode, label,
                     int(resumed.group(1)) if resumed else None)


def time_cold_starts(processes=None) -> list[ColdStart]:
    """The processes of :data:`COLD_START_PROCESSES` (or the given ``(label, out name)`` pairs), one
    after the other, sharing a new, empty numba cache and, where they name the same output
    directory, its result caches."""
    processes = COLD_START_PROCESSES if processes is None else processes
    with tempfile.TemporaryDirectory(prefix="spec_speed_") as folder:
        cache = Path(folder) / "numba_cache"
        return [time_cold_start(Path(folder) / out, Path(folder), cache, label) for label, out in processes]


def rate_ratio(largest: Rate, paper: Rate) -> float:
    """Largest spec's updates per second over the paper spec's (1.0: as fast; 0.5: twice as slow)."""
    return largest.per_second / paper.per_second


def within_target(ratio: float, slowdown: float = TARGET_SLOWDOWN) -> bool:
    """Whether a rate ``ratio`` (largest / paper) is within a factor ``slowdown`` of the paper's rate."""
    return ratio >= 1.0 / slowdown


def summary_lines(paper: Rate, largest: Rate, cold: list[ColdStart]) -> list[str]:
    """The printed summary block: the rates, then (if any) the cold-start processes."""
    ratio = rate_ratio(largest, paper)
    verdict = "yes" if within_target(ratio) else "NO"
    lines = [
        f"Spec speed ({LEARNER}, {REWARD}; {paper.updates:,} updates per train() call, fastest of the repeats):",
        f"  paper        {paper.codes:>7} codes: {paper.per_second:>14,.0f} updates/s ({paper.seconds:.3f} s)",
        f"  {largest.spec:<12} {largest.codes:>7} codes: {largest.per_second:>14,.0f} updates/s "
        f"({largest.seconds:.3f} s)",
        f"  ratio largest/paper: {ratio:.2f} (within {TARGET_SLOWDOWN:g}x of the paper's rate: {verdict})",
    ]
    return lines + cold_start_lines(cold)


def cold_start_lines(cold: list[ColdStart]) -> list[str]:
    """The cold-start block: one line per process, and the goal on the warm one (nothing if ``cold`` is empty)."""
    if not cold:
        return []
    command = "python " + " ".join(COLD_START_COMMAND) + " --out DIR"
    lines = [f"  cold start of `{command}`, fresh processes sharing one numba cache, in this order:"]
    for number, process in enumerate(cold, 1):
        status = "" if process.returncode == 0 else f", EXIT CODE {process.returncode}"
        resumed = "" if process.resumed is None else f", cells resumed {process.resumed}"
        label = process.label or f"process {number}"
        lines.append(f"    #{number} {label}: {process.seconds:.2f} s (numba kernels compiled {process.compiled}, "
                     f"loaded from disk cache {process.loaded}{resumed}{status})")
    warm = warm_process(cold)
    if warm is not None:
        verdict = "yes" if warm_within_target(warm) else "NO"
        lines.append(f"  second process with warm caches within {TARGET_SECOND_PROCESS:g} s: {verdict}")
    return lines


def warm_process(cold: list[ColdStart]) -> ColdStart | None:
    """The process of ``cold`` with warm numba and result caches (:data:`WARM_PROCESS`), if it ran."""
    return next((process for process in cold if process.label == WARM_PROCESS), None)


def warm_within_target(process: ColdStart) -> bool:
    """Whether the warm process succeeded within :data:`TARGET_SECOND_PROCESS` seconds."""
    return process.seconds <= TARGET_SECOND_PROCESS and process.returncode == 0
