"""Counter-based random numbers of the learners.

Every draw is a pure function of ``(seed, run, iteration, stream)``: SplitMix64
(Steele et al., 2014) indexed by ``iteration * N_STREAMS + stream`` from a per-run
key, so results do not depend on how runs are batched or spread over processes.

The four streams of the *main lane* (the run key itself) and their counter layout are
fixed: they produce the paper's numbers.  Draws that only some learners need come from
*side lanes*: a second key per lane, derived from the run key with a fixed salt
([`lane_key`][tableclean_suite.learners.rng.lane_key]), counted independently of the main lane, so adding them changes no
main-lane draw:

- ``LANE_LEARNER``: ``uniform(lane key, iteration, STREAM_DOUBLE_TABLE)``, which table a
  double-Q update changes;
- ``LANE_PLANNING``: ``uniform_at(lane key, iteration * planning_steps + j)``, the pair of
  Dyna-Q's j-th planning update after that iteration;
- ``LANE_ADVICE``: ``uniform(lane key, iteration, STREAM_ADVISE / STREAM_CONSISTENT /
  STREAM_ADVICE_ACTION)``, whether the simulated advisor advises the action taken at that
  iteration, whether its advice is its own policy's action, and which random action otherwise
  (interactive RL, [`assist`][tableclean_suite.learners.assist]);
- ``LANE_TIES``: ``uniform(lane key, iteration, STREAM_TIE)``, which of the tied greedy actions
  the behaviour policy takes at that iteration under ``train(ties="random")``;
- ``LANE_SIMULATION``: the episodes a cell's analysis simulates from each run's final greedy
  policy ([`tableclean_suite.simulation`][tableclean_suite.simulation]).
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

#: Side lanes (keys derived from the run key, see [`lane_key`][tableclean_suite.learners.rng.lane_key]); the main lane is 0.
LANE_LEARNER = 1
LANE_PLANNING = 2
LANE_ADVICE = 3
LANE_TIES = 4
LANE_SIMULATION = 64
#: Streams of the learner lane (same ``iteration * N_STREAMS + stream`` layout as the main lane).
STREAM_DOUBLE_TABLE = 0  # u < 0.5 -> a double-Q step updates table A, else table B
#: Streams of the advice lane (same layout).
STREAM_ADVISE = 0  # u < L -> the advisor advises this iteration's action
STREAM_CONSISTENT = 1  # u < C -> the advice is the advisor's own action, else a random one
STREAM_ADVICE_ACTION = 2  # which random action an inconsistent advisor gives, uniform over all actions
#: Stream of the ties lane: which of the tied greedy actions is taken (``ties="random"``).
STREAM_TIE = 0
#: Odd 64-bit constant that separates the lanes' keys (fixed: changing it changes the side draws).
LANE_SALT = 0xD1B54A32D192ED03

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


def lane_key_py(key: int, lane: int) -> int:
    """The key of side lane ``lane`` (>= 1) of the run key ``key`` (plain Python)."""
    return _mix_py((key ^ ((lane * LANE_SALT) & _MASK64)) & _MASK64)


_G = np.uint64(_GOLDEN)
_M1 = np.uint64(_MIX1)
_M2 = np.uint64(_MIX2)
_S30, _S27, _S31, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)
_NS = np.uint64(N_STREAMS)
_SALT = np.uint64(LANE_SALT)


@numba.njit(cache=True, inline="always")
def uniform(key, iteration, stream):
    """A uniform draw in [0, 1) of ``key`` (uint64) at ``iteration`` on ``stream``."""
    return uniform_at(key, np.uint64(iteration) * _NS + np.uint64(stream))


@numba.njit(cache=True, inline="always")
def _mix(z):
    """SplitMix64's finaliser of ``z + golden`` (compiled, uint64 wrap-around)."""
    z = z + _G
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@numba.njit(cache=True, inline="always")
def uniform_at(key, counter):
    """The uniform draw in [0, 1) at a raw ``counter`` (>= 0) of ``key`` (uint64)."""
    return np.float64(_mix(key + np.uint64(counter) * _G) >> _S11) * _TO_UNIT


@numba.njit(cache=True, inline="always")
def lane_key(key, lane):
    """The key of side lane ``lane`` (>= 1) of the run key ``key``; equal to [`lane_key_py`][tableclean_suite.learners.rng.lane_key_py]'s."""
    return _mix(key ^ (np.uint64(lane) * _SALT))
