"""Results ``benchmarks.run`` derives from its cells, cached by the code and inputs that make them.

The cells (:mod:`.experiments`) are cached by their own key; what a run computes from them is
cached here, under ``OUT/cells/derived/``:

- the **probabilities of improvement** (:func:`comparisons`: 32 stratified bootstraps, ~1.7 s
  at the defaults), keyed by a digest of the per-run scores they are computed from (learner,
  reward and every run's values, in order), the bootstrap settings (replicates, confidence,
  seed), the source of :mod:`.statistics` and the numpy, numba and Python versions;
- the **figures** (:func:`figures`: ~2 s with matplotlib's import), each keyed by a digest of
  the data it draws (the whole curves frame and Table 3, whose plateaus it marks), the plateau
  fraction, the dpi, the source of :mod:`.plots` (which holds the drawing and the ``savefig``
  call), the matplotlib, Pillow, numpy, pandas and Python versions, matplotlib's live
  ``rcParams`` (so every matplotlibrc and style in effect) and the font file matplotlib resolves
  for them.  A figure whose key is stored is copied from the cache without importing pyplot.

Both paths produce the bytes the same way: a computed result is serialised (JSON rows, PNG
bytes), stored, and what the run writes and prints is decoded from those bytes, so a cached and
a computed run write identical files (a test compares them).  Each entry is one file,
``NAME-HASH.cache``, written atomically, holding its full key and the SHA-256 of its payload; an
entry whose stored key differs from the one asked for (a hash collision) or whose payload does
not match its digest (damage) is treated as missing, reported on stderr, recomputed and
replaced.  ``--fresh`` ignores stored entries (and overwrites them).
"""

from __future__ import annotations

import gc
import hashlib
import importlib.util
import json
import os
import platform
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tableclean_suite.bench import plots
from tableclean_suite.bench.outputs import atomic_write

#: Bump when an entry's layout or the meaning of a stored payload changes.
FORMAT_VERSION = 1
#: First line of every entry file.
MAGIC = b"tableclean_suite derived result\n"
#: Extension of entry files.
SUFFIX = ".cache"


def _key_text(key: dict) -> str:
    return json.dumps(key, sort_keys=True, separators=(",", ":"))


def key_hash(key: dict) -> str:
    """SHA-256 (hex) of a key's canonical JSON."""
    return hashlib.sha256(_key_text(key).encode()).hexdigest()


class DerivedStore:
    """Derived results, one file per (name, key) under ``root``.

    Args:
        root: the directory (created on the first save).
        read: False to ignore stored entries (``--fresh``); saving still replaces them.
    """

    def __init__(self, root, read: bool = True):
        self.root = Path(root)
        self.read = read

    def path(self, name: str, key: dict) -> Path:
        """Where the entry of ``name`` under ``key`` lives."""
        return self.root / f"{name}-{key_hash(key)[:16]}{SUFFIX}"

    def load(self, name: str, key: dict) -> bytes | None:
        """The payload stored for ``name`` under exactly ``key``, or None."""
        if not self.read:
            return None
        path = self.path(name, key)
        try:
            data = path.read_bytes()
        except FileNotFoundError:
            return None
        except OSError as error:
            print(f"warning: cannot read cached result {path} ({error}); recomputing it", file=sys.stderr)
            return None
        try:
            if not data.startswith(MAGIC):
                raise ValueError("not a derived-result file")
            end = data.index(b"\n", len(MAGIC))
            header = json.loads(data[len(MAGIC):end])
            payload = data[end + 1:]
            if header["key"] != _key_text(key):
                raise ValueError("its key differs from its name's")
            if header["sha256"] != hashlib.sha256(payload).hexdigest() or header["bytes"] != len(payload):
                raise ValueError("its payload does not match its digest")
        except (ValueError, KeyError, TypeError) as error:
            print(f"warning: ignoring cached result {path} ({error}); recomputing it", file=sys.stderr)
            return None
        return payload

    def save(self, name: str, key: dict, payload: bytes) -> Path:
        """Store ``payload`` for ``name`` under ``key``, atomically (temporary file, then rename)."""
        path = self.path(name, key)
        header = {"key": _key_text(key), "sha256": hashlib.sha256(payload).hexdigest(), "bytes": len(payload)}
        self.root.mkdir(parents=True, exist_ok=True)
        data = MAGIC + json.dumps(header, sort_keys=True).encode() + b"\n" + payload
        return atomic_write(path, lambda temporary: temporary.write_bytes(data))


