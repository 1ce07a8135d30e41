"""Which skill class carries out which task-level action.

``SKILL_REGISTRY`` maps :class:`~tableclean_suite.task.Action` to a
:class:`~tableclean_suite.controllers.skill.Skill` subclass.  Users add or swap
skills with :func:`register_skill` without touching the controller::

    register_skill(Action.CLEAN, MyFasterCleanSkill, replace=True)
"""

from __future__ import annotations

from tableclean_suite.controllers.skill import Skill
from tableclean_suite.task import Action, as_action

#: The global action -> skill class table used by default by SkillController.
SKILL_REGISTRY: dict[Action, type[Skill]] = {}


def register_skill(action, cls: type[Skill], *, replace: bool = False, registry: dict | None = None) -> type[Skill]:
    """Register ``cls`` as the skill for ``action`` (an Action, its int value or name).

    Raises ``TypeError`` if ``cls`` is not a Skill subclass, ``ValueError`` if the
    action is unknown, if ``cls.action`` names a different action, or if the
    action already has a skill and ``replace`` is False.  Returns ``cls``.
    """
    action = as_action(action)
    if not (isinstance(cls, type) and issubclass(cls, Skill)):
        raise TypeError(f"skill for {action.name} must be a Skill subclass, got {cls!r}")
    declared = getattr(cls, "action", None)
    if declared is not None and as_action(declared) != action:
        raise ValueError(f"{cls.__name__} implements {as_action(declared).name}, not {action.name}")
    table = SKILL_REGISTRY if registry is None else registry
    if action in table and table[action] is not cls and not replace:
        raise ValueError(
            f"{action.name} already has skill {table[action].__name__}; pass replace=True to override"
        )
    table[action] = cls
    return cls


def get_skill_class(action, registry: dict | None = None) -> type[Skill]:
    """The skill class registered for ``action``; ``KeyError`` naming the registered actions if none."""
    action = as_action(action)
    table = SKILL_REGISTRY if registry is None else registry
    try:
        return table[action]
    except KeyError:
        known = ", ".join(a.name for a in table) or "none"
        raise KeyError(f"no skill registered for {action.name}; registered: {known}") from None
