"""One BLAS thread while a task runs, so its numbers do not depend on where it runs.

OpenBLAS's thread count changes the rounding of some products, hence a physics trajectory's last
bits (Ray starts workers with ``OMP_NUM_THREADS=1``, local processes inherit the caller's).  The
count is set through the OpenBLAS libraries this process has loaded (``/proc/self/maps``) and
restored afterwards; without ``/proc`` or OpenBLAS nothing changes.
"""

from __future__ import annotations

import contextlib
import ctypes
from typing import Iterator

#: ``(get, set)`` thread-count functions of the OpenBLAS builds numpy and scipy ship (64-bit
#: integer builds add a suffix; scipy's has a prefix).
OPENBLAS_FUNCTIONS = (
    ("openblas_get_num_threads", "openblas_set_num_threads"),
    ("openblas_get_num_threads64_", "openblas_set_num_threads64_"),
    ("scipy_openblas_get_num_threads", "scipy_openblas_set_num_threads"),
    ("scipy_openblas_get_num_threads64_", "scipy_openblas_set_num_threads64_"),
)
MAPS = "/proc/self/maps"


def loaded_openblas() -> list[tuple[str, object, object]]:
    """``(path, get, set)`` for every OpenBLAS library this process has loaded (``[]`` if none or no ``/proc``)."""
    try:
        with open(MAPS) as handle:
            paths = sorted({line.split()[-1] for line in handle
                            if "openblas" in line.rsplit("/", 1)[-1].lower() and "/" in line})
    except OSError:
        return []
    found = []
    for path in paths:
        try:
            library = ctypes.CDLL(path, mode=ctypes.RTLD_LOCAL)
        except OSError:
            continue
        for get_name, set_name in OPENBLAS_FUNCTIONS:
            getter, setter = getattr(library, get_name, None), getattr(library, set_name, None)
            if getter is not None and setter is not None:
                getter.restype, getter.argtypes = ctypes.c_int, []
                setter.restype, setter.argtypes = None, [ctypes.c_int]
                found.append((path, getter, setter))
                break
    return found


@contextlib.contextmanager
def single_blas_thread() -> Iterator[None]:
    """Run the ``with`` block with every loaded OpenBLAS on one thread; the counts are restored after."""
    libraries = loaded_openblas()
    before = [int(getter()) for _, getter, _ in libraries]
    for _, _, setter in libraries:
        setter(1)
    try:
        yield
    finally:
        for (_, _, setter), count in zip(libraries, before):
            setter(count)
