"""Has a cell's behaviour settled inside its training window?

A run's *behaviour drift* is ``|success asymptote at T - success asymptote at the checkpoint|``
(a fraction in [0, 1]), the checkpoint being [checkpoint_iteration][tableclean_suite.settling.checkpoint_iteration].
A cell is *settled* when its mean drift over runs is at most a tolerance (a fraction).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Where the checkpoint lies in the window (a fraction in (0, 1)): the last quarter is compared.
CHECKPOINT_FRACTION = 0.75
#: Largest mean per-run change of the success asymptote over the last quarter of the window that
#: counts as settled (a fraction of episodes: 0.01 = one percentage point).
DEFAULT_SETTLE_TOLERANCE = 0.01


def checkpoint_iteration(iterations: int) -> int:
    """The checkpoint of a window of ``iterations`` (>= 1) steps: floor(`CHECKPOINT_FRACTION` x iterations), >= 1."""
    if int(iterations) < 1:
        raise ValueError(f"iterations must be >= 1, got {iterations!r}")
    return max(1, math.floor(CHECKPOINT_FRACTION * int(iterations)))


def behaviour_drift(final_success, checkpoint_success) -> np.ndarray:
    """Per-run drift ``|final - checkpoint|`` of two ``(R,)`` arrays of success asymptotes in [0, 1]."""
    final = np.asarray(final_success, dtype=np.float64)
    checkpoint = np.asarray(checkpoint_success, dtype=np.float64)
    if final.shape != checkpoint.shape or final.ndim != 1:
        raise ValueError(f"need two (R,) arrays of the same length, got {final.shape} and {checkpoint.shape}")
    return np.abs(final - checkpoint)


@dataclass(frozen=True)
class Settling:
    """A cell's behaviour drift over the window's last quarter.

    Attributes:
        drift: mean over runs of the per-run drift, a fraction in [0, 1] (NaN: not measured).
        low, high: its percentile bootstrap interval over runs (NaN: not measured).
        checkpoint: the iteration the final behaviour was compared with (0: not measured).
    """

    drift: float
    low: float
    high: float
    checkpoint: int

    @classmethod
    def not_measured(cls) -> "Settling":
        """For a backend that cannot replay a prefix cheaply and exactly (e.g. physics)."""
        return cls(float("nan"), float("nan"), float("nan"), 0)

    @property
    def measured(self) -> bool:
        return self.checkpoint > 0 and not math.isnan(self.drift)

    def settled(self, tolerance: float = DEFAULT_SETTLE_TOLERANCE) -> bool | None:
        """True if the mean drift is at most ``tolerance`` (a fraction); None if not measured."""
        if not self.measured:
            return None
        return bool(self.drift <= tolerance)
