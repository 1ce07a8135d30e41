"""Make a TableClean environment set up for the skills (absolute world-frame OSC, no episode end)."""

from __future__ import annotations

import robosuite

import tableclean_suite  # noqa: F401  (registers TableClean with robosuite)
from tableclean_suite.controllers.osc import skill_controller_config

#: Settings the skills rely on, or that only cost time when running skills headless.
SKILL_ENV_DEFAULTS = {
    "robots": "Panda",
    "ignore_done": True,  # a skill never runs into robosuite's horizon
    "has_renderer": False,
    "has_offscreen_renderer": False,
    "use_camera_obs": False,
    "hard_reset": False,  # resets keep the compiled model (several times faster)
}


def make_skill_env(object_segment: int | None = 1, arm_segment: int | None = 1, **kwargs):
    """``robosuite.make("TableClean", ...)`` with :func:`skill_controller_config` and :data:`SKILL_ENV_DEFAULTS`.

    Args:
        object_segment, arm_segment: start layout (1 or 2; ``None``: random at each reset).
        **kwargs: any other TableClean/robosuite argument; overrides the defaults.
    """
    options = {**SKILL_ENV_DEFAULTS, "controller_configs": skill_controller_config(), **kwargs}
    return robosuite.make("TableClean", object_segment=object_segment, arm_segment=arm_segment, **options)
