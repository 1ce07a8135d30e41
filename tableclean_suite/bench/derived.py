"""What a run derives from its cells (the comparisons table and the figures), cached in ``OUT/cells/derived/``.

[derive][tableclean_suite.bench.derived.derive] loads them from the entry stored under the key of
what determines them ([derived_key][tableclean_suite.bench.derived.derived_key]), else computes and
stores them.  An entry is one zip file (only the latest is kept), written atomically, whose members'
CRC-32 is checked on reading; an unreadable, partial or mismatched entry is a miss (a warning on
stderr), recomputed and replaced.  A hit and a miss both decode the stored bytes, so their outputs
are the same bytes.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import sys
import time
import zipfile
from dataclasses import dataclass
from pathlib import Path

from tableclean_suite.bench import digests, plots

#: Bump when an entry's layout or the meaning of what it stores changes.
CACHE_FORMAT = 2


def _drawing_config() -> dict:
    """What the figures' pixels depend on beyond their data and dpi: matplotlib's and Pillow's
    versions, a digest of the live ``rcParams`` and of the font file they resolve to."""
    import matplotlib
    from matplotlib import font_manager

    params = repr([(name, repr(matplotlib.rcParams[name])) for name in matplotlib.rcParams  # not those pyplot's
                   if name not in ("backend", "backend_fallback")])  # import sets; reading "backend" imports it
    font = Path(font_manager.findfont(font_manager.FontProperties(family=matplotlib.rcParams["font.family"])))
    return {"matplotlib": matplotlib.__version__, "pillow": importlib.metadata.version("pillow"),
            "rc_params": hashlib.sha256(params.encode()).hexdigest(), "font": font.name,
            "font_sha256": hashlib.sha256(font.read_bytes()).hexdigest()}


def derived_key(cells: list[dict], confidence: float, samples: int, seed: int, curves=None, table3=None,
                plateau_fraction: float = 0.0, dpi: int = 120) -> dict:
    """The JSON-able cache key of [derive][tableclean_suite.bench.derived.derive]'s results (same
    arguments): the cells' per-run scores, the comparison settings, the package's source and the numpy,
    scipy and pandas versions; with ``curves``, the frames, ``plateau_fraction``, ``dpi``, matplotlib's
    and Pillow's versions, the ``rcParams`` and the font file."""
    import numpy as np
    import pandas as pd

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
                digest.update(repr((list(frame.columns), [str(dtype) for dtype in frame.dtypes])).encode())
                digest.update(pd.util.hash_pandas_object(frame).to_numpy().tobytes())
            digest.update(b"\0table3\0")
        key["figures"] = {"data": digest.hexdigest(), "plateau_fraction": float(plateau_fraction), "dpi": int(dpi),
                          **_drawing_config()}
    return key


@dataclass(frozen=True)
class Derived:
    """A run's derived results: the comparisons, the figures (``{file name: PNG bytes}``), and where
    they came from (``seconds``: the time taken to load or compute them)."""

    comparisons: "pandas.DataFrame"
    figures: dict[str, bytes]
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
            return rows, {name: entry.read(name) for name in json.loads(entry.read("figures.json"))}
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


def derive(root, cells: list[dict], confidence: float, samples: int, seed: int, curves=None, table3=None, *,
           plateau_fraction: float = 0.0, dpi: int = 120, read: bool = True) -> Derived:
    """The comparisons ([statistics.comparisons][tableclean_suite.bench.statistics.comparisons] of
    ``cells`` at ``confidence``, ``samples`` bootstrap replicates, ``seed``) and the figures
    [available][tableclean_suite.bench.plots.available_figures] in ``curves`` (None: none) at ``dpi``,
    from the entry in the folder ``root`` under their key, else computed and stored there (every other
    entry is deleted).  ``read=False`` (``--fresh``) ignores a stored entry and replaces it."""
    import pandas as pd

    from tableclean_suite.bench import statistics

    started = time.perf_counter()
    key = derived_key(cells, confidence, samples, seed, curves, table3, plateau_fraction, dpi)
    path = Path(root) / f"derived-{hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:16]}.zip"
    stored = _load(path, key) if read else None
    cached = stored is not None
    if not cached:
        rows = json.loads(json.dumps(statistics.comparison_rows(cells, confidence, samples, seed), allow_nan=True))
        stems = [] if curves is None else plots.available_figures(curves)
        stored = rows, {f"{stem}.png": plots.render_png(stem, curves, plateau_fraction, table3, dpi) for stem in stems}
        _store(path, key, *stored)
    for other in path.parent.glob("derived-*.zip"):  # a folder keeps the derived results of its latest run only
        if other != path:
            other.unlink(missing_ok=True)
    rows, pngs = stored
    return Derived(pd.DataFrame(rows, columns=statistics.COMPARISON_COLUMNS),
                   pngs, cached, path, time.perf_counter() - started)
