"""Counter-based random numbers shared by the compiled and the plain-Python learners.

Every draw is a pure function of ``(seed, run, iteration, stream)``: SplitMix64
(Steele et al., 2014) indexed by ``iteration * N_STREAMS + stream`` from a per-run
key.  So results do not depend on how runs are batched, split over threads or
processes, or whether the compiled or the plain loop draws them: same seed,
same numbers, bit for bit.
"""

from __future__ import annotations

import numba
import numpy as np

#: Independent streams per iteration.
STREAM_EXPLORE = 0  # u < epsilon -> explore
STREAM_RANDOM_ACTION = 1  # which random action, uniform over all actions
STREAM_START = 2  # which start state, when there are several
STREAM_TRANSITION = 3  # which successor, for stochastic (calibrated) transitions
N_STREAMS = 4

_MASK64 = (1 << 64) - 1
_GOLDEN = 0x9E3779B97F4A7C15
_MIX1 = 0xBF58476D1CE4E5B9
_MIX2 = 0x94D049BB133111EB
_TO_UNIT = 2.0**-53  # 53 random bits -> [0, 1)


def _mix_py(z: int) -> int:
    z = (z + _GOLDEN) & _MASK64
    z = ((z ^ (z >> 30)) * _MIX1) & _MASK64
    z = ((z ^ (z >> 27)) * _MIX2) & _MASK64
    return z ^ (z >> 31)


def run_key(seed: int, run: int) -> int:
    """The 64-bit key of one run (Python int)."""
    return _mix_py((_mix_py(seed & _MASK64) + run) & _MASK64)


def run_keys(seed: int, first_run: int, runs: int) -> np.ndarray:
    """Keys of runs ``first_run .. first_run + runs - 1``, shape ``(runs,)`` uint64."""
    return np.array([run_key(seed, first_run + r) for r in range(runs)], dtype=np.uint64)


def uniform_py(key: int, iteration: int, stream: int) -> float:
    """A uniform draw in [0, 1) (plain Python)."""
    counter = (iteration * N_STREAMS + stream) & _MASK64
    z = _mix_py((key + counter * _GOLDEN) & _MASK64)
    return (z >> 11) * _TO_UNIT


_G = np.uint64(_GOLDEN)
_M1 = np.uint64(_MIX1)
_M2 = np.uint64(_MIX2)
_S30, _S27, _S31, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)
_NS = np.uint64(N_STREAMS)


@numba.njit(cache=True, inline="always")
def uniform(key, iteration, stream):
    """A uniform draw in [0, 1) (compiled); identical to :func:`uniform_py`."""
    counter = np.uint64(iteration) * _NS + np.uint64(stream)
    z = key + counter * _G + _G
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    z = z ^ (z >> _S31)
    return np.float64(z >> _S11) * _TO_UNIT
