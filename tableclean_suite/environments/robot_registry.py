"""The robot registry (a leaf module): per-robot skill configuration, what differs between the arms.

The skills are written once (`skill`, `primitives`, ...) against named constants
(each skill's ``DEFAULT_CONFIG``, extending `BASE_CONFIG`) and the OSC settings
of `OSC_OVERRIDES`.  An arm with another gripper, other dynamics or another
reach needs other values for some of them (finger geometry, gripper settling rule, OSC gains,
step budgets).  Those values live here, in a registry ``robot name -> RobotSkillConfig``, and
nowhere in the skill code:

- `SkillController` merges [`skill_overrides`][tableclean_suite.environments.robot_registry.skill_overrides] of the env's robot
  under the caller's own ``skill_configs`` for every skill it runs;
- `skill_controller_config` merges [`osc_overrides`][tableclean_suite.environments.robot_registry.osc_overrides] of the robot over
  `OSC_OVERRIDES`;
- [`TableClean`][tableclean_suite.environments.table_clean.TableClean] and
  `make_skill_env` refuse a robot that is not registered here
  ([`check_robot`][tableclean_suite.environments.robot_registry.check_robot]: a ``ValueError`` naming [`supported_robots`][tableclean_suite.environments.robot_registry.supported_robots]), and the scene mounts
  the config's ``gripper`` and moves the base by its ``base_shift``.

Shipped: Panda (the reference), Sawyer, UR5e and Kinova3.  The three others carry robosuite's
Panda gripper unless ``gripper_types`` names another the skills drive (the Sawyer's Rethink, on any
arm: [`grippers`][tableclean_suite.environments.grippers]; see `SWAP_GRIPPER`).  The windowed and
timeout settling rules of
`gripper_settled` (``gripper_window``, ``gripper_drift``,
``gripper_timeout``) are for grippers whose fingers never stop, such as the Robotiq 85.

Users add an arm with
[register_robot_config][tableclean_suite.controllers.robot_configs.register_robot_config], which
checks the config against the skills before storing it in `ROBOT_CONFIGS`.

This module imports neither robosuite nor MuJoCo nor the rest of the package (but the leaf list of
grippers): the scene and the controllers both read it, and it reads neither.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

from tableclean_suite.environments.grippers import check_gripper

#: Key of `RobotSkillConfig.skills` whose overrides apply to every skill (keys of ``BASE_CONFIG``).
ALL_SKILLS = "*"


@dataclass(frozen=True)
class RobotSkillConfig:
    """How the skills run on one robosuite robot.

    Attributes:
        robot: robosuite's robot name (``robosuite.ALL_ROBOTS``), e.g. ``"UR5e"``.
        skills: config overrides per skill: key `ALL_SKILLS` (``"*"``) for every skill (its
            keys must be keys of `BASE_CONFIG`, checked at registration), or a
            registered action name (``"move"``, ``"pick"``, ``"place"``, ``"clean"``, ...) for that
            action's skill (keys checked by the skill when it is built).  Units as in the skills'
            ``DEFAULT_CONFIG``.
        osc: overrides of the arm controller's config on top of `OSC_OVERRIDES`
            (robosuite OSC keys, e.g. ``{"kp": 300}``); may not change what the skills rely on
            (``type``, ``input_type``, ``input_ref_frame``).
        gripper: robosuite's name of the gripper the scene mounts when the env is made with
            ``gripper_types="default"`` (None: the robot's own default gripper); for arms whose own
            gripper cannot do the task (see `SWAP_GRIPPER`).  An explicit ``gripper_types``
            wins.
        base_shift: (3,) m added to robosuite's table-side base position of the robot (its
            ``base_xpos_offset["table"]``), for an arm whose reach does not cover the scene from there.
        note: why these values (measurements), for the reader.
    """

    robot: str
    skills: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    osc: Mapping[str, Any] = field(default_factory=dict)
    gripper: str | None = None
    base_shift: tuple[float, float, float] = (0.0, 0.0, 0.0)
    note: str = ""


#: The OSC settings the skills rely on; a robot config may not override them.
FIXED_OSC_KEYS = ("type", "input_type", "input_ref_frame")


def supported_robots() -> tuple[str, ...]:
    """Names of the robots with a registered skill config, sorted."""
    return tuple(sorted(ROBOT_CONFIGS))


def robot_name(robots) -> str:
    """The one robot name in ``robots`` (a name, or a one-element list/tuple of names).

    Raises ``ValueError`` naming the value when it is not exactly one name (the scene has one arm).
    """
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


def skill_overrides(robot: str, action_name: str) -> dict[str, Any]:
    """Config overrides of ``robot`` for the skill of ``action_name``: its ``"*"`` entries, then the action's.

    An unregistered robot has none (``{}``): a test double or a user's env keeps the skills' defaults.
    """
    config = ROBOT_CONFIGS.get(robot)
    if config is None:
        return {}
    return {**config.skills.get(ALL_SKILLS, {}), **config.skills.get(action_name, {})}


def scene_gripper_types(robot: str, gripper_types):
    """``gripper_types`` for the env: the robot config's `gripper` in place of ``"default"``; ``ValueError``
    naming a gripper the skills cannot drive ([`check_gripper`][tableclean_suite.environments.grippers.check_gripper])."""
    config = ROBOT_CONFIGS.get(robot)
    if isinstance(gripper_types, (list, tuple)) and len(gripper_types) == 1:
        gripper_types = gripper_types[0]
    if gripper_types == "default" and config is not None and config.gripper is not None:
        gripper_types = config.gripper
    return gripper_types if gripper_types == "default" else check_gripper(gripper_types, robot)


def base_shift(robot: str) -> tuple[float, float, float]:
    """(3,) m the scene moves ``robot``'s base from robosuite's table-side position; zeros if unregistered."""
    config = ROBOT_CONFIGS.get(robot)
    return tuple(config.base_shift) if config is not None else (0.0, 0.0, 0.0)


def osc_overrides(robot: str) -> dict[str, Any]:
    """OSC config overrides of ``robot`` (on top of `OSC_OVERRIDES`); ``{}`` if unregistered."""
    config = ROBOT_CONFIGS.get(robot)
    return dict(config.osc) if config is not None else {}


# ---------------------------------------------------------------------------------------------
# the arms robosuite 1.5 ships that the skills are tuned for
# ---------------------------------------------------------------------------------------------

#: robosuite's gripper the scene mounts by default on the three other arms: robosuite's Robotiq 85 (UR5e's and
#: Kinova3's own) collides with itself and stops 6.2 cm open, wider than the sponge's 5 cm side (excluding those
#: self-contacts makes its linkage diverge); the Sawyer keeps the gripper its earlier measurements were made
#: with, its own Rethink is mounted with ``gripper_types="RethinkGripper"``.
SWAP_GRIPPER = "PandaGripper"

#: Sawyer's Rethink gripper holds the 5 cm sponge with ~8.5 N per finger (the Panda gripper: 20 N), too
#: little to keep it from slipping out while it is dragged pressed on the table.
_SAWYER = RobotSkillConfig(
    "Sawyer", gripper=SWAP_GRIPPER,
    # m/s: the clean's grasp descends only once the hand is this still: arriving, the hand swings ~1 cm on along
    # the fingers' closing axis, and the Rethink's fingertip lands on the sponge and rolls it onto its side
    # (then lost while wiping: 1 of 10 paper episodes from random starts; 10 of 10 with this)
    skills={"clean": {"hover_still_speed": 0.05}},
    note="Panda gripper by default (the Rethink gripper with gripper_types='RethinkGripper'); the scene excludes the "
         "contact between the base and the first link (environments.robot_support), which otherwise stalls the OSC "
         "3.7 cm short over segment 2",
)
_KINOVA3 = RobotSkillConfig(
    "Kinova3", gripper=SWAP_GRIPPER,
    # stiffness (1/s^2; the skills' default 300): at 300 the pressed sponge twists in the hand while wiping
    osc={"kp": 450},
    # m: from robosuite's table-side position the far row of three_segments_two_objects (x up to 0.2 m) lies at
    # the edge of the arm's 0.9 m reach, where a carried object's lift stalls with the elbow straight
    base_shift=(0.08, 0.0, 0.0),
    # m/s: the clean's grasp descends only once the hand is this still (arriving at 0.24 m/s it swings on
    # 1.7 cm past its hover point and a finger can tip the sponge)
    skills={"clean": {"hover_still_speed": 0.05}},
    note="Panda gripper instead of the Robotiq 85; stiffer OSC; base 8 cm closer to the table",
)

#: The registry: robot name -> its config (add with
#: [register_robot_config][tableclean_suite.controllers.robot_configs.register_robot_config]).
ROBOT_CONFIGS: dict[str, RobotSkillConfig] = {config.robot: config for config in (
    RobotSkillConfig("Panda", note="the reference arm: the skills' DEFAULT_CONFIGs and OSC_OVERRIDES were tuned on it"),
    _SAWYER,
    RobotSkillConfig("UR5e", gripper=SWAP_GRIPPER, note="Panda gripper instead of the Robotiq 85"),
    _KINOVA3,
)}
