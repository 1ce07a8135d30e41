"""Checks of ``TableClean``'s arguments and its start layout, before anything is built (one-line ``ValueError``s
naming the value and what is allowed)."""

from __future__ import annotations

import enum
from typing import Iterable, Mapping, NamedTuple

import numpy as np

#: Non-finite action entries an error message lists.
MAX_NAMED_ENTRIES = 4
#: Hz, the slowest control loop the scene takes (the skills' rate limits are per control step; slower, a step
#: holds one arm goal for over a second).
MIN_CONTROL_FREQ = 1.0


class _LayoutDefault(enum.Enum):
    """`FROM_SPEC`'s type: a sentinel compared by identity and kept through pickling."""

    FROM_SPEC = "from_spec"

    def __repr__(self) -> str:
        return self.name


#: Default of the layout arguments: with ``task=`` given, the layout comes from the spec's start; without it,
#: each is drawn at each reset.
FROM_SPEC = _LayoutDefault.FROM_SPEC


class StartLayout(NamedTuple):
    """Where the following resets start (what ``TableClean.set_start`` stores), 0-based (None: drawn at each reset)."""

    object_segment: int | None  #: the segment every object starts on, or None (drawn, or objects apart)
    object_segments: tuple[int | None, ...]  #: (M,) each object's segment
    arm_segment: int | None  #: the segment the arm starts above
    dirty_segments: tuple[int, ...]  #: sorted segments that start dirty


def segment_numbers(n_segments: int) -> str:
    """The 1-based segment numbers of the scene, as text for error messages (e.g. "1, 2")."""
    return ", ".join(str(k) for k in range(1, n_segments + 1))


def segment_option(name: str, value, n_segments: int) -> int | None:
    """``None`` (random each reset) or the 0-based index of a 1-based segment number; clear ``ValueError`` otherwise."""
    if value is None:
        return None
    if isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)) and 1 <= value <= n_segments:
        return int(value) - 1
    raise ValueError(f"{name} must be {segment_numbers(n_segments)} or None (random at each reset), got {value!r}")


def dirty_option(value: Iterable[int] | None, n_segments: int) -> tuple[int, ...]:
    """Sorted 0-based indices of the 1-based segment numbers in ``value`` (None: all); clear ``ValueError`` otherwise."""
    if value is None:
        return tuple(range(n_segments))
    allowed = segment_numbers(n_segments)
    try:
        numbers = tuple(value)
    except TypeError:
        raise ValueError(f"dirty_segments must be a collection of segment numbers ({allowed}), got {value!r}") from None
    segments = tuple(segment_option("dirty_segments entry", n, n_segments) for n in numbers)
    if None in segments:
        raise ValueError(f"dirty_segments must contain only segment numbers ({allowed}), got {value!r}")
    return tuple(sorted(set(segments)))


def start_layout(n_segments: int, n_objects: int, object_segment: int | None, arm_segment: int | None,
                 dirty_segments: Iterable[int] | None = None,
                 object_segments: Iterable[int | None] | None = None) -> StartLayout:
    """The [StartLayout][tableclean_suite.environments.arguments.StartLayout] of 1-based arguments (see
    ``TableClean.set_start``); ``ValueError`` naming the bad value and the allowed ones."""
    single = segment_option("object_segment", object_segment, n_segments)
    if object_segments is None:
        per_object = (single,) * n_objects
    else:
        try:
            entries = tuple(object_segments)
        except TypeError:
            raise ValueError(f"object_segments must be {n_objects} segment numbers, got {object_segments!r}") from None
        if len(entries) != n_objects:
            raise ValueError(f"object_segments must have one entry per object ({n_objects}), got {object_segments!r}")
        per_object = tuple(segment_option(f"object_segments[{j}]", v, n_segments) for j, v in enumerate(entries))
        single = per_object[0] if len(set(per_object)) == 1 else None
    return StartLayout(single, per_object, segment_option("arm_segment", arm_segment, n_segments),
                       dirty_option(dirty_segments, n_segments))


def check_finite_action(action) -> None:
    """``ValueError`` unless ``action`` is a flat sequence of finite numbers (the entries that are not are named)."""
    try:
        values = np.asarray(action, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"action must be a sequence of numbers, got {action!r}") from None
    bad = np.flatnonzero(~np.isfinite(values.ravel()))
    if bad.size:
        shown = ", ".join(f"[{i}] = {values.ravel()[i]}" for i in bad[:MAX_NAMED_ENTRIES])
        raise ValueError(f"action has {bad.size} non-finite entr{'y' if bad.size == 1 else 'ies'} ({shown}); "
                         "every entry must be a finite number")


def check_episode_settings(horizon, control_freq) -> None:
    """``ValueError`` naming ``horizon`` (an integer >= 1, control steps) or ``control_freq`` (Hz, from
    `MIN_CONTROL_FREQ` to one control step per physics step, 1 / robosuite's ``SIMULATION_TIMESTEP``)."""
    from robosuite.macros import SIMULATION_TIMESTEP

    if isinstance(horizon, bool) or not isinstance(horizon, (int, np.integer)) or horizon < 1:
        raise ValueError(f"horizon must be an integer >= 1 (control steps per episode), got {horizon!r}")
    highest = 1.0 / SIMULATION_TIMESTEP
    if isinstance(control_freq, bool) or not isinstance(control_freq, (int, float, np.number)) \
            or not MIN_CONTROL_FREQ <= control_freq <= highest:  # False for NaN
        raise ValueError(f"control_freq must be a number from {MIN_CONTROL_FREQ:g} to {highest:g} Hz (at most one "
                         f"control step per {SIMULATION_TIMESTEP:g} s physics step), got {control_freq!r}")


def check_controller_configs(controller_configs) -> None:
    """``ValueError`` for a controller config robosuite would refuse with an assertion: not a dict, or a
    ``type`` that is not one of robosuite's composite or part controllers (named)."""
    if controller_configs is None:
        return
    from robosuite.controllers import ALL_COMPOSITE_CONTROLLERS, ALL_PART_CONTROLLERS

    allowed = [*ALL_COMPOSITE_CONTROLLERS, *ALL_PART_CONTROLLERS]
    configs = controller_configs if isinstance(controller_configs, (list, tuple)) else [controller_configs]
    for config in configs:
        if not isinstance(config, Mapping):
            raise ValueError(f"controller_configs must be a dict (e.g. robosuite.load_composite_controller_config"
                             f"(controller='BASIC')), got {config!r}")
        kind = config.get("type")
        if kind not in allowed:
            raise ValueError(f"unknown controller type {kind!r}; allowed: {', '.join(allowed)}")
