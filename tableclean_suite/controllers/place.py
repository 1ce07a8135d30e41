"""PlaceSkill: put the held object down on a free spot of the arm's segment (a [`Release`][tableclean_suite.controllers.primitives.Release])."""

from __future__ import annotations

import enum
from typing import Any, Mapping

import numpy as np

from tableclean_suite.controllers.configs import PlaceConfig
from tableclean_suite.controllers.primitives import Grasp, PrimitiveSkill, Release, gripper_of, object_body, wrist_reach
from tableclean_suite.controllers.skill import SkillFailure, object_heights
from tableclean_suite.environments.abstraction import AbstractionError
from tableclean_suite.environments.gripper_geometry import GripperGeometry
from tableclean_suite.environments.placement import footprint_of, free_spot, grown, other_segments
from tableclean_suite.task import Action


def place_spot(info: Mapping[str, Any], segment: int, held: int, lying, place_clearance: float,
               gripper: GripperGeometry | None = None) -> np.ndarray:
    """(2,) world xy [m] where the held object ``held`` goes on ``segment`` (0-based) among the objects ``lying``
    there (indices): [`free_spot`][tableclean_suite.environments.placement.free_spot] of the footprints as the
    objects stand now (the held one as it hangs in the hand), the hand's half width across the fingers
    (the side [`Release`][tableclean_suite.controllers.primitives.Release] turns toward a neighbour), about the grip site wherever the
    held object's centre is off it (the hand can turn about the object's centre: a disc of the half
    width plus that offset), kept ``object_clearance`` from every lying object whose top reaches the
    hand's underside at release (``place_clearance`` [m] above the resting height, as
    [`Release`][tableclean_suite.controllers.primitives.Release] lowers it).

    With ``gripper`` (the env's measures, [`gripper_of`][tableclean_suite.controllers.primitives.gripper_of]), a neighbour tall enough to reach the links
    above the hand ([`wrist_reach`][tableclean_suite.controllers.primitives.wrist_reach]) is kept that much wider
    from the hand's axis (its footprint `grown` by the difference);
    [`Release`][tableclean_suite.controllers.primitives.Release] turns the hand's narrow side to its nearest point,
    so the whole neighbour lies beyond that width."""
    others = [(np.asarray(info["objects_pos"][j], dtype=float), footprint_of(info, j)) for j in lying]
    offset = np.asarray(info["eef_pos"], dtype=float) - np.asarray(info["objects_pos"][held], dtype=float)
    grip_z = float(info["objects_rest_z"][held]) + place_clearance + float(offset[2])
    hand_bottom = grip_z + float(info["gripper_palm_height"])
    tops, _ = object_heights(info)
    tall = []
    for j, (xy, footprint) in zip(lying, others):
        if tops[j] > hand_bottom:
            wider = wrist_reach(info, gripper, tops[j], grip_z)
            if wider is not None:
                footprint = grown(footprint, wider - float(info["gripper_hand_half_width"]))
            tall.append((xy, footprint))
    hand = float(info["gripper_hand_half_width"]) + float(np.hypot(offset[0], offset[1]))
    return free_spot(info["segment_centers"][segment], info["segment_half_sizes"][segment], footprint_of(info, held),
                     others, info["object_clearance"],
                     other_segments(info["segment_centers"], info["segment_half_sizes"], segment),
                     hand=hand, under_hand=tall)


PlacePhase = enum.Enum("PlacePhase", [*Release.PHASES, *(f"REGRASP_{p}" for p in Grasp.PHASES), "DONE"],
                       module=__name__)
"""Phases of a place, in order: the [`Release`][tableclean_suite.controllers.primitives.Release] primitive's, then
REGRASP_ and the [`Grasp`][tableclean_suite.controllers.primitives.Grasp]'s (a retry: the object did not end on the
segment, grasped again where it lies)."""


class PlaceSkill(PrimitiveSkill):
    """Put the held object down on the arm's segment: at its centre, or the first free spot clear of
    the objects lying there ([`place_spot`][tableclean_suite.controllers.place.place_spot]).

    Its goal is checked where the controller will check it, after RETREAT: the abstraction reads the object
    lying on the arm's segment.  If not (it fell between segments, say), a retry grasps it again where it
    lies and puts it down on a spot measured anew."""

    action = Action.PLACE
    Phase = PlacePhase
    Config = PlaceConfig
    DEFAULT_CONFIG = PlaceConfig().as_dict()

    def build(self, info: Mapping[str, Any]):
        held = self.state.held_object
        if held is None:
            raise SkillFailure("nothing is held")
        segment, lying, gripper = self.state.arm, self.state.objects_on(self.state.arm), gripper_of(self.env)
        rest_z = float(info["objects_rest_z"][held])
        self.release = Release(object_body(held), lambda skill, info: place_spot(
            info, segment, held, lying, self.config["place_clearance"], gripper), lambda skill, info: rest_z)
        return [("", self.release)]

    def next_phase(self, info: Mapping[str, Any]):
        if self.phase is PlacePhase.RETREAT:
            try:
                lies = self.env.symbolic_state().objects[self.state.held_object] == self.state.arm
            except AbstractionError:
                lies = False
            if not lies:
                raise SkillFailure(f"the object does not lie on segment {self.state.arm + 1}", redo=0)
        return super().next_phase(info)

    def restart(self, info: Mapping[str, Any], redo: int) -> bool:
        """Grasp the object again where it lies, then put it down anew (a failure of either does this again)."""
        self.plan = [("REGRASP_", Grasp(object_body(self.state.held_object, info), "grasp")), ("", self.release)]
        self._enter(0, info, again=True)
        return True
