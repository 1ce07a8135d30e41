"""Which skill class carries out which task-level action.

``SKILL_REGISTRY`` maps action names (``"move"``, ...; [`Action`][tableclean_suite.task.actions.Action]
members and the paper-order ints are accepted as keys too) to a
[`Skill`][tableclean_suite.controllers.skill.Skill] subclass.  Users add or swap skills with
[`register_skill`][tableclean_suite.controllers.registry.register_skill] without touching the controller, also for actions they registered
with [`tableclean_suite.task.register_action`][tableclean_suite.task.actions.register_action]:

    register_skill(Action.CLEAN, MyFasterCleanSkill, replace=True)
    register_skill("move_back", MoveBackSkill)        # after register_action(ActionRule("move_back", ...))
"""

from __future__ import annotations

from tableclean_suite.controllers.skill import Skill
from tableclean_suite.task import Action, ActionRule, action_names, as_action, get_action_rule, register_action


def action_key(action) -> str:
    """The registered action name of ``action`` (an Action, a paper-order int or a name).

    Raises ``ValueError`` naming the registered actions when it is none of these.
    """
    if isinstance(action, Action):
        return action.rule_name
    if isinstance(action, str):
        key = action.strip().lower()
        if key.upper() in Action.__members__:
            return key
        return get_action_rule(key).name  # ValueError: unknown action ..., allowed: ...
    return as_action(action).rule_name  # an int, or the ValueError naming the allowed actions


class SkillTable(dict):
    """A ``dict`` from action name to skill class whose keys may be given as Actions, ints or names."""

    def __getitem__(self, action):
        return super().__getitem__(action_key(action))

    def __setitem__(self, action, cls):
        super().__setitem__(action_key(action), cls)

    def __contains__(self, action):
        try:
            return super().__contains__(action_key(action))
        except ValueError:
            return False

    def get(self, action, default=None):
        return self[action] if action in self else default


#: The global action -> skill class table used by default by SkillController.
SKILL_REGISTRY: SkillTable = SkillTable()


def register_skill(action, cls: type[Skill], *, replace: bool = False, registry: dict | None = None) -> type[Skill]:
    """Register ``cls`` as the skill for ``action`` (an Action, its int value or a registered action name).

    A skill made by [`compose_skill`][tableclean_suite.controllers.authoring.compose_skill] carries its
    action's symbolic rule (``cls.rule``): it is registered with
    [`register_action`][tableclean_suite.task.actions.register_action] when the action is unknown (or replaced along
    with the skill when ``replace``), once the checks below passed: a refused skill registers nothing.

    Raises ``TypeError`` if ``cls`` is not a Skill subclass, ``ValueError`` if the
    action is unknown, if ``cls.action`` names a different action, or if the
    action already has a skill and ``replace`` is False.  Returns ``cls``.
    """
    rule = getattr(cls, "rule", None)
    carried = rule if isinstance(rule, ActionRule) and isinstance(action, str) and rule.name == action.strip().lower() \
        else None

    def key_of(named) -> str:  # the carried rule's action is a key before its rule is registered
        if carried is not None and isinstance(named, str) and named.strip().lower() == carried.name:
            return carried.name
        return action_key(named)

    key = key_of(action)
    if not (isinstance(cls, type) and issubclass(cls, Skill)):
        raise TypeError(f"skill for {key.upper()} must be a Skill subclass, got {cls!r}")
    declared = getattr(cls, "action", None)
    if declared is not None and key_of(declared) != key:
        raise ValueError(f"{cls.__name__} implements {key_of(declared).upper()}, not {key.upper()}")
    table = SKILL_REGISTRY if registry is None else registry
    existing = {key_of(k): v for k, v in table.items()}
    if key in existing and existing[key] is not cls and not replace:
        raise ValueError(f"{key.upper()} already has skill {existing[key].__name__}; pass replace=True to override")
    if carried is not None:  # every check passed: a failed registration leaves no action behind
        known = carried.name in action_names()
        if not known or (replace and get_action_rule(carried.name) is not carried):
            register_action(carried, overwrite=known)
    for old in [k for k in table if key_of(k) == key]:
        del table[old]
    dict.__setitem__(table, key, cls) if isinstance(table, SkillTable) else table.__setitem__(key, cls)
    return cls


def get_skill_class(action, registry: dict | None = None) -> type[Skill]:
    """The skill class registered for ``action``; ``KeyError`` naming the registered actions if none."""
    key = action_key(action)
    table = SKILL_REGISTRY if registry is None else registry
    for name, cls in table.items():
        if action_key(name) == key:
            return cls
    known = ", ".join(action_key(a).upper() for a in table) or "none"
    raise KeyError(f"no skill registered for {key.upper()}; registered: {known}")