def source_digest(*modules: str) -> str:
    """SHA-256 (hex) of the named modules' source files, read without importing the modules."""
    digest = hashlib.sha256()
    for name in modules:
        spec = importlib.util.find_spec(name)
        if spec is None or not spec.origin or not os.path.isfile(spec.origin):
            raise RuntimeError(f"no source file for module {name}")
        digest.update(name.encode() + b"\0")
        digest.update(Path(spec.origin).read_bytes())
    return digest.hexdigest()


def frame_digest(frame) -> str:
    """SHA-256 (hex) of a DataFrame's column names, dtypes, index and values (numbers by their bits,
    anything else by ``repr``)."""
    import pandas as pd

    digest = hashlib.sha256()
    index = frame.index
    digest.update((repr(index) if isinstance(index, pd.RangeIndex) else repr(index.tolist())).encode())
    for name in frame.columns:
        series = frame[name]
        digest.update(f"\0{name!r}\0{series.dtype}\0".encode())
        if isinstance(series.dtype, np.dtype) and series.dtype.kind in "biufc":
            digest.update(np.ascontiguousarray(series.to_numpy()).tobytes())
        else:
            values = series.tolist()
            try:  # str.join accepts only str: all text, joined; anything else: its repr
                text = "str:" + "\0".join(values)
            except TypeError:
                text = "repr:" + repr(values)
            digest.update(text.encode("utf-8", "surrogatepass"))
    return digest.hexdigest()


def _versions(*names: str) -> dict:
    versions = {"python": platform.python_version(), "implementation": sys.implementation.name}
    for name in names:
        module = sys.modules.get(name) or importlib.import_module(name)
        versions[name] = getattr(module, "__version__", None)
    return versions


# -- probabilities of improvement -----------------------------------------------------------

def scores_digest(cells: list[dict]) -> str:
    """SHA-256 (hex) of :func:`.statistics.comparisons`' input: each cell's learner, reward and
    per-run scores (dtype, shape, bits), in order."""
    digest = hashlib.sha256()
    for cell in cells:
        digest.update(f"{cell['learner']!r}\0{cell['reward']!r}\0".encode())
        for score in sorted(cell["runs"]):
            values = np.ascontiguousarray(cell["runs"][score])
            digest.update(f"{score!r}\0{values.dtype.str}\0{values.shape}\0".encode())
            digest.update(values.tobytes())
    return digest.hexdigest()


def comparisons_key(cells: list[dict], confidence: float, samples: int, seed: int) -> dict:
    """The cache key of :func:`.statistics.comparison_rows` of these inputs."""
    return {"format": FORMAT_VERSION, "what": "comparisons", "scores": scores_digest(cells),
            "confidence": float(confidence), "samples": int(samples), "seed": int(seed),
            "code": source_digest("tableclean_suite.bench.statistics"), "versions": _versions("numpy", "numba")}


def comparisons(store: DerivedStore, cells: list[dict], confidence: float, samples: int, seed: int):
    """:func:`.statistics.comparisons` of the inputs, from ``store`` when it holds them.

    Returns:
        ``(frame, cached)``: the DataFrame and whether it came from the store.
    """
    from tableclean_suite.bench import statistics

    key = comparisons_key(cells, confidence, samples, seed)
    payload = store.load("comparisons", key)
    cached = payload is not None
    if not cached:
        rows = statistics.comparison_rows(cells, confidence, samples, seed)
        payload = json.dumps(rows, allow_nan=True).encode()
        store.save("comparisons", key, payload)
    return statistics.comparisons_frame(json.loads(payload)), cached


# -- figures ----------------------------------------------------------------------------------

