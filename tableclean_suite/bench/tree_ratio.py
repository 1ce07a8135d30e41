"""The run command in this tree against an older tree, as ratios measured in one go (``--old-tree``).

A speed goal in seconds depends on when it is measured: on the shared 2-core machines the same
default run took 6.99 s of CPU in one report and 5.70 s half an hour later.  A ratio to the tree
the goal was set against, timed in alternating pairs, cancels that drift.  Issue 16 asked for the
default run "in a third of the time" of the tree it timed, and for a first process (empty numba
cache) of at most 12 s where that tree took 32.7 s: :data:`DEFAULT_RUN_RATIO_GOAL` and
:data:`FIRST_PROCESS_RATIO_GOAL`.

Each measurement is a whole fresh process of ``python -m benchmarks.run --fresh --no-progress
--out NEW`` (the README's command, in the tree's own directory, its own package first on
``PYTHONPATH``), started alternately in this tree and in the other one, ``pairs`` times:

- ``default run``: after one untimed run in each tree (so both trees' kernels are in their numba
  caches), whole processes with warm kernel caches and no result cache;
- ``first process``: each run with a new, empty numba cache (``NUMBA_CACHE_DIR``), as a newcomer's
  first run.

A pair's ratio is this tree's seconds over the other's; the report gives every pair's ratio and
their median, checked against the goal.  Get the older tree with, e.g.,
``git worktree add /tmp/old f690eb5`` (the tree issue 16 timed).
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

#: Goal (issue 16): the default run's whole process in at most this fraction of the older tree's.
DEFAULT_RUN_RATIO_GOAL = 1.0 / 3.0
#: The first process's time on the tree issue 16 timed (s), and its goal (s; also the speed report's
#: goal in seconds): the ratio goal.
ISSUE_FIRST_PROCESS_S = 32.7
FIRST_PROCESS_GOAL_S = 12.0
FIRST_PROCESS_RATIO_GOAL = FIRST_PROCESS_GOAL_S / ISSUE_FIRST_PROCESS_S
#: Pairs of processes per measurement unless the caller gives a number.
DEFAULT_PAIRS = 3
#: The command each tree runs (with ``--out`` a new directory), from the tree's own directory.
RUN_COMMAND = ("-m", "benchmarks.run", "--fresh", "--no-progress")
#: The file a tree must have to be timed (the command's module).
RUN_MODULE = Path("benchmarks") / "run.py"


class TreeRunError(RuntimeError):
    """The run command exited non-zero in a tree (its output's last lines are in the message)."""


@dataclass(frozen=True)
class PairedTimes:
    """Wall seconds of the same command in this tree and the other one, pair by pair.

    Attributes:
        label: what was timed, e.g. ``"default run"``.
        ours: this tree's wall seconds, one per pair, in order (> 0).
        theirs: the other tree's, same length.
    """

    label: str
    ours: tuple[float, ...]
    theirs: tuple[float, ...]

    @property
    def ratios(self) -> tuple[float, ...]:
        """This tree's seconds over the other's, pair by pair."""
        return tuple(a / b for a, b in zip(self.ours, self.theirs))

    @property
    def ratio(self) -> float:
        """The median of :attr:`ratios`."""
        return statistics.median(self.ratios)

    def line(self) -> str:
        """One report line: medians of both trees and every pair's ratio."""
        return (f"  {self.label}: this tree {statistics.median(self.ours):.2f} s, the other "
                f"{statistics.median(self.theirs):.2f} s (medians of {len(self.ours)}); ratio by pair "
                f"{', '.join(f'{r:.3f}' for r in self.ratios)}; median {self.ratio:.3f}")


def this_tree() -> Path:
    """The source tree this package is imported from (the directory holding ``tableclean_suite``)."""
    import tableclean_suite

    return Path(tableclean_suite.__file__).resolve().parent.parent


def child_environment(first: Path | None = None, **variables: str) -> dict[str, str]:
    """This process's environment for a child started in another directory: ``PYTHONPATH``'s entries
    made absolute (a relative one, e.g. ``PYTHONPATH=.``, would name the child's directory and let it
    import another copy of the code), ``first`` (a directory) before them, and ``variables`` set."""
    entries = [str(first)] if first is not None else []
    entries += [os.path.abspath(entry) for entry in os.environ.get("PYTHONPATH", "").split(os.pathsep) if entry]
    environment = {**os.environ, **variables}
    if entries:
        environment["PYTHONPATH"] = os.pathsep.join(entries)
    return environment


def timed_python(arguments: list[str], cwd: Path, environment: dict[str, str]
                 ) -> tuple[float, subprocess.CompletedProcess]:
    """``python ARGUMENTS`` (this interpreter) as a fresh process in ``cwd`` with ``environment``, its
    output captured as text: ``(wall seconds, the finished process)``."""
    started = time.perf_counter()
    done = subprocess.run([sys.executable, *arguments], cwd=cwd, env=environment, capture_output=True, text=True)
    return time.perf_counter() - started, done


def tree_problem(path) -> str | None:
    """Why ``path`` cannot be timed (a sentence naming it), or None when it has :data:`RUN_MODULE`."""
    path = Path(path)
    if not path.is_dir():
        return f"{str(path)!r} is not a directory; give a checkout of an older tree (e.g. git worktree add DIR REV)"
    if not (path / RUN_MODULE).is_file():
        return f"{str(path)!r} has no {RUN_MODULE}: not a checkout of this repository"
    return None


def time_run(tree: Path, out: Path, cache_dir: Path | None = None) -> float:
    """Wall seconds of :data:`RUN_COMMAND` as a fresh process in ``tree`` writing to ``out``;
    ``cache_dir``: its numba cache (None: the tree's own).

    Raises:
        TreeRunError: the command exited non-zero.
    """
    environment = child_environment(first=tree, **({} if cache_dir is None else {"NUMBA_CACHE_DIR": str(cache_dir)}))
    seconds, done = timed_python([*RUN_COMMAND, "--out", str(out)], tree, environment)
    if done.returncode != 0:
        tail = "\n".join((done.stdout + done.stderr).strip().splitlines()[-5:])
        raise TreeRunError(f"`python {' '.join(RUN_COMMAND)}` exited {done.returncode} in {tree}:\n{tail}")
    return seconds


def paired_times(label: str, ours: Path, theirs: Path, pairs: int = DEFAULT_PAIRS, cold: bool = False,
                 timer=time_run) -> PairedTimes:
    """Time the run command alternately in ``ours`` and ``theirs``, ``pairs`` (>= 1) times each,
    every run in a new output directory; ``cold``: every run with a new, empty numba cache, else one
    untimed run in each tree first.  ``timer``: ``(tree, out, cache_dir) -> seconds``."""
    if pairs < 1:
        raise ValueError(f"pairs must be >= 1, got {pairs}")
    trees = (ours, theirs)
    times: tuple[list[float], list[float]] = ([], [])
    with tempfile.TemporaryDirectory(prefix="tree_ratio_") as folder:
        folder = Path(folder)
        if not cold:
            for side, tree in enumerate(trees):
                timer(tree, folder / f"warm{side}", None)
        for pair in range(pairs):
            for side, tree in enumerate(trees):
                name = f"pair{pair}_{side}"
                times[side].append(timer(tree, folder / name, folder / f"{name}_numba" if cold else None))
    return PairedTimes(label, tuple(times[0]), tuple(times[1]))
