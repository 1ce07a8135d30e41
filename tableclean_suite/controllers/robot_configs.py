"""Per-robot skill configuration for the controllers: the robot registry
(:mod:`tableclean_suite.environments.robot_registry`, a leaf module) and the checked way to add to it.

:class:`~.skill_controller.SkillController` merges :func:`skill_overrides` of the env's robot
under the caller's own ``skill_configs``; :func:`~.osc.skill_controller_config` merges
:func:`osc_overrides` over :data:`~.osc.OSC_OVERRIDES`.  Users add an arm with
:func:`register_robot_config`::

    register_robot_config(RobotSkillConfig("MyArm", skills={"*": {"fingertip_depth": 0.02}}))
"""

from __future__ import annotations

from tableclean_suite.controllers.config_check import checked_skill_config
from tableclean_suite.controllers.configs import SkillConfig
from tableclean_suite.controllers.registry import SKILL_REGISTRY
from tableclean_suite.controllers.skill import BASE_CONFIG, Skill
from tableclean_suite.environments.robot_registry import (  # noqa: F401  (the registry's public names)
    ALL_SKILLS,
    ROBOT_CONFIGS,
    SWAP_GRIPPER,
    RobotSkillConfig,
    action_name,
    add_robot_config,
    base_shift,
    check_robot,
    osc_overrides,
    robot_name,
    scene_gripper_types,
    skill_overrides,
    supported_robots,
)


def _check_action_overrides(robot: str, skill: type[Skill], overrides: dict) -> None:
    """Refuse the merged robot ``overrides`` (``"*"`` then per-action) for ``skill`` that it would refuse
    when made (:func:`~.config_check.checked_skill_config`, the check its constructor runs)."""
    checked_skill_config(f"{skill.__name__} (robot {robot!r})", skill.Config, skill.DEFAULT_CONFIG, overrides)


def register_robot_config(config: RobotSkillConfig, *, replace: bool = False) -> RobotSkillConfig:
    """Add ``config`` to the robot registry under ``config.robot``; returns the stored config.

    The per-action keys of ``config.skills`` may be anything :func:`~.registry.action_key` reads
    (an :class:`~tableclean_suite.task.Action`, a paper-order int, a name in any case); the stored
    config has them as registered action names, the keys :func:`skill_overrides` looks up.

    Raises:
        TypeError: ``config`` is not a :class:`RobotSkillConfig`.
        ValueError: the robot is already registered and ``replace`` is False; a skills key that
            is neither :data:`ALL_SKILLS` nor a registered action, or two keys naming the same
            action; an :data:`ALL_SKILLS` key that is not a key of ``BASE_CONFIG`` or its value
            outside the range of :class:`~.configs.SkillConfig`'s field; per-action overrides for an
            action whose skill is registered that it would refuse (unknown keys, values outside its
            ``Config``'s ranges: :class:`~.config_check.SkillConfigError`, a ``ValueError``); an OSC
            override of ``type``, ``input_type`` or ``input_ref_frame``.
    """
    if isinstance(config, RobotSkillConfig):
        unknown = sorted(set(config.skills.get(ALL_SKILLS, {})) - set(BASE_CONFIG))
        if unknown:
            raise ValueError(f"robot {config.robot!r}: keys {unknown} under {ALL_SKILLS!r} are not BASE_CONFIG keys "
                             f"(allowed: {sorted(BASE_CONFIG)}); put skill-specific keys under the action's name")
        SkillConfig(**config.skills.get(ALL_SKILLS, {}))  # its values in range (ValueError naming the field)
        for key, overrides in config.skills.items():
            if key != ALL_SKILLS and key in SKILL_REGISTRY:
                _check_action_overrides(config.robot, SKILL_REGISTRY[key],
                                        {**config.skills.get(ALL_SKILLS, {}), **overrides})
    return add_robot_config(config, replace=replace)
