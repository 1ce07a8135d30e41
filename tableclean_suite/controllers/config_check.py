"""The one check of a skill's settings: the keys it knows, the ranges of its ``Config``.

[`checked_skill_config`][tableclean_suite.controllers.config_check.checked_skill_config] is what a skill's
constructor, a robot's per-action overrides and [`compose_skill`][tableclean_suite.controllers.authoring.compose_skill]
run, so each refuses the same settings with the same [`SkillConfigError`][tableclean_suite.controllers.config_check.SkillConfigError]
(a leaf module: it imports nothing of the package).
"""

from __future__ import annotations

import warnings
from typing import Any, Mapping

#: Old config keys still accepted, with the key that replaced them (a ``DeprecationWarning`` says so).
RENAMED_KEYS = {"grasp_retries": "retries"}


class SkillConfigError(KeyError, ValueError):
    """Settings a skill refuses (a ``KeyError`` and a ``ValueError``): a key it does not know, or a value outside
    its ``Config``'s range; the message is one line naming the skill, the key and the allowed keys or range."""

    def __str__(self) -> str:  # a KeyError would quote the message
        return str(self.args[0]) if self.args else ""


def checked_skill_config(owner: str, config_type, defaults: Mapping[str, Any],
                         overrides: Mapping[str, Any] | None = None):
    """``({**defaults, **overrides}, the config_type instance of them)``, both checked.

    Args:
        owner: the skill as the message names it (e.g. ``"PickSkill"``, ``"skill 'transfer'"``).
        config_type: the skill's [`SkillConfig`][tableclean_suite.controllers.configs.SkillConfig] subclass (its ``keys()`` and ranges).
        defaults: the skill's settings before ``overrides`` (its ``DEFAULT_CONFIG``); their keys
            are the keys allowed (keys ``config_type`` lacks pass through unchecked).
        overrides: the values to put on top.

    Raises:
        SkillConfigError: a key of ``overrides`` not in ``defaults`` (naming the keys and the allowed
            ones), or a merged value outside ``config_type``'s range (naming the field, the value
            and the range).
    """
    overrides = dict(overrides or {})
    for old, new in RENAMED_KEYS.items():
        if old in overrides and new in defaults:
            warnings.warn(f"{owner}: config key {old!r} is now {new!r}", DeprecationWarning, stacklevel=3)
            overrides.setdefault(new, overrides.pop(old))
    unknown = sorted(set(overrides) - set(defaults))
    if unknown:
        raise SkillConfigError(f"unknown config keys for {owner}: {unknown} (allowed: {sorted(defaults)})")
    merged = {**defaults, **overrides}
    try:
        settings = config_type(**{key: merged[key] for key in config_type.keys() if key in merged})
    except ValueError as error:
        raise SkillConfigError(f"{owner}: {error}") from None
    return merged, settings
