"""Which arms the TableClean scene builds, and the one scene fix some of them need.

- :func:`check_scene_robot`: the scene and its skills are tuned per robot
  (the robot registry, :mod:`.robot_registry`); a robot without a registered config is
  refused before robosuite builds anything, with a ``ValueError`` listing the supported ones
  (rather than a MuJoCo name lookup error deep inside the build, e.g. XArm7's gripper has no
  finger-pad geoms for the grasp check).
- :func:`exclude_parent_contacts`: MuJoCo skips contacts between a body and its parent body,
  except when the parent is welded to the world.  A fixed-base arm's first link is the child of
  its world-welded base, so that pair collides: Sawyer's ``right_l0`` presses on its base link
  once joint 0 turns ~0.5 rad (measured: the OSC then stalls 3.7 cm short of a waypoint over
  segment 2 while the contact absorbs ~50 N m at joint 0).  Excluding every robot
  parent-child pair restores MuJoCo's usual parent filtering for those pairs too; for all other
  pairs it changes nothing (MuJoCo filters them already).
- :func:`scene_gripper`: the gripper the robot's config mounts in place of robosuite's default.
- :func:`scene_base_shift`: how far the robot's config moves its base from robosuite's table-side position.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from tableclean_suite.environments.robot_registry import base_shift, check_robot, scene_gripper_types


def check_scene_robot(robots) -> str:
    """The robot name of ``robots`` when the scene supports it; ``ValueError`` naming the supported ones otherwise."""
    return check_robot(robots)


def scene_gripper(robot: str, gripper_types):
    """``gripper_types`` with ``"default"`` replaced by the robot config's gripper, if it names one."""
    return scene_gripper_types(robot, gripper_types)


def scene_base_shift(robot: str) -> tuple[float, float, float]:
    """(3,) m added to the robot's table-side base position (its config's ``base_shift``)."""
    return base_shift(robot)


def exclude_parent_contacts(robot_model) -> int:
    """Add ``<exclude>`` contact pairs for every parent-child body pair of ``robot_model`` (robosuite MJCF model).

    Call before the robot model is merged into the task model (its ``<contact>`` is merged with it).
    Returns the number of pairs added.
    """
    added = 0
    for parent in robot_model.worldbody.iter("body"):
        for child in parent.findall("body"):
            first, second = parent.get("name"), child.get("name")
            if first and second:
                robot_model.contact.append(ET.Element("exclude", attrib={"body1": first, "body2": second}))
                added += 1
    return added
