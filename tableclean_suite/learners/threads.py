"""Compiled loops over independent items, spread over threads (one job: [`run_in_threads`][tableclean_suite.learners.threads.run_in_threads]).

Used instead of numba's ``prange``, whose compilation costs a first process seconds per function;
each item's result does not depend on the thread that computes it, so any split gives the same bits.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np

#: Slices of the items per thread (items differ in cost: several slices per thread, taken in
#: turn, keep the threads busy until the end).
SLICES_PER_THREAD = 8


def run_in_threads(kernel, n_items: int, arguments: tuple) -> None:
    """``kernel(lo, hi, *arguments)`` over slices covering items ``0 .. n_items``, on up to
    ``numba.get_num_threads()`` threads (in this thread alone when that is 1 or ``n_items`` is).

    ``kernel`` must be compiled with ``nogil=True`` (else the threads take turns) and write each
    item's results independently of the others.  The first slice's exception (in item order) is
    raised here once every slice has run.
    """
    threads = max(1, min(numba.get_num_threads(), int(n_items)))
    if threads == 1:
        kernel(0, int(n_items), *arguments)
        return
    bounds = np.linspace(0, int(n_items), threads * SLICES_PER_THREAD + 1).astype(np.int64)
    with ThreadPoolExecutor(threads) as pool:
        pieces = [pool.submit(kernel, int(lo), int(hi), *arguments) for lo, hi in zip(bounds[:-1], bounds[1:]) if hi > lo]
    for piece in pieces:
        piece.result()
