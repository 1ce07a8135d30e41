"""Which of robosuite's grippers the skills drive, with what settings; the others are refused by name before anything
is built.

The skills need two finger pads closing on a line (the gripper's ``important_geoms``
``left_fingerpad`` and ``right_fingerpad``, measured by
[`measure_gripper`][tableclean_suite.environments.gripper_geometry.measure_gripper]) that stop
once they hold: robosuite's Panda and Rethink grippers and the Robotiq 2F-85 and 2F-140, whose linkages the scene mounts
corrected ([`gripper_models`][tableclean_suite.environments.gripper_models]) (`SUPPORTED`).  `REFUSED` names the
others and why.  `GRIPPER_SKILLS` holds a gripper's skill-config overrides, applied after the robot's.
"""

from __future__ import annotations

#: robosuite's names of the grippers the skills drive (``gripper_types=``).
SUPPORTED = ("PandaGripper", "RethinkGripper", "Robotiq85Gripper", "Robotiq140Gripper")
_HAND = "a three-finger hand: the skills close two pads on a line"
#: robosuite's grippers refused, with the defect (robosuite's others: not a two-finger gripper the skills drive).
REFUSED = {
    "JacoThreeFingerGripper": _HAND,
    "JacoThreeFingerDexterousGripper": _HAND,
    "RobotiqThreeFingerGripper": _HAND,
    "RobotiqThreeFingerDexterousGripper": _HAND,
    "WipingGripper": "a wiping tool without fingers: it cannot hold the sponge or an object",
}


#: robosuite's gripper name -> skill-config overrides: key ``"*"`` for every skill (keys of ``BASE_CONFIG``), or an
#: action name for that action's skill; merged after the robot's
#: ([`skill_overrides`][tableclean_suite.environments.robot_registry.skill_overrides]).
GRIPPER_SKILLS: dict[str, dict[str, dict]] = {
    # fingertip_depth [m]: how far its closed fingertips reach below the grip site; descend_speed [m/s]: a place
    # comes down slowly, its inner finger reaching 3.4 cm out along the closing axis
    "Robotiq85Gripper": {"*": {"fingertip_depth": 0.018}, "place": {"descend_speed": 0.1}},
    # carry_clearance [m]: a carried box and a fingertip clear a lying neighbour as the hand sets off
    "Robotiq140Gripper": {"*": {"fingertip_depth": 0.027, "carry_clearance": 0.02}},
}


def gripper_name(robot) -> str | None:
    """robosuite's name of the gripper robosuite robot ``robot`` carries (a corrected model's: the gripper it
    replaces); None when it has none."""
    grippers = getattr(robot, "gripper", None)
    if not isinstance(grippers, dict) or not grippers:
        return None
    kind = type(next(iter(grippers.values())))
    return getattr(kind, "replaces", kind.__name__)


def check_gripper(name, robot: str):
    """``name`` (robosuite's ``gripper_types`` entry for ``robot``) if the skills drive that gripper, or if it is a
    user's gripper registered with robosuite (``register_gripper``; its pads and finger joints are checked when
    the scene measures it); else a one-line ``ValueError`` naming it, why, and the supported grippers."""
    from robosuite.models.grippers import GRIPPER_MAPPING

    kind = GRIPPER_MAPPING.get(name) if isinstance(name, str) else None
    if name in SUPPORTED or (kind is not None and name not in REFUSED and not kind.__module__.startswith("robosuite.")):
        return name
    why = REFUSED.get(name, "not a two-finger gripper the skills drive" if kind is not None or name is None
                      else "not a gripper robosuite knows")
    raise ValueError(f"gripper {name!r} on {robot} is not supported by the TableClean skills ({why}); supported "
                     f"grippers: {', '.join(SUPPORTED)}")
