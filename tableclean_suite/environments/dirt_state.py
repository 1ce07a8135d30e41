"""The dirt markers' wiped flags as MuJoCo state, so ``sim.get_state()`` / ``set_state_from_flattened()`` (robosuite's
``DataCollectionWrapper``, playback, robomimic) restore the cleaning.

Each segment has a dirt-state joint ([`dirt_state_joint_name`][tableclean_suite.environments.dirt_state.dirt_state_joint_name]): a horizontal, heavily damped
slide joint of a geometry-less body whose position is the segment's wiped flags as a binary fraction,

    qpos = sum_i wiped_i * 2**i / 2**k        (k markers, marker i -> bit i; in [0, 1) metres)

which a float64 holds exactly for k <= `MAX_MARKERS_PER_SEGMENT`.
"""

from __future__ import annotations

import numpy as np

#: Largest number of markers per segment one float64 joint position encodes exactly (its mantissa).
MAX_MARKERS_PER_SEGMENT = 52
#: A decoded position may sit at most this far [in code units] from an integer code; further is a fault.
CODE_TOLERANCE = 1e-6


class DirtStateError(ValueError):
    """A dirt-state joint holds a position that encodes no set of wiped flags (the message names it)."""


def dirt_state_joint_name(segment: int) -> str:
    """Name of the dirt-state slide joint of ``segment`` (0-based; e.g. ``"dirt_state_s1_joint"`` for segment 0)."""
    return f"dirt_state_s{segment + 1}_joint"


def _check_count(n_markers: int) -> int:
    if isinstance(n_markers, bool) or not isinstance(n_markers, (int, np.integer)) or not 1 <= n_markers <= MAX_MARKERS_PER_SEGMENT:
        raise ValueError(f"markers per segment must be an integer in [1, {MAX_MARKERS_PER_SEGMENT}], got {n_markers!r}")
    return int(n_markers)


def encode(wiped: np.ndarray) -> float:
    """The joint position [m, in [0, 1)] of the bool ``(k,)`` wiped flags of one segment's markers."""
    flags = np.asarray(wiped, dtype=bool)
    k = _check_count(flags.size)
    code = int(np.dot(flags.astype(np.int64), np.left_shift(np.int64(1), np.arange(k, dtype=np.int64))))
    return code / float(1 << k)


def decode(position: float, n_markers: int, joint: str = "dirt-state joint") -> np.ndarray:
    """Bool ``(k,)`` wiped flags of a joint ``position`` (inverse of [`encode`][tableclean_suite.environments.dirt_state.encode]);
    [`DirtStateError`][tableclean_suite.environments.dirt_state.DirtStateError] if it encodes none."""
    k = _check_count(n_markers)
    scaled = float(position) * float(1 << k)
    code = round(scaled) if np.isfinite(scaled) else -1
    if not 0 <= code < (1 << k) or abs(scaled - code) > CODE_TOLERANCE:
        raise DirtStateError(
            f"{joint} is at {position!r}, which encodes no wiped flags of {k} markers "
            f"(allowed: multiples of 2**-{k} in [0, 1))"
        )
    return ((int(code) >> np.arange(k)) & 1).astype(bool)