def matplotlib_config() -> dict:
    """What matplotlib's rendering depends on beyond its version: a digest of the live
    ``rcParams`` (Agg backend) and of the font file they resolve to."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import font_manager

    params = hashlib.sha256(repr(sorted((k, repr(v)) for k, v in matplotlib.rcParams.items())).encode())
    font = font_manager.findfont(font_manager.FontProperties(family=matplotlib.rcParams["font.family"]))
    return {"rc_params": params.hexdigest(), "font": Path(font).name,
            "font_sha256": hashlib.sha256(Path(font).read_bytes()).hexdigest()}


def figure_key(stem: str, curves_sha256: str, table3_sha256: str | None, plateau_fraction: float, dpi: int,
               config: dict) -> dict:
    """The cache key of :func:`.plots.render_png` of these inputs."""
    import PIL

    return {"format": FORMAT_VERSION, "what": "figure", "stem": stem, "curves": curves_sha256,
            "table3": table3_sha256, "plateau_fraction": float(plateau_fraction), "dpi": int(dpi),
            "code": source_digest("tableclean_suite.bench.plots"),
            "versions": {**_versions("numpy", "pandas", "matplotlib"), "pillow": PIL.__version__},
            "matplotlib": config}


@dataclass(frozen=True)
class Figure:
    """One figure of a run: its file name, PNG bytes and whether they came from the cache."""

    name: str
    png: bytes
    cached: bool


def figures(store: DerivedStore, curves, plateau_fraction: float, table3=None, dpi: int = 120,
            processes: int = 1) -> list[Figure]:
    """The paper's figures that ``curves`` allows, each from ``store`` when it holds it, else drawn
    (:func:`.plots.render_png`, pyplot imported then) and stored: :func:`start_figures`, finished."""
    return start_figures(store, curves, plateau_fraction, table3, dpi, processes).result()


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
    """Figures being drawn (:func:`start_figures`); :meth:`result` waits for them, stores the
    drawn ones and returns every :class:`Figure` in the order of :func:`.plots.available_figures`."""

    def __init__(self, store: DerivedStore, stems: list, keys: dict, loaded: dict, drawing, pool):
        self._store, self._stems, self._keys, self._loaded = store, stems, keys, loaded
        self._drawing, self._pool = drawing, pool

    def result(self) -> list[Figure]:
        global _DRAWING_INPUTS
        try:
            drawn = dict(self._drawing()) if self._drawing is not None else {}
        finally:
            if self._pool is not None:
                self._pool.close()
                self._pool.join()
            _DRAWING_INPUTS = None
        figures = []
        for stem in self._stems:
            if stem in drawn:
                self._store.save(stem, self._keys[stem], drawn[stem])
                figures.append(Figure(f"{stem}.png", drawn[stem], False))
            else:
                figures.append(Figure(f"{stem}.png", self._loaded[stem], True))
        return figures


def start_figures(store: DerivedStore, curves, plateau_fraction: float, table3=None, dpi: int = 120,
                  processes: int = 1) -> PendingFigures:
    """Start drawing the figures ``store`` does not hold; the caller works on meanwhile.

    With ``processes`` > 1 on a platform that forks (Linux), up to that many forked processes
    (at most :data:`FIGURE_PROCESSES`) draw them while this one goes on; they inherit the inputs
    and run the same code on the same matplotlib configuration, so the PNG bytes are those drawn
    here (the cache key names that configuration).  Otherwise they are drawn here, on
    :meth:`PendingFigures.result`.
    """
    global _DRAWING_INPUTS
    import multiprocessing

    stems = plots.available_figures(curves)
    if not stems:
        return PendingFigures(store, [], {}, {}, None, None)
    curves_sha256 = frame_digest(curves)
    table3_sha256 = frame_digest(table3) if table3 is not None else None
    config = matplotlib_config()
    keys = {stem: figure_key(stem, curves_sha256, table3_sha256, plateau_fraction, dpi, config) for stem in stems}
    loaded = {stem: store.load(stem, keys[stem]) for stem in stems}
    missing = [stem for stem in stems if loaded[stem] is None]
    _DRAWING_INPUTS = (curves, plateau_fraction, table3, dpi)
    forks = "fork" in multiprocessing.get_all_start_methods() and sys.platform.startswith("linux")
    workers = min(int(processes), FIGURE_PROCESSES, len(missing))
    if not missing:
        return PendingFigures(store, stems, keys, loaded, None, None)
    if workers < 2 or not forks:
        return PendingFigures(store, stems, keys, loaded, lambda: [(stem, _draw(stem)) for stem in missing], None)
    plots.code_columns(curves)  # once here, inherited by every drawing process
    gc.freeze()  # the forked processes' collections then leave this process's objects (and pages) alone
    try:
        pool = multiprocessing.get_context("fork").Pool(workers)
    finally:
        gc.unfreeze()
    pending = pool.map_async(_draw, missing, chunksize=1)
    return PendingFigures(store, stems, keys, loaded, lambda: zip(missing, pending.get()), pool)
