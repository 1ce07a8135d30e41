"""Make a TableClean environment set up for the skills (absolute world-frame OSC, no episode end)."""

from __future__ import annotations

import robosuite
from robosuite.environments.base import MujocoEnv

import tableclean_suite  # noqa: F401  (registers TableClean with robosuite)
from tableclean_suite.controllers.fast_control import attach_fast_stepper
from tableclean_suite.controllers.osc import skill_controller_config
from tableclean_suite.controllers.robot_configs import check_robot
from tableclean_suite.environments.table_clean import FROM_SPEC

#: Settings the skills rely on, or that only cost time when running skills headless.
SKILL_ENV_DEFAULTS = {
    "robots": "Panda",
    "ignore_done": True,  # a skill never runs into robosuite's horizon
    "has_renderer": False,
    "has_offscreen_renderer": False,
    "use_camera_obs": False,
    "hard_reset": False,  # resets keep the compiled model (several times faster)
}


#: Start layout ``(object_segment, arm_segment)`` when neither a layout nor ``task`` is given (1-based).
DEFAULT_LAYOUT = (1, 1)


def make_skill_env(object_segment: int | None = FROM_SPEC, arm_segment: int | None = FROM_SPEC,
                   fast_control: bool = True, **kwargs):
    """``robosuite.make("TableClean", ...)`` with `SKILL_ENV_DEFAULTS` and the skills' controller.

    The controller config is [`skill_controller_config`][tableclean_suite.controllers.osc.skill_controller_config] of the robot in ``robots``
    (default ``"Panda"``; robosuite's default config of that robot, arm switched to absolute
    world-frame OSC_POSE, input ranges those of the scene of ``task_config``), unless
    ``controller_configs`` is given.

    Args:
        object_segment, arm_segment: start layout (1..N; ``None``: random at each reset).  When
            neither is given (nor ``object_segments`` / ``dirty_segments``), the scene starts where
            ``task``'s spec says (its fixed ``start_state`` or a ``uniform_unclean`` draw at each
            reset, see [`TableClean`][tableclean_suite.environments.table_clean.TableClean]); without
            ``task``, at `DEFAULT_LAYOUT`.
        fast_control: give the env a [`FastSkillStepper`][tableclean_suite.controllers.fast_control.FastSkillStepper]
            (``env.fast_stepper``): the SkillController then runs robosuite's control law in compiled
            code (several times faster than ``env.step``, same trajectories); ``False``: ``env.step``.
        **kwargs: any other TableClean/robosuite argument; overrides the defaults.

    Raises:
        ValueError: ``robots`` names more than one robot (the scene has one arm), or a robot without
            a registered skill config (the message lists the supported ones,
            [`supported_robots`][tableclean_suite.environments.robot_registry.supported_robots]); checked before
            anything is built.
        NotImplementedError: ``fast_control`` with controllers the fast path does not reproduce
            (e.g. custom ``controller_configs``); pass ``fast_control=False``.
    """
    options = {**SKILL_ENV_DEFAULTS, **kwargs}
    robot = check_robot(options["robots"])
    if "controller_configs" not in kwargs:
        options["controller_configs"] = skill_controller_config(robot, options.get("task_config"))
    layout_given = any(options.get(key, FROM_SPEC) is not FROM_SPEC for key in ("object_segments", "dirty_segments"))
    layout_given = layout_given or object_segment is not FROM_SPEC or arm_segment is not FROM_SPEC
    if options.get("task") is None and not layout_given:
        object_segment, arm_segment = DEFAULT_LAYOUT
    env = robosuite.make("TableClean", object_segment=object_segment, arm_segment=arm_segment, **options)
    if fast_control and isinstance(env, MujocoEnv):  # anything else (a test double) is returned as made
        attach_fast_stepper(env)
    return env

