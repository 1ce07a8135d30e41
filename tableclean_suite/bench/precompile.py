"""A first process compiles the cells' statistics kernels in a forked process, beside the training loop.

With an empty numba cache, ``tableclean-bench run`` first compiles the training loop
(:data:`tableclean_suite.learners.kernel.train_batch`, the paper's learners' copy: ~5 s of CPU on
one core), then, once the first cell is trained, the kernels of its statistics (the asymptotes'
episode DP, the grouped curves, the bootstrap's sums and draws, the probabilities of improvement:
~5-6 s), on the same core while the other one waits.  :func:`start` forks a process that
summarises a tiny cell of each learner of the grid (its runs trained by the plain-Python reference
engine, so without the training loop) through the same code as the run
(:func:`.experiments.train_cell`, :func:`.statistics.comparison_rows`): that compiles those
kernels, with the run's argument types, into numba's disk cache while this process compiles the
training loop; this process then loads them from the cache instead of compiling them.  The forked
process writes nothing but the cache, and any failure there only means this process compiles them
itself; numbers never depend on it (a kernel gives the same bits compiled here or there).

The forked process does not also compile the loop's separately compiled callees for this process
to load from the cache: measured, its work already takes longer (~6-7 s of CPU with the tiny
cells' training) than this process's compile of the loop, so callees compiled there first only
delayed the statistics kernels, which this process then compiled itself (no gain in time).

Nothing is forked when the kernels are already in the cache (:func:`statistics_kernels_cached`),
on a backend that does not train with the compiled loop, or where processes cannot be forked.
"""

from __future__ import annotations

import os
import signal
import sys
from dataclasses import replace

#: Runs and iterations of the tiny cells the forked process summarises: enough runs for the
#: bootstrap's groups (:data:`.statistics.MIN_GROUPS`), so every kernel of a real cell is reached
#: with a real cell's argument types (a test checks it against a longer cell).  The runs are trained
#: by the plain-Python reference engine, ~16 us per step: for the paper grid's five learners 20
#: iterations cost ~0.06 s of CPU, 200 cost ~0.6 s (on the first process's critical path).
PRECOMPILE_RUNS = 40
PRECOMPILE_ITERATIONS = 20
#: Bootstrap replicates of the tiny cells (one batch of :data:`.statistics.REPLICATE_BATCH`).
PRECOMPILE_SAMPLES = 100
#: Exit code of the forked process when compiling failed (it is not an error of the run).
FAILED = 1


def statistics_kernels():
    """The compiled (numba, disk-cached) kernels a cell's statistics and comparisons use."""
    from tableclean_suite import asymptotes, curves, metrics
    from tableclean_suite.bench import statistics

    return (asymptotes._episode_statistics, asymptotes._retire, asymptotes._reached_pairs, curves._grouped_curves,
            metrics._batch_curves, statistics._uniform_multinomial, statistics._weighted_row_range,
            statistics._improvement_replicates, statistics._band_columns, statistics._resampled_rows)


def _in_cache(dispatcher) -> bool:
    """Whether numba's disk cache holds a current entry of ``dispatcher`` (True when it cannot tell)."""
    try:
        return bool(dispatcher._cache._cache_file._load_index())
    except Exception:  # noqa: BLE001  (numba's cache internals changed: assume cached, fork nothing)
        return True


def statistics_kernels_cached() -> bool:
    """Whether numba's disk cache holds every kernel of :func:`statistics_kernels` (for these sources)."""
    return all(_in_cache(kernel) for kernel in statistics_kernels())


class Precompiling:
    """The forked process compiling the statistics kernels; :meth:`finish` reaps it.

    Args:
        pid: its process id.
    """

    def __init__(self, pid: int):
        self.pid = pid
        self.returncode: int | None = None

    def finish(self) -> int:
        """Stop the process if it still runs (its cache entries are written whole or not at all)
        and reap it; returns its exit status (0: compiled everything)."""
        if self.returncode is None:
            finished, status = os.waitpid(self.pid, os.WNOHANG)
            if finished == 0:
                os.kill(self.pid, signal.SIGTERM)
                finished, status = os.waitpid(self.pid, 0)
            self.returncode = os.waitstatus_to_exitcode(status)
        return self.returncode


def start(cells, config, model, transitions=None) -> Precompiling | None:
    """Fork the process that compiles the statistics kernels of ``cells`` (see the module doc), or
    None when there is nothing to gain: no cells, a backend other than a table's, a platform that
    cannot fork, or the kernels already cached.  Call before any thread is started (a fork copies
    only the calling thread)."""
    from tableclean_suite.backends import get_backend
    from tableclean_suite.backends.tabular import TableBackend

    cells = list(cells)
    if (not cells or not isinstance(get_backend(config.backend), TableBackend) or not hasattr(os, "fork")
            or not sys.platform.startswith("linux") or statistics_kernels_cached()):
        return None
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid != 0:
        return Precompiling(pid)
    signal.signal(signal.SIGINT, signal.SIG_DFL)  # a Ctrl-C ends it here, never as a run's KeyboardInterrupt
    status = FAILED
    try:  # the forked process: compile, write nothing but numba's cache, never return into the run
        quiet = os.open(os.devnull, os.O_WRONLY)
        os.dup2(quiet, 1)
        os.dup2(quiet, 2)
        compile_statistics(cells, config, model, transitions)
        status = 0
    finally:
        os._exit(status)


def compile_statistics(cells, config, model, transitions=None) -> None:
    """Summarise a tiny cell of each learner of ``cells`` (:data:`PRECOMPILE_RUNS` runs x
    :data:`PRECOMPILE_ITERATIONS` iterations, trained by the reference engine) and compare two of
    them: every statistics kernel is compiled (or loaded) with the argument types of the run."""
    from tableclean_suite.bench import experiments, statistics

    tiny = replace(config, runs=PRECOMPILE_RUNS, iterations=PRECOMPILE_ITERATIONS,
                   bootstrap_samples=PRECOMPILE_SAMPLES, progress=False)
    first_of_learner: dict = {}
    for cell in cells:
        first_of_learner.setdefault(cell.learner, cell)
    runs = None
    for cell in first_of_learner.values():
        chunks = experiments.cell_chunks(cell, tiny, model, transitions, engine="reference")
        _, cell_stats, _, _ = experiments.train_cell(cell, tiny, model, transitions, chunks=chunks)
        runs = cell_stats.runs
    statistics.comparison_rows([{"learner": "x", "reward": "a", "runs": runs},
                                {"learner": "x", "reward": "b", "runs": runs}],
                               tiny.confidence, tiny.bootstrap_samples, tiny.seed)
