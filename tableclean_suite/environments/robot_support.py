"""The one scene fix some arms need: robot bodies that must not collide with their parent.

MuJoCo skips contacts between a body and its parent body, except when the parent is welded to
the world.  A fixed-base arm's first link is the child of its world-welded base, so that pair
collides: Sawyer's ``right_l0`` presses on its base link once joint 0 turns ~0.5 rad (the OSC
then stalls 3.7 cm short of a waypoint over segment 2 while the contact absorbs ~50 N m at
joint 0).  Excluding every robot parent-child pair restores MuJoCo's usual parent filtering for
those pairs too; for all other pairs it changes nothing (MuJoCo filters them already).

Which arms the scene builds, the gripper it mounts and where it puts the base come from the robot
registry ([robot_registry][tableclean_suite.environments.robot_registry]).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET


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
