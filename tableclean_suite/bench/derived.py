"""The run's figures, drawn in forked processes while the run writes its CSV files.

[start_figures][tableclean_suite.bench.derived.start_figures] forks up to
[FIGURE_PROCESSES][tableclean_suite.bench.derived.FIGURE_PROCESSES] processes (Linux) that draw
the figures [plots.available_figures][tableclean_suite.bench.plots.available_figures] allows
with [plots.render_png][tableclean_suite.bench.plots.render_png]; they inherit the inputs and
run the same code on the same matplotlib configuration, so the PNG bytes are those drawn in this
process.  Elsewhere the figures are drawn here, when their result is asked for.
"""

from __future__ import annotations

import gc
import sys
from dataclasses import dataclass

from tableclean_suite.bench import plots


@dataclass(frozen=True)
class Figure:
    """One figure of a run: its file name and PNG bytes."""

    name: str
    png: bytes


#: Most processes that draw a run's figures at once (one per core of the paper's 2-core machine).
FIGURE_PROCESSES = 2
#: What the forked drawing processes read (set just before they are forked, so they inherit it
#: instead of receiving a pickled copy of the curves): ``(curves, plateau_fraction, table3, dpi)``.
_DRAWING_INPUTS: tuple | None = None


def _draw(stem: str) -> bytes:
    """:func:`.plots.render_png` of ``stem`` from the inherited :data:`_DRAWING_INPUTS`."""
    curves, plateau_fraction, table3, dpi = _DRAWING_INPUTS
    return plots.render_png(stem, curves, plateau_fraction, table3, dpi)


class PendingFigures:
    """Figures being drawn (:func:`start_figures`); :meth:`result` waits for them and returns every
    :class:`Figure` in the order of :func:`.plots.available_figures`."""

    def __init__(self, stems: list, drawing, pool):
        self._stems, self._drawing, self._pool = stems, drawing, pool

    def result(self) -> list[Figure]:
        global _DRAWING_INPUTS
        try:
            drawn = dict(self._drawing()) if self._drawing is not None else {}
        finally:
            if self._pool is not None:
                self._pool.close()
                self._pool.join()
            _DRAWING_INPUTS = None
        return [Figure(f"{stem}.png", drawn[stem]) for stem in self._stems]


def figures(curves, plateau_fraction: float, table3=None, dpi: int = 120, processes: int = 1) -> list[Figure]:
    """The paper's figures that ``curves`` allows: :func:`start_figures`, finished."""
    return start_figures(curves, plateau_fraction, table3, dpi, processes).result()


def start_figures(curves, plateau_fraction: float, table3=None, dpi: int = 120, processes: int = 1) -> PendingFigures:
    """Start drawing the figures; the caller works on meanwhile.

    With ``processes`` > 1 on a platform that forks (Linux), up to that many forked processes
    (at most :data:`FIGURE_PROCESSES`) draw them; otherwise they are drawn here, on
    :meth:`PendingFigures.result`.
    """
    global _DRAWING_INPUTS
    import multiprocessing

    stems = plots.available_figures(curves)
    if not stems:
        return PendingFigures([], None, None)
    _DRAWING_INPUTS = (curves, plateau_fraction, table3, dpi)
    forks = "fork" in multiprocessing.get_all_start_methods() and sys.platform.startswith("linux")
    workers = min(int(processes), FIGURE_PROCESSES, len(stems))
    if workers < 2 or not forks:
        return PendingFigures(stems, lambda: [(stem, _draw(stem)) for stem in stems], None)
    plots.code_columns(curves)  # once here, inherited by every drawing process
    gc.freeze()  # the forked processes' collections then leave this process's objects (and pages) alone
    try:
        pool = multiprocessing.get_context("fork").Pool(workers)
    finally:
        gc.unfreeze()
    pending = pool.map_async(_draw, stems, chunksize=1)
    return PendingFigures(stems, lambda: zip(stems, pending.get()), pool)
