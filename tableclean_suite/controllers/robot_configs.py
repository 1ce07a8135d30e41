"""Per-robot skill configuration for the controllers: the robot registry
([`tableclean_suite.environments.robot_registry`][tableclean_suite.environments.robot_registry], a leaf module) and the one way to add to it.

[`SkillController`][tableclean_suite.controllers.skill_controller.SkillController] merges [`skill_overrides`][tableclean_suite.environments.robot_registry.skill_overrides] of the env's robot
under the caller's own ``skill_configs``; [`skill_controller_config`][tableclean_suite.controllers.osc.skill_controller_config] merges
[`osc_overrides`][tableclean_suite.environments.robot_registry.osc_overrides] over `OSC_OVERRIDES`.  Users add an arm with
[`register_robot_config`][tableclean_suite.controllers.robot_configs.register_robot_config]:

    register_robot_config(RobotSkillConfig("MyArm", skills={"*": {"fingertip_depth": 0.02}}))
"""

from __future__ import annotations

import dataclasses

from tableclean_suite.controllers.configs import SkillConfig, checked_skill_config
from tableclean_suite.controllers.osc import SKILL_ARM_CONTROLLER
from tableclean_suite.controllers.registry import SKILL_REGISTRY, action_key
from tableclean_suite.controllers.skill import BASE_CONFIG
from tableclean_suite.environments import robot_registry
from tableclean_suite.environments.robot_registry import (  # noqa: F401  (the registry's public names)
    ALL_SKILLS,
    ROBOT_CONFIGS,
    SWAP_GRIPPER,
    RobotSkillConfig,
    base_shift,
    check_robot,
    osc_overrides,
    robot_name,
    scene_gripper_types,
    skill_overrides,
    supported_robots,
)


def register_robot_config(config: RobotSkillConfig, *, replace: bool = False) -> RobotSkillConfig:
    """Add ``config`` to the robot registry under ``config.robot``; returns the stored config, its per-action keys
    (anything [`action_key`][tableclean_suite.controllers.registry.action_key] reads) as registered action names.

    Raises:
        TypeError: ``config`` is not a [`RobotSkillConfig`][tableclean_suite.environments.robot_registry.RobotSkillConfig].
        ValueError: a skills key that is neither `ALL_SKILLS` nor a registered action, or two naming the same
            action; an `ALL_SKILLS` key not in ``BASE_CONFIG`` or out of [`SkillConfig`][tableclean_suite.controllers.configs.SkillConfig]'s
            range; per-action overrides the action's registered skill refuses
            ([`SkillConfigError`][tableclean_suite.controllers.configs.SkillConfigError]); the robot already
            registered without ``replace``; an OSC override of ``type``, ``input_type`` or ``input_ref_frame``.
    """
    if not isinstance(config, RobotSkillConfig):
        raise TypeError(f"register_robot_config needs a RobotSkillConfig, got {config!r}")
    skills = {}
    for key, values in config.skills.items():
        name = key if key == ALL_SKILLS else action_key(key)
        if name in skills:
            raise ValueError(f"robot {config.robot!r}: skills keys {key!r} and another both name {name!r}")
        skills[name] = values
    shared = skills.get(ALL_SKILLS, {})
    unknown = sorted(set(shared) - set(BASE_CONFIG))
    if unknown:
        raise ValueError(f"robot {config.robot!r}: keys {unknown} under {ALL_SKILLS!r} are not BASE_CONFIG keys "
                         f"(allowed: {sorted(BASE_CONFIG)}); put skill-specific keys under the action's name")
    SkillConfig(**shared)  # its values in range (ValueError naming the field)
    for name, overrides in skills.items():
        if name != ALL_SKILLS and name in SKILL_REGISTRY:  # the check the skill's constructor runs
            skill = SKILL_REGISTRY[name]
            checked_skill_config(f"{skill.__name__} (robot {config.robot!r})", skill.Config, skill.DEFAULT_CONFIG,
                                 {**shared, **overrides})
    if config.robot in robot_registry.ROBOT_CONFIGS and not replace:
        raise ValueError(f"robot {config.robot!r} already has a skill config; pass replace=True to override")
    fixed = sorted(set(config.osc) & set(SKILL_ARM_CONTROLLER))
    if fixed:
        raise ValueError(f"robot {config.robot!r}: the OSC keys {fixed} are what the skills rely on and cannot be overridden")
    config = dataclasses.replace(config, skills=skills)
    robot_registry.ROBOT_CONFIGS[config.robot] = config
    return config
