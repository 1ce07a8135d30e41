"""Skills that turn task-level actions into OSC motions, and the SkillController that runs them.

Make the environment with [`make_skill_env`][tableclean_suite.controllers.make.make_skill_env] (or pass [`skill_controller_config`][tableclean_suite.controllers.osc.skill_controller_config]
as ``controller_configs`` and ``ignore_done=True`` to ``robosuite.make``), then:

    env = make_skill_env(object_segment=1, arm_segment=1)
    controller = SkillController(env)
    result = controller.execute(Action.PICK)   # -> SkillResult

Add or replace skills with [`register_skill`][tableclean_suite.controllers.registry.register_skill] (see [`registry`][tableclean_suite.controllers.registry]); skills are built from the
primitives of [`primitives`][tableclean_suite.controllers.primitives] (reach, grasp, release, wipe).  A new action's skill is a short
list of those steps with targets named by meaning ([`compose_skill`][tableclean_suite.controllers.authoring.compose_skill], [`authoring`][tableclean_suite.controllers.authoring]).
"""

from tableclean_suite.controllers.clean import CleanPhase, CleanSkill, Wipe
from tableclean_suite.controllers.make import make_skill_env
from tableclean_suite.controllers.move import MovePhase, MoveSkill
from tableclean_suite.controllers.osc import check_skill_env, skill_command_limits, skill_controller_config
from tableclean_suite.controllers.pick import PickPhase, PickSkill
from tableclean_suite.controllers.place import PlacePhase, PlaceSkill
from tableclean_suite.controllers.primitives import Body, Grasp, Primitive, PrimitiveSkill, Reach, Release
from tableclean_suite.controllers.registry import SKILL_REGISTRY, action_key, get_skill_class, register_skill
from tableclean_suite.controllers.skill import BASE_CONFIG, Skill, SkillEnv, SkillFailure, Waypoint
from tableclean_suite.controllers.skill_controller import SkillController, SkillResult
from tableclean_suite.controllers.authoring import compose_skill

for _skill in (MoveSkill, PickSkill, PlaceSkill, CleanSkill):
    register_skill(_skill.action, _skill, replace=True)

__all__ = [
    "BASE_CONFIG",
    "Body",
    "Grasp",
    "Primitive",
    "PrimitiveSkill",
    "Reach",
    "Release",
    "SkillEnv",
    "Wipe",
    "action_key",
    "CleanPhase",
    "CleanSkill",
    "MovePhase",
    "MoveSkill",
    "PickPhase",
    "PickSkill",
    "PlacePhase",
    "PlaceSkill",
    "SKILL_REGISTRY",
    "Skill",
    "SkillController",
    "SkillFailure",
    "SkillResult",
    "Waypoint",
    "check_skill_env",
    "compose_skill",
    "get_skill_class",
    "make_skill_env",
    "register_skill",
    "skill_command_limits",
    "skill_controller_config",
]
