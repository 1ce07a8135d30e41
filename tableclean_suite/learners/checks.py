"""Range checks with errors that name the value and what is allowed (shared by the learner modules)."""

from __future__ import annotations

import math

import numpy as np


def check_number(name, value, low, high, low_open=False, integer=False) -> None:
    """Raise ``ValueError`` unless ``value`` is a finite number in the interval ``[low, high]``.

    Args:
        name: what the value is, for the message (e.g. ``"alpha"`` or ``"learner 'q_lambda': lambda_"``).
        value: the value to check (``bool`` is refused, integers and floats of any kind are accepted).
        low, high: the bounds; ``math.inf`` for an unbounded side.
        low_open: exclude the lower bound itself.
        integer: the value must be a whole number.
    """
    allowed = f"{'(' if low_open else '['}{low}, {high}{')' if high == math.inf else ']'}"
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number in {allowed}, got {value!r}")
    if not math.isfinite(float(value)):
        raise ValueError(f"{name} must be a finite number in {allowed}, got {value!r}")
    if integer and int(value) != value:
        raise ValueError(f"{name} must be an integer in {allowed}, got {value!r}")
    if value < low or value > high or (low_open and value == low):
        raise ValueError(f"{name} must be in {allowed}, got {value!r}")
