"""PlaceSkill: put the held object down on a free spot of the arm's segment (a :class:`~.primitives.Release`)."""

from __future__ import annotations

import enum
from typing import Any, Mapping

import numpy as np

from tableclean_suite.controllers.configs import PlaceConfig
from tableclean_suite.controllers.primitives import PrimitiveSkill, Release, object_body
from tableclean_suite.controllers.skill import SkillFailure
from tableclean_suite.environments.placement import free_spot, other_segments
from tableclean_suite.task import Action


class PlacePhase(enum.Enum):
    """Phases of a place, in order (the :class:`~.primitives.Release` primitive's)."""

    ALIGN = enum.auto()  # hover above the free spot
    DESCEND = enum.auto()  # lower the object to just above the table
    RELEASE = enum.auto()  # open until the fingers settle
    RETREAT = enum.auto()  # up to the hover height
    DONE = enum.auto()


class PlaceSkill(PrimitiveSkill):
    """Put the held object down on the arm's segment: at its centre, or the first free spot clear of
    the objects lying there (:func:`tableclean_suite.environments.placement.free_spot`)."""

    action = Action.PLACE
    Phase = PlacePhase
    Config = PlaceConfig
    DEFAULT_CONFIG = PlaceConfig().as_dict()

    def build(self, info: Mapping[str, Any]):
        held = self.state.held_object
        if held is None:
            raise SkillFailure("nothing is held")
        segment = self.state.arm
        radii = info["objects_footprint"]
        others = [(np.asarray(info["objects_pos"][j], dtype=float), float(radii[j]))
                  for j in self.state.objects_on(segment)]
        self.place_xy = free_spot(info["segment_centers"][segment], info["segment_half_sizes"][segment],
                                  float(radii[held]), others, info["object_clearance"],
                                  other_segments(info["segment_centers"], info["segment_half_sizes"], segment))
        rest_z = float(info["objects_rest_z"][held])
        return [("", Release(object_body(held), lambda skill, info: self.place_xy, lambda skill, info: rest_z))]
