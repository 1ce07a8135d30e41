"""Keep numba's disk cache honest when a compiled function's *dependencies* change.

numba keys a cached function on its own bytecode and its file's timestamp, not on the
functions it calls from other modules: edit [`rules`][tableclean_suite.learners.rules] or [`exploration`][tableclean_suite.learners.exploration] and a
process would load the kernel compiled against the old code.  [`guard`][tableclean_suite.learners.cache_guard.guard] stores a
digest of the dependency modules' sources beside numba's cache and, when it no longer
matches, empties the listed functions' cache indexes before anything loads from them,
so they are recompiled once against the current code.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from types import ModuleType

from tableclean_suite.atomic_files import atomic_write_text

#: Name of the digest file written into each guarded cache directory (one per guard name).
STAMP_SUFFIX = ".deps.sha256"


def guard(name: str, dispatchers: list, modules: list[ModuleType]) -> bool:
    """Invalidate the disk cache of ``dispatchers`` if ``modules`` changed since it was written.

    Args:
        name: a file-name-safe label for this group (e.g. ``"learners.kernel"``).
        dispatchers: ``numba.njit(cache=True)`` functions whose compiled code depends on ``modules``.
        modules: every module whose source the compiled code depends on (including the
            dispatchers' own).

    Returns:
        True when the cache was invalidated (the next call compiles), else False.  Does
        nothing when caching is off or the cache directory cannot be written (numba then
        compiles in every process anyway).
    """
    caches = [getattr(d, "_cache", None) for d in dispatchers]
    paths = {Path(c._cache_path) for c in caches if c is not None and hasattr(c, "_cache_path")}
    if not paths:
        return False
    current = hashlib.sha256(b"".join(Path(module.__file__).read_bytes() for module in modules)).hexdigest()
    invalidated = False
    for path in paths:
        stamp = path / f"{name}{STAMP_SUFFIX}"
        try:
            previous = stamp.read_text().strip() if stamp.exists() else None
        except OSError:
            continue
        if previous == current:
            continue
        if previous is not None or any(path.glob("*.nbi")):
            for cache in caches:
                if cache is not None and Path(cache._cache_path) == path:
                    cache.flush()
            invalidated = True
        try:
            path.mkdir(parents=True, exist_ok=True)
            atomic_write_text(stamp, current)
        except OSError:  # an OutputError too
            continue
    return invalidated
