"""Robot bodies that must not collide with their parent: MuJoCo skips parent-child contacts except when the parent
is welded to the world, so a fixed-base arm's first link collides with its base (Sawyer's stalls the OSC)."""

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
