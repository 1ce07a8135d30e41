"""The robot registry (a leaf module): robot name ->
[RobotSkillConfig][tableclean_suite.environments.robot_registry.RobotSkillConfig], what the skills and the scene do
differently per arm (skill and OSC overrides, gripper, base position).

The skill controller merges [`skill_overrides`][tableclean_suite.environments.robot_registry.skill_overrides] under the caller's
``skill_configs``, the controller config merges [`osc_overrides`][tableclean_suite.environments.robot_registry.osc_overrides], and the scene and
``make_skill_env`` refuse an unregistered robot ([`check_robot`][tableclean_suite.environments.robot_registry.check_robot]).  Shipped: Panda (the
reference), Sawyer, UR5e and Kinova3 (the three others carry the Panda gripper unless ``gripper_types`` names
another the skills drive).  Users add an arm with
[register_robot_config][tableclean_suite.controllers.robot_configs.register_robot_config].
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

from tableclean_suite.environments.grippers import GRIPPER_SKILLS, check_gripper

#: Key of `RobotSkillConfig.skills` whose overrides apply to every skill (keys of ``BASE_CONFIG``).
ALL_SKILLS = "*"


@dataclass(frozen=True)
class RobotSkillConfig:
    """How the skills run on one robosuite robot.

    Attributes:
        robot: robosuite's robot name (``robosuite.ALL_ROBOTS``), e.g. ``"UR5e"``.
        skills: config overrides per skill: key `ALL_SKILLS` (``"*"``) for every skill (keys of
            ``BASE_CONFIG``), or an action name (``"move"``, ``"clean"``, ...) for that action's skill.
        osc: overrides of the arm's OSC config (e.g. ``{"kp": 300}``); not ``type``, ``input_type``
            or ``input_ref_frame``.
        gripper: the gripper mounted with ``gripper_types="default"`` (None: the robot's own).
        base_shift: (3,) m added to robosuite's table-side base position of the robot.
        note: why these values, for the reader.
    """

    robot: str
    skills: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    osc: Mapping[str, Any] = field(default_factory=dict)
    gripper: str | None = None
    base_shift: tuple[float, float, float] = (0.0, 0.0, 0.0)
    note: str = ""


def supported_robots() -> tuple[str, ...]:
    """Names of the robots with a registered skill config, sorted."""
    return tuple(sorted(ROBOT_CONFIGS))


def robot_name(robots) -> str:
    """The one robot name in ``robots`` (a name or a one-element list/tuple); else ``ValueError`` naming it."""
    if isinstance(robots, str):
        return robots
    names = list(robots) if isinstance(robots, (list, tuple)) else []
    if len(names) != 1 or not isinstance(names[0], str):
        raise ValueError(f"robots must name one robot (the TableClean scene has one arm), got {robots!r}; "
                         f"supported: {', '.join(supported_robots())}")
    return names[0]


def check_robot(robots) -> str:
    """The robot name of ``robots`` if it has a registered config; else ``ValueError`` naming the supported ones."""
    name = robot_name(robots)
    if name not in ROBOT_CONFIGS:
        raise ValueError(f"robot {name!r} is not supported by the TableClean scene and skills; supported robots: "
                         f"{', '.join(supported_robots())} (add one with "
                         f"tableclean_suite.controllers.robot_configs.register_robot_config)")
    return name


def skill_overrides(robot: str, action_name: str, gripper: str | None = None) -> dict[str, Any]:
    """Config overrides of ``robot`` for the skill of ``action_name``: its ``"*"`` entries, then the action's
    (none for an unregistered robot), then those of ``gripper`` (robosuite's gripper name,
    [`GRIPPER_SKILLS`][tableclean_suite.environments.grippers]) the same way."""
    config = ROBOT_CONFIGS.get(robot)
    robots = {} if config is None else config.skills
    grippers = GRIPPER_SKILLS.get(gripper, {})
    return {**robots.get(ALL_SKILLS, {}), **robots.get(action_name, {}),
            **grippers.get(ALL_SKILLS, {}), **grippers.get(action_name, {})}


def scene_gripper_types(robot: str, gripper_types):
    """``gripper_types`` for the env: the robot config's `gripper` in place of ``"default"``, a corrected model's
    name in place of the gripper it corrects
    ([`mounted_gripper`][tableclean_suite.environments.gripper_models.mounted_gripper]); ``ValueError`` naming a
    gripper the skills cannot drive ([`check_gripper`][tableclean_suite.environments.grippers.check_gripper])."""
    config = ROBOT_CONFIGS.get(robot)
    if isinstance(gripper_types, (list, tuple)) and len(gripper_types) == 1:
        gripper_types = gripper_types[0]
    if gripper_types == "default" and config is not None and config.gripper is not None:
        gripper_types = config.gripper
    if gripper_types == "default":
        return gripper_types
    from tableclean_suite.environments.gripper_models import mounted_gripper  # imports robosuite's grippers

    return mounted_gripper(check_gripper(gripper_types, robot))


def base_shift(robot: str) -> tuple[float, float, float]:
    """(3,) m the scene moves ``robot``'s base from robosuite's table-side position; zeros if unregistered."""
    config = ROBOT_CONFIGS.get(robot)
    return tuple(config.base_shift) if config is not None else (0.0, 0.0, 0.0)


def osc_overrides(robot: str) -> dict[str, Any]:
    """OSC config overrides of ``robot`` (on top of `OSC_OVERRIDES`); ``{}`` if unregistered."""
    config = ROBOT_CONFIGS.get(robot)
    return dict(config.osc) if config is not None else {}


#: The gripper the three other arms mount by default: the hand the skills' defaults were tuned on, so every
#: arm's default rows compare arms, not grippers (their own: ``gripper_types="RethinkGripper"`` or
#: ``"Robotiq85Gripper"``).
SWAP_GRIPPER = "PandaGripper"

_SAWYER = RobotSkillConfig(
    "Sawyer", gripper=SWAP_GRIPPER,
    # m/s: the clean's grasp descends only once the hand is this still (else a fingertip can roll the sponge over)
    skills={"clean": {"hover_still_speed": 0.05}},
    note="Panda gripper by default (its own: gripper_types='RethinkGripper'); the scene excludes the contact "
         "between its base and first link",
)
_KINOVA3 = RobotSkillConfig(
    "Kinova3", gripper=SWAP_GRIPPER,
    osc={"kp": 450},  # stiffness (the skills' default 300): at 300 the pressed sponge twists in the hand
    base_shift=(0.08, 0.0, 0.0),  # m: else the far row of three_segments_two_objects lies at the edge of its reach
    skills={"clean": {"hover_still_speed": 0.05}},
    note="Panda gripper by default (its own: gripper_types='Robotiq85Gripper'); stiffer OSC; base 8 cm closer",
)

#: The registry: robot name -> its config (add with
#: [register_robot_config][tableclean_suite.controllers.robot_configs.register_robot_config]).
ROBOT_CONFIGS: dict[str, RobotSkillConfig] = {config.robot: config for config in (
    RobotSkillConfig("Panda", note="the reference arm: the skills' DEFAULT_CONFIGs and OSC_OVERRIDES were tuned on it"),
    _SAWYER,
    RobotSkillConfig("UR5e", gripper=SWAP_GRIPPER,
                     note="Panda gripper by default (its own Robotiq 85 with gripper_types='Robotiq85Gripper')"),
    _KINOVA3,
)}
