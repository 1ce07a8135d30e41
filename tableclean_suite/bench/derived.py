"""What a run derives from its cells (the comparisons table and the figures), cached, and the
figures drawn in forked processes while the run writes its CSV files.

[start][tableclean_suite.bench.derived.start] serves both from ``OUT/cells/derived/`` when an
entry holds them under the key of what determines them, else computes and stores them.  The key
(`derived_key`) digests the inputs as read from the cells (each main cell's learner, reward
and per-run scores; the curves frame and Table 3 that the figures draw, bit for bit), the
comparison settings (confidence, bootstrap samples, seed), the figure settings (dpi, plateau
fraction, matplotlib's and Pillow's versions, every live ``rcParams`` value and the font file they
resolve to), the source of every module of the package and the numpy, scipy and pandas versions.
An entry is one zip file (only the latest is kept), written atomically, whose members' CRC-32 is checked on reading; an
unreadable, partial or mismatched entry is a miss (reported on stderr), recomputed and replaced.
A hit and a miss both decode the stored bytes, so their outputs are the same bytes.

[start_figures][tableclean_suite.bench.derived.start_figures] forks up to
`FIGURE_PROCESSES` processes (Linux) that draw
the figures [plots.available_figures][tableclean_suite.bench.plots.available_figures] allows
with [plots.render_png][tableclean_suite.bench.plots.render_png]; they inherit the inputs and
run the same code on the same matplotlib configuration, so the PNG bytes are those drawn in this
process.  They ignore Ctrl-C (the terminal sends it to them too): the parent stops them
(`PendingFigures.result` terminates the
pool, also when interrupted) and reports the interruption once.  Elsewhere the figures are drawn
here, when their result is asked for.
"""

from __future__ import annotations

import gc
import hashlib
import importlib.metadata
import json
import signal
import sys
import time
import zipfile
from dataclasses import dataclass
from pathlib import Path

from tableclean_suite.bench import digests, plots


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
    """[`plots.render_png`][tableclean_suite.bench.plots.render_png] of ``stem`` from the inherited `_DRAWING_INPUTS`."""
    curves, plateau_fraction, table3, dpi = _DRAWING_INPUTS
    return plots.render_png(stem, curves, plateau_fraction, table3, dpi)


class PendingFigures:
    """Figures being drawn ([`start_figures`][tableclean_suite.bench.derived.start_figures]); `result` waits for them and returns every
    [`Figure`][tableclean_suite.bench.derived.Figure] in the order of [`plots.available_figures`][tableclean_suite.bench.plots.available_figures]."""

    def __init__(self, stems: list, drawing, pool):
        self._stems, self._drawing, self._pool = stems, drawing, pool

    def result(self) -> list[Figure]:
        global _DRAWING_INPUTS
        try:
            drawn = dict(self._drawing()) if self._drawing is not None else {}
        finally:  # every figure is in (or Ctrl-C came): stop the workers, never wait on them
            if self._pool is not None:
                self._pool.terminate()
            _DRAWING_INPUTS = None
        return [Figure(f"{stem}.png", drawn[stem]) for stem in self._stems]


def figures(curves, plateau_fraction: float, table3=None, dpi: int = 120, processes: int = 1) -> list[Figure]:
    """The paper's figures that ``curves`` allows: [`start_figures`][tableclean_suite.bench.derived.start_figures], finished."""
    return start_figures(curves, plateau_fraction, table3, dpi, processes).result()


