"""Compiled loops over independent items, spread over threads (one job: [`run_in_threads`][tableclean_suite.learners.threads.run_in_threads]).

A compiled function ``kernel(lo, hi, *arguments)`` that handles items ``lo .. hi - 1`` and is
compiled with ``nogil=True`` runs on several Python threads at once.  Used instead of numba's
parallel loops (``prange``), whose compilation cost a first process seconds per function, where
each item's result does not depend on which thread computes it, so any split gives the same bits.
"""

from __future__ import annotations

import threading

import numba
import numpy as np

#: Slices of the items per thread (items differ in cost: several slices per thread, taken in
#: turn, keep the threads busy until the end).
SLICES_PER_THREAD = 8


def run_in_threads(kernel, n_items: int, arguments: tuple) -> None:
    """``kernel(lo, hi, *arguments)`` over slices covering items ``0 .. n_items``, on up to
    ``numba.get_num_threads()`` threads (in this thread alone when that is 1 or ``n_items`` is).

    ``kernel`` must be compiled with ``nogil=True`` (else the threads take turns) and write each
    item's results independently of the others.  The first exception a slice raises is raised
    here once every thread has stopped.
    """
    threads = max(1, min(numba.get_num_threads(), int(n_items)))
    if threads == 1:
        kernel(0, int(n_items), *arguments)
        return
    bounds = np.linspace(0, int(n_items), threads * SLICES_PER_THREAD + 1).astype(np.int64)
    slices = iter([(int(lo), int(hi)) for lo, hi in zip(bounds[:-1], bounds[1:]) if hi > lo])
    taking = threading.Lock()
    errors = []

    def work():
        while not errors:
            with taking:
                piece = next(slices, None)
            if piece is None:
                return
            try:
                kernel(piece[0], piece[1], *arguments)
            except BaseException as error:  # noqa: BLE001  (re-raised in the caller's thread)
                errors.append(error)

    helpers = [threading.Thread(target=work, daemon=True) for _ in range(threads - 1)]
    for helper in helpers:
        helper.start()
    work()
    for helper in helpers:
        helper.join()
    if errors:
        raise errors[0]
