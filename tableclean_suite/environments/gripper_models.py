"""Corrected models of robosuite grippers whose own models the skills cannot drive.

`CORRECTED` maps robosuite's gripper name to the package's corrected class, mounted in its place when a scene
asks for that gripper ([`mounted_gripper`][tableclean_suite.environments.gripper_models.mounted_gripper]: each class is
added to robosuite's ``GRIPPER_MAPPING`` under its own class name, a new key); robosuite's own classes and its
entries stay as they are.  A corrected class's ``replaces`` names the gripper it stands for (the key of its
per-gripper skill settings, [`GRIPPER_SKILLS`][tableclean_suite.environments.grippers]).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
from robosuite.models.grippers import GRIPPER_MAPPING, Robotiq85Gripper, Robotiq140Gripper

#: MuJoCo solref / solimp of the joint couplings (a stiff, critically damped constraint).
_COUPLING = {"solref": "0.005 1", "solimp": "0.95 0.99 0.001"}


#: The outer knuckles: a corrected model's robosuite gripper ``joints`` (the linkage's followers move with them).
DRIVERS = ("finger_joint", "right_outer_knuckle_joint")


def _make_kinematic(gripper) -> None:
    """Replace ``gripper``'s tendons and equalities by joint equalities ``follower = factor * leader`` for each
    ``(follower, leader, factor)`` of its ``COUPLING`` (robosuite's joint names without the prefix), exclude the
    contacts between any two of its bodies, and keep only `DRIVERS` as its ``joints``."""
    prefix = gripper.naming_prefix
    gripper._joints = [name for name in gripper._joints if name in DRIVERS]  # robosuite keeps them unprefixed
    for parent in (gripper.tendon, gripper.equality):
        for element in list(parent):
            parent.remove(element)
    for follower, leader, factor in gripper.COUPLING:
        ET.SubElement(gripper.equality, "joint", joint1=prefix + follower, joint2=prefix + leader,
                      polycoef=f"0 {factor} 0 0 0", **_COUPLING)
    bodies = [body.get("name") for body in gripper.worldbody.iter("body")]
    for i, first in enumerate(bodies):
        for second in bodies[i + 1:]:
            ET.SubElement(gripper.contact, "exclude", body1=first, body2=second)


class CorrectedRobotiq85Gripper(Robotiq85Gripper):
    """robosuite's Robotiq 2F-85 with its four-bar finger linkage closed and its self-contacts removed.

    What changes against robosuite's model (why, with the measurements: the physics-and-fidelity docs page):

    - the linkage: joint equalities (`COUPLING`) in place of robosuite's soft tendon: inner knuckle = outer
      knuckle, inner finger = -outer knuckle (the pad stays parallel), right outer knuckle = left;
    - contacts between any two of the gripper's bodies excluded (their meshes overlap);
    - every linkage joint limited to [0, `CLOSED`] rad (inner fingers [-`CLOSED`, 0]) with stiff limits, damping
      0.1 N m s/rad and armature 0.005 kg m^2; ``init_qpos`` open;
    - the actuators limited to `MAX_TORQUE` (about 24 N per finger on the sponge, the Panda hand's is 20 N);
    - the finger geoms resist twisting (``condim`` 4, as the Panda's fingers);
    - its ``joints`` (robosuite's gripper joints) are the two outer knuckles, `DRIVERS`; the followers move
      with them.
    """

    replaces = "Robotiq85Gripper"
    #: (follower, leader, factor): the follower joint's angle is factor times the leader's, robosuite's names.
    COUPLING = (("left_inner_knuckle_joint", "finger_joint", 1), ("left_inner_finger_joint", "finger_joint", -1),
                ("right_inner_knuckle_joint", "right_outer_knuckle_joint", 1),
                ("right_inner_finger_joint", "right_outer_knuckle_joint", -1),
                ("right_outer_knuckle_joint", "finger_joint", 1))
    #: rad, the closed end of every linkage joint's range (robosuite's ``ctrlrange`` top).
    CLOSED = 0.8
    #: N m, the most each finger's actuator exerts.
    MAX_TORQUE = 1.5

    def __init__(self, idn=0):
        super().__init__(idn=idn)
        prefix = self.naming_prefix
        _make_kinematic(self)
        closing = {**{name: 1 for name in DRIVERS}, **{follower: factor for follower, _, factor in self.COUPLING}}
        for joint in self.worldbody.iter("joint"):
            if joint.get("name")[len(prefix):] in closing:  # the closing direction's side of zero
                low, high = sorted((0, closing[joint.get("name")[len(prefix):]] * self.CLOSED))
                joint.attrib.update(limited="true", range=f"{low} {high}", damping="0.1", armature="0.005",
                                    solreflimit=_COUPLING["solref"], solimplimit=_COUPLING["solimp"])
        fingers = {prefix + name for side in ("left_finger", "right_finger") for name in self._important_geoms[side]}
        for geom in self.worldbody.iter("geom"):
            if geom.get("name") in fingers:
                geom.set("condim", "4")
        for actuator in self.actuator:
            actuator.attrib.update(ctrlrange=f"0 {self.CLOSED}", forcelimited="true",
                                   forcerange=f"{-self.MAX_TORQUE} {self.MAX_TORQUE}")

    @property
    def init_qpos(self):
        """(2,) rad: the outer knuckles open."""
        return np.zeros(2)


class CorrectedRobotiq140Gripper(Robotiq140Gripper):
    """robosuite's Robotiq 2F-140 with its finger linkage coupled as the parallel gripper it is and its self-contacts
    removed; geometry, masses, actuators (position, kp 20 N m/rad) and the action mapping are robosuite's.

    What changes (why, with the measurements: the physics-and-fidelity docs page):

    - the coupling: joint equalities (`COUPLING`) in place of robosuite's tendon equalities, which the linkage's
      own contacts contradict: each inner finger turns with its outer knuckle (the pad stays parallel over the
      stroke) and each inner knuckle follows it;
    - contacts between any two of the gripper's bodies excluded;
    - the stroke: the outer knuckles (its ``joints`` here, `DRIVERS`) open to `OPEN` rad, not 0 (pads 8.5 cm
      apart, as the Panda hand's 8 cm, not 12.6 cm); the right outer knuckle's range is its actuator's;
      ``init_qpos`` is the open end.
    """

    replaces = "Robotiq140Gripper"
    #: (follower, leader, factor): the follower joint's angle is factor times the leader's, robosuite's names.
    COUPLING = (("left_inner_finger_joint", "finger_joint", 1.0), ("left_inner_knuckle_joint", "finger_joint", -1.0),
                ("right_inner_finger_joint", "right_outer_knuckle_joint", -1.0),
                ("right_inner_knuckle_joint", "right_outer_knuckle_joint", 1.0))
    #: rad, the outer knuckles' open and closed ends (robosuite's: 0 and 0.7; the right knuckle's negated).
    OPEN, CLOSED = 0.25, 0.7

    def __init__(self, idn=0):
        super().__init__(idn=idn)
        prefix = self.naming_prefix
        _make_kinematic(self)
        ranges = {"finger_joint": f"{self.OPEN} {self.CLOSED}",  # the right knuckle closes the other way
                  "right_outer_knuckle_joint": f"{-self.CLOSED} {-self.OPEN}"}
        for joint in self.worldbody.iter("joint"):
            joint.set("range", ranges.get(joint.get("name")[len(prefix):], joint.get("range")))
        for actuator in self.actuator:
            actuator.set("ctrlrange", ranges[actuator.get("joint")[len(prefix):]])

    @property
    def init_qpos(self):
        """(2,) rad: the outer knuckles open."""
        return np.array([self.OPEN, -self.OPEN])


#: robosuite's gripper name -> the package's corrected class mounted in its place.
CORRECTED = {cls.replaces: cls for cls in (CorrectedRobotiq85Gripper, CorrectedRobotiq140Gripper)}
for _corrected in CORRECTED.values():
    GRIPPER_MAPPING.setdefault(_corrected.__name__, _corrected)


def mounted_gripper(name):
    """The ``GRIPPER_MAPPING`` key the scene mounts for ``gripper_types`` entry ``name``: its corrected class's name
    when `CORRECTED` has one, else ``name`` unchanged."""
    corrected = CORRECTED.get(name) if isinstance(name, str) else None
    return name if corrected is None else corrected.__name__
