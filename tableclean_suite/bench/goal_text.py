"""How the speed report words a measurement against its goal (one wording for every section)."""

from __future__ import annotations


def against_goal(measured: str, value: float, goal: float, goal_text: str, at_most: bool, difference: str) -> str:
    """``measured`` and how far ``value`` is from its ``goal``, e.g. ``"6.52% (1.30x the 5% goal, 1.52 points over)"``:
    every goal line of the speed report (:mod:`.speed`, :mod:`.skill_speed`) is worded so.

    ``goal_text``: the goal as printed; ``at_most``: the goal is an upper bound (``over``/``under``)
    rather than a lower one (``above``/``below``); ``difference``: the distance formatted, e.g.
    ``"1.52 points"`` (the caller knows its unit).
    """
    if at_most:
        side = "over" if value > goal else "under"
    else:
        side = "above" if value >= goal else "below"
    return f"{measured} ({value / goal:.2f}x the {goal_text} goal, {difference} {side})"


def seconds_against_goal(seconds: float, goal: float) -> str:
    """``"5.32 s (1.33x the 4 s goal, 1.32 s over)"``: a time and how far it is from its goal (``under`` when within)."""
    return against_goal(f"{seconds:.2f} s", seconds, goal, f"{goal:g} s", True, f"{abs(seconds - goal):.2f} s")
