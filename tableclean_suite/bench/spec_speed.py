"""``python -m benchmarks.spec_speed``: does the compiled learner keep its speed on large task specs?

    python -m benchmarks.spec_speed                 # ~1 minute: per-update rates and the cold start
    python -m benchmarks.spec_speed --no-cold-start # only the per-update rates

Two measurements, printed as one summary block:

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
    Wall time of the README's ``python -m benchmarks.run --no-progress --out DIR`` (defaults,
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

import argparse
import math
import os
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from tableclean_suite.bench import cli
from tableclean_suite.bench.cli import OneLineParser, positive_int

PROG = "python -m benchmarks.spec_speed"
EXIT_USAGE = cli.EXIT_USAGE
#: The learner's per-update rate on the largest spec should stay within this factor of the paper spec's.
TARGET_SLOWDOWN = 2.0
DEFAULT_RUNS = 64
DEFAULT_ITERATIONS = 50_000
DEFAULT_REPEATS = 9
LEARNER, REWARD = "q_learning", "r4"
#: The harness command timed for the cold start (``--out`` is appended).
COLD_START_COMMAND = ("-m", "benchmarks.run", "--no-progress")  # the README's command (figures included)
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
    environment = {**os.environ, "NUMBA_DEBUG_CACHE": "1", "NUMBA_CACHE_DIR": str(cache_dir)}
    started = time.perf_counter()
    finished = subprocess.run([sys.executable, *COLD_START_COMMAND, "--out", str(out)], cwd=cwd, env=environment,
                              capture_output=True, text=True)
    seconds = time.perf_counter() - started
    compiled, loaded = count_cache_events(finished.stdout + finished.stderr)
    resumed = _RESUMED.search(finished.stdout)
    return ColdStart(seconds, compiled, loaded, finished.returncode, label,
                     int(resumed.group(1)) if resumed else None)


def time_cold_starts(processes=None) -> list[ColdStart]:
    """The processes of :data:`COLD_START_PROCESSES` (or the given ``(label, out name)`` pairs), one
    after the other, sharing a new, empty numba cache and, where they name the same output
    directory, its result caches."""
    processes = COLD_START_PROCESSES if processes is None else processes
    checkout = Path(__file__).resolve().parents[2]
    with tempfile.TemporaryDirectory(prefix="spec_speed_") as folder:
        cache = Path(folder) / "numba_cache"
        return [time_cold_start(Path(folder) / out, checkout, cache, label) for label, out in processes]


def rate_ratio(largest: Rate, paper: Rate) -> float:
    """Largest spec's updates per second over the paper spec's (1.0: as fast; 0.5: twice as slow)."""
    return largest.per_second / paper.per_second


def within_target(ratio: float, slowdown: float = TARGET_SLOWDOWN) -> bool:
    """Whether a rate ``ratio`` (largest / paper) is within a factor ``slowdown`` of the paper's rate."""
    return ratio >= 1.0 / slowdown


def summary_lines(paper: Rate, largest: Rate, cold: list[ColdStart]) -> list[str]:
    """The printed summary block."""
    ratio = rate_ratio(largest, paper)
    verdict = "yes" if within_target(ratio) else "NO"
    lines = [
        f"Spec speed ({LEARNER}, {REWARD}; {paper.updates:,} updates per train() call, fastest of the repeats):",
        f"  paper        {paper.codes:>7} codes: {paper.per_second:>14,.0f} updates/s ({paper.seconds:.3f} s)",
        f"  {largest.spec:<12} {largest.codes:>7} codes: {largest.per_second:>14,.0f} updates/s "
        f"({largest.seconds:.3f} s)",
        f"  ratio largest/paper: {ratio:.2f} (within {TARGET_SLOWDOWN:g}x of the paper's rate: {verdict})",
    ]
    if cold:
        command = "python " + " ".join(COLD_START_COMMAND) + " --out DIR"
        lines.append(f"  cold start of `{command}`, fresh processes sharing one numba cache, in this order:")
    for number, process in enumerate(cold, 1):
        status = "" if process.returncode == 0 else f", EXIT CODE {process.returncode}"
        resumed = "" if process.resumed is None else f", cells resumed {process.resumed}"
        label = process.label or f"process {number}"
        lines.append(f"    #{number} {label}: {process.seconds:.2f} s (numba kernels compiled {process.compiled}, "
                     f"loaded from disk cache {process.loaded}{resumed}{status})")
    warm = [p for p in cold if p.label == WARM_PROCESS]
    if warm:
        verdict = "yes" if warm[0].seconds <= TARGET_SECOND_PROCESS and warm[0].returncode == 0 else "NO"
        lines.append(f"  second process with warm caches within {TARGET_SECOND_PROCESS:g} s: {verdict}")
    return lines


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line."""
    parser = OneLineParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=positive_int, default=DEFAULT_RUNS,
                        help=f"runs per timed call (default: {DEFAULT_RUNS})")
    parser.add_argument("--iterations", type=positive_int, default=DEFAULT_ITERATIONS,
                        help=f"iterations per run (default: {DEFAULT_ITERATIONS})")
    parser.add_argument("--repeats", type=positive_int, default=DEFAULT_REPEATS,
                        help=f"timed calls per spec, the fastest kept (default: {DEFAULT_REPEATS})")
    parser.add_argument("--no-cold-start", dest="cold_start", action="store_false",
                        help="skip the three fresh-process timings of benchmarks.run")
    return parser


def main(argv=None, prog: str = PROG) -> int:
    """Measure and print the summary block; returns 0 (1 if a cold-start process failed)."""
    from tableclean_suite.task import get_task_spec

    args = build_parser(prog).parse_args(argv)
    paper, largest = measure_rates([get_task_spec("paper"), largest_study_spec()], args.runs, args.iterations,
                                   args.repeats)
    cold = time_cold_starts() if args.cold_start else []
    print("\n".join(summary_lines(paper, largest, cold)))
    return 0 if all(process.returncode == 0 for process in cold) else 1


if __name__ == "__main__":
    sys.exit(main(prog="python -m tableclean_suite.bench.spec_speed"))
