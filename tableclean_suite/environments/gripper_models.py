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


def _make_kinematic(gripper, coupling) -> None:
    """Replace ``gripper``'s tendons and equalities by joint equalities ``follower = factor * leader`` for each
    ``(follower, leader, factor)`` of ``coupling`` (robosuite's joint names without the prefix), and exclude the
    contacts between any two of its bodies."""
    prefix = gripper.naming_prefix
    for parent in (gripper.tendon, gripper.equality):
        for element in list(parent):
            parent.remove(element)
    for follower, leader, factor in coupling:
        ET.SubElement(gripper.equality, "joint", joint1=prefix + follower, joint2=prefix + leader,
                      polycoef=f"0 {factor} 0 0 0", **_COUPLING)
    bodies = [body.get("name") for body in gripper.worldbody.iter("body")]
    for i, first in enumerate(bodies):
        for second in bodies[i + 1:]:
            ET.SubElement(gripper.contact, "exclude", body1=first, body2=second)


class CorrectedRobotiq85Gripper(Robotiq85Gripper):
    """robosuite's Robotiq 2F-85 with its four-bar finger linkage closed and its self-contacts removed.

    Corrected, each against what robosuite's model does (measured with the hand pointing down, closing
    at 20 Hz control, 2 ms physics steps):

    - The linkage: robosuite ties each finger's outer knuckle, inner knuckle and inner finger only by a soft
      tendon (stiffness 0.4), so the links fall apart under load: open, a knuckle sits at -0.23 rad, out of its
      [0, 0.876] range; closing on the 5 cm sponge the joints run to 2.4 rad and the sponge is thrown out.
      Here joint equalities make it the parallel gripper it is: inner knuckle = outer knuckle, inner finger =
      -outer knuckle (the pad stays parallel), right outer knuckle = left; the tendons go.
    - Self-contact: the inner knuckle's mesh overlaps the inner finger's and outer knuckle's, which press on each
      other with 58 N open and 110 N closed and keep the fingers moving (they never settle).  Contacts between
      any two of the gripper's bodies are excluded (the linkage is kinematic now): 0 N open and closed.
    - Ranges: every linkage joint limited to [0, 0.8] rad (inner fingers [-0.8, 0]), as the actuators'
      ``ctrlrange``, with stiff limits (solref 0.005 s; MuJoCo's default let a closing finger run 0.023 rad
      past); ``init_qpos`` open (robosuite's starts out of range).
    - Strength: the position actuators (kp 20 N m/rad) are limited to 1.5 N m, about 24 N per finger on the
      sponge, like the Panda hand's 20 N (unlimited, 136 N per finger squeeze it by 7 mm).
    - Joint damping 0.1 N m s/rad and armature 0.005 kg m^2 on the linkage joints.
    - The finger geoms resist twisting (``condim`` 4, as the Panda's fingers): without it the sponge pinched
      between the narrow pads turned about the closing axis while wiping and went down 3.2 cm off its home
      (2 of 10 UR5e episodes from random starts, and 1 of 1 260 fidelity trials).
    - Its ``joints`` (robosuite's gripper joints: reset, observations, the skills' finger motion, the open width
      measured over their ranges' ends) are the two outer knuckles; the four followers move with them (tried at
      their own range ends they gave a 12.3 cm open width, which the pads never reach).

    Measured closing: pads 8.5 cm apart open, 0.1 cm closed on nothing, 4.8 cm on the 8 x 5 x 3 cm sponge
    (settled in 4 control steps, lifted 10 cm without slipping); no joint leaves its range by over 0.006 rad.
    """

    replaces = "Robotiq85Gripper"
    #: (follower, leader, factor): the follower joint's angle is factor times the leader's, robosuite's names.
    COUPLING = (("left_inner_knuckle_joint", "finger_joint", 1), ("left_inner_finger_joint", "finger_joint", -1),
                ("right_inner_knuckle_joint", "right_outer_knuckle_joint", 1),
                ("right_inner_finger_joint", "right_outer_knuckle_joint", -1),
                ("right_outer_knuckle_joint", "finger_joint", 1))
    #: the outer knuckles, robosuite's gripper ``joints`` here (the followers move with them).
    DRIVERS = ("finger_joint", "right_outer_knuckle_joint")
    #: rad, the closed end of every linkage joint's range (robosuite's ``ctrlrange`` top).
    CLOSED = 0.8
    #: N m, the most each finger's actuator exerts.
    MAX_TORQUE = 1.5

    def __init__(self, idn=0):
        super().__init__(idn=idn)
        prefix = self.naming_prefix
        _make_kinematic(self, self.COUPLING)
        closing = {**{name: 1 for name in self.DRIVERS}, **{follower: factor for follower, _, factor in self.COUPLING}}
        for joint in self.worldbody.iter("joint"):
            if joint.get("name")[len(prefix):] in closing:  # the closing direction's side of zero
                low, high = sorted((0, closing[joint.get("name")[len(prefix):]] * self.CLOSED))
                joint.attrib.update(limited="true", range=f"{low} {high}", damping="0.1", armature="0.005",
                                    solreflimit=_COUPLING["solref"], solimplimit=_COUPLING["solimp"])
        self._joints = [name for name in self._joints if name in self.DRIVERS]  # robosuite keeps them unprefixed
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

    Corrected, each against what robosuite's model does (UR5e, 20 Hz control, 2 ms physics steps):

    - The coupling: robosuite's tendon equalities hold ``finger_joint + 1.5 inner_finger = 0`` and
      ``inner_finger + 3.5 inner_knuckle = 0``, which the linkage's own contacts contradict: closed on the sponge
      the left inner finger sits at +0.5 rad where the coupling wants -0.3, and creeps on for over 100 control
      steps, then jitters by 0.01 rad without end.  Here joint equalities make each inner finger turn with its
      outer knuckle (left ``inner finger = finger_joint``, right ``inner finger = -outer knuckle``: the pad stays
      parallel over the whole stroke) and each inner knuckle follow it; the tendons go.
    - Self-contact: the knuckles press on each other with 15-24 N open and closed (up to 150 N); contacts between
      any two of the gripper's bodies are excluded.
    - Stroke: the outer knuckles (its ``joints`` here, the followers move with them) open to 0.25 rad, not 0: pads
      8.5 cm apart open (the Panda hand's 8 cm), not 12.6 cm; opening fully to release a box, a pad swept a
      neighbour 5.7 cm away off its segment (6 of 100 episodes of three_segments_two_objects, every one placing
      beside a neighbour on segment 1).  The right outer knuckle's range is its actuator's (robosuite's lets it
      open 0.725 rad outwards); ``init_qpos`` is the open end (robosuite's is off its own coupling).
    """

    replaces = "Robotiq140Gripper"
    #: (follower, leader, factor): the follower joint's angle is factor times the leader's, robosuite's names.
    COUPLING = (("left_inner_finger_joint", "finger_joint", 1.0), ("left_inner_knuckle_joint", "finger_joint", -1.0),
                ("right_inner_finger_joint", "right_outer_knuckle_joint", -1.0),
                ("right_inner_knuckle_joint", "right_outer_knuckle_joint", 1.0))
    #: the actuated joints, robosuite's gripper ``joints`` here (the followers move with them).
    DRIVERS = ("finger_joint", "right_outer_knuckle_joint")
    #: rad, the outer knuckles' open and closed ends (robosuite's: 0 and 0.7; the right knuckle's negated).
    OPEN, CLOSED = 0.25, 0.7

    def __init__(self, idn=0):
        super().__init__(idn=idn)
        prefix = self.naming_prefix
        _make_kinematic(self, self.COUPLING)
        ranges = {"finger_joint": f"{self.OPEN} {self.CLOSED}",  # the right knuckle closes the other way
                  "right_outer_knuckle_joint": f"{-self.CLOSED} {-self.OPEN}"}
        for joint in self.worldbody.iter("joint"):
            joint.set("range", ranges.get(joint.get("name")[len(prefix):], joint.get("range")))
        for actuator in self.actuator:
            actuator.set("ctrlrange", ranges[actuator.get("joint")[len(prefix):]])
        self._joints = [name for name in self._joints if name in self.DRIVERS]  # robosuite keeps them unprefixed

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