def start_figures(curves, plateau_fraction: float, table3=None, dpi: int = 120, processes: int = 1) -> PendingFigures:
    """Start drawing the figures; the caller works on meanwhile.

    With ``processes`` > 1 on a platform that forks (Linux), up to that many forked processes
    (at most `FIGURE_PROCESSES`) draw them; otherwise they are drawn here, on
    `PendingFigures.result`.
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
        pool = multiprocessing.get_context("fork").Pool(workers, signal.signal, (signal.SIGINT, signal.SIG_IGN))
    finally:
        gc.unfreeze()
    pending = pool.map_async(_draw, stems, chunksize=1)
    return PendingFigures(stems, lambda: zip(stems, pending.get()), pool)


# -- the cache of derived results ------------------------------------------------------------

#: Bump when an entry's layout or the meaning of what it stores changes.
CACHE_FORMAT = 1


def _frame_digest(digest, frame) -> None:
    """Feed a DataFrame's column names, dtypes, index and values (numbers by their bits) to ``digest``."""
    import numpy as np
    import pandas as pd

    digest.update(repr((list(frame.columns), [str(dtype) for dtype in frame.dtypes])).encode())
    for values in (frame.index.to_numpy(), *(frame[name].to_numpy() for name in frame.columns)):
        if values.dtype.kind in "biufcM":
            digest.update(values.dtype.str.encode() + np.ascontiguousarray(values).tobytes())
        else:  # text and the like: its distinct values in order of appearance, and each row's code
            codes, uniques = pd.factorize(values, use_na_sentinel=False)
            digest.update(repr(list(uniques)).encode("utf-8", "surrogatepass") + codes.tobytes())


def _drawing_config() -> dict:
    """What the figures' pixels depend on beyond their data and dpi: matplotlib's and Pillow's
    versions, a digest of the live ``rcParams`` and of the font file they resolve to."""
    import matplotlib
    from matplotlib import font_manager

    params = repr([(name, repr(matplotlib.rcParams[name])) for name in matplotlib.rcParams
                   if name != "backend"])  # reading "backend" would resolve it, importing pyplot
    font = Path(font_manager.findfont(font_manager.FontProperties(family=matplotlib.rcParams["font.family"])))
    return {"matplotlib": matplotlib.__version__, "pillow": importlib.metadata.version("pillow"),
            "rc_params": hashlib.sha256(params.encode()).hexdigest(), "font": font.name,
            "font_sha256": hashlib.sha256(font.read_bytes()).hexdigest()}


def derived_key(cells: list[dict], confidence: float, samples: int, seed: int, curves=None, table3=None,
                plateau_fraction: float = 0.0, dpi: int = 120) -> dict:
    """The cache key of [start][tableclean_suite.bench.derived.start]'s results for these inputs
    (same arguments): a JSON-able dict; ``curves`` None means no figures."""
    import numpy as np

    digest = hashlib.sha256()
    for cell in cells:
        digest.update(repr((cell["learner"], cell["reward"])).encode())
        for score in sorted(cell["runs"]):
            values = np.ascontiguousarray(cell["runs"][score])
            digest.update(repr((score, values.dtype.str, values.shape)).encode() + values.tobytes())
    key = {"format": CACHE_FORMAT, "scores": digest.hexdigest(), "confidence": float(confidence),
           "samples": int(samples), "seed": int(seed), "code": digests.code_digest(),
           "versions": {name: importlib.metadata.version(name) for name in ("numpy", "scipy", "pandas")},
           "figures": None}
    if curves is not None:
        digest = hashlib.sha256()
        for frame in (curves, table3):
            if frame is not None:
                _frame_digest(digest, frame)
            digest.update(b"\0table3\0")
        key["figures"] = {"data": digest.hexdigest(), "plateau_fraction": float(plateau_fraction), "dpi": int(dpi),
                          **_drawing_config()}
    return key


@dataclass(frozen=True)
class Derived:
    """A run's derived results: the comparisons, the figures, and where they came from (``seconds``:
    the time taken to load or compute them)."""

    comparisons: "pandas.DataFrame"
    figures: list[Figure]
    cached: bool
    path: Path
    seconds: float

    def summary(self) -> str:
        """One line for the run's output: loaded from or computed into `path`."""
        what = f"derived results (comparisons, {len(self.figures)} figures)"
        if self.cached:
            return f"{what}: loaded from {self.path}"
        return f"{what}: computed in {self.seconds:.2f} s, stored in {self.path}"


def _load(path: Path, key: dict):
    """``(comparison rows, {figure name: PNG bytes})`` stored at ``path`` under ``key``, else None."""
    try:
        with zipfile.ZipFile(path) as entry:
            if json.loads(entry.read("key.json")) != key:
                raise ValueError("it was stored under another key")
            rows = json.loads(entry.read("comparisons.json"))
            names = json.loads(entry.read("figures.json"))
            return rows, {name: entry.read(name) for name in names}
    except FileNotFoundError:
        return None
    except Exception as error:  # noqa: BLE001 - any damage (truncated, bad CRC, bad JSON, missing member) is a miss
        print(f"warning: ignoring the cached results {path} ({type(error).__name__}: {error}); recomputing them",
              file=sys.stderr)
        return None


def _store(path: Path, key: dict, rows: list[dict], pngs: dict) -> None:
    from tableclean_suite.bench.outputs import atomic_write

    def write(temporary: Path) -> None:
        with zipfile.ZipFile(temporary, "w", zipfile.ZIP_STORED) as entry:
            entry.writestr("comparisons.json", json.dumps(rows, allow_nan=True))
            entry.writestr("figures.json", json.dumps(list(pngs)))
            for name, png in pngs.items():
                entry.writestr(name, png)
            entry.writestr("key.json", json.dumps(key, sort_keys=True))

    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, write)
    _keep_only(path)


def _keep_only(path: Path) -> None:
    """Delete every other entry beside ``path``: a folder keeps the derived results of its latest run only."""
    for other in path.parent.glob("derived-*.zip"):
        if other != path:
            other.unlink(missing_ok=True)


class PendingDerived:
    """[start][tableclean_suite.bench.derived.start]'s results; `result` waits for the
    figures, stores a computed entry and returns a [`Derived`][tableclean_suite.bench.derived.Derived]."""

    def __init__(self, finish):
        self._finish = finish

    def result(self) -> Derived:
        return self._finish()


def start(root, cells: list[dict], confidence: float, samples: int, seed: int, curves=None, table3=None, *,
          plateau_fraction: float = 0.0, dpi: int = 120, read: bool = True) -> PendingDerived:
    """The comparisons ([statistics.comparisons][tableclean_suite.bench.statistics.comparisons] of
    ``cells`` at ``confidence``, ``samples`` bootstrap replicates, ``seed``) and the figures of
    ``curves`` (none when it is None), from the entry under ``root`` when it holds their key;
    else the comparisons are computed here and the figures start drawing in forked processes
    ([start_figures][tableclean_suite.bench.derived.start_figures]) while the caller works on.
    ``read=False`` (``--fresh``) ignores a stored entry and replaces it."""
    import pandas as pd

    from tableclean_suite.bench import statistics

    started = time.perf_counter()
    key = derived_key(cells, confidence, samples, seed, curves, table3, plateau_fraction, dpi)
    path = Path(root) / f"derived-{hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:16]}.zip"

    def results(rows, pngs, cached):
        comparisons = pd.DataFrame(rows, columns=statistics.COMPARISON_COLUMNS)
        figures = [Figure(name, png) for name, png in pngs.items()]
        return Derived(comparisons, figures, cached, path, time.perf_counter() - started)

    stored = _load(path, key) if read else None
    if stored is not None:
        _keep_only(path)
        return PendingDerived(lambda: results(*stored, True))
    rows = json.loads(json.dumps(statistics.comparison_rows(cells, confidence, samples, seed), allow_nan=True))
    drawing = (start_figures(curves, plateau_fraction, table3, dpi, processes=FIGURE_PROCESSES)
               if curves is not None else None)

    def finish():
        pngs = {figure.name: figure.png for figure in drawing.result()} if drawing is not None else {}
        _store(path, key, rows, pngs)
        return results(rows, pngs, False)

    return PendingDerived(finish)
