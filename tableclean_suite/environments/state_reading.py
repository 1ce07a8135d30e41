"""Reading the scene's state from one MuJoCo data: the dirt markers' flags and visuals
([DirtMarkers][tableclean_suite.environments.state_reading.DirtMarkers]) and the contacts (grasp test, sponge
on the table, press force: [Contacts][tableclean_suite.environments.state_reading.Contacts])."""

from __future__ import annotations

from typing import Sequence

import mujoco
import numpy as np

from tableclean_suite.environments import dirt_state
from tableclean_suite.environments.contact_kernels import (LOOKUP_BODY, LOOKUP_PADS, PAD_A, PAD_B, contact_within,
                                                           contacts_between, grasped_bodies)

#: Entries of ``mujoco.mj_contactForce``'s output: normal force first, then two tangential, three torques.
CONTACT_WRENCH_SIZE = 6


class DirtMarkers:
    """The dirt markers of one raw ``mujoco.MjData``: N segments of K markers, their flags in one joint per
    segment (``joints`` their names, ``qpos_addr``/``qvel_addr`` (N,) their addresses); ``show`` writes the
    alpha of ``geom_rgba`` (ngeom, 4) at ``geom_ids`` (N * K,)."""

    def __init__(self, data, joints: Sequence[str], qpos_addr: Sequence[int], qvel_addr: Sequence[int],
                 markers_per_segment: int, geom_rgba: np.ndarray, geom_ids: np.ndarray):
        self.data = data
        self.joints = tuple(joints)
        self.qpos_addr = tuple(int(a) for a in qpos_addr)
        self.qvel_addr = tuple(int(a) for a in qvel_addr)
        self.markers_per_segment = int(markers_per_segment)
        self._rgba, self._geom_ids = geom_rgba, np.asarray(geom_ids)
        self._qpos = data.qpos  # a kept view: each mjData attribute access builds a new one
        self._index = np.array(self.qpos_addr, dtype=np.intp)
        self._present: tuple | None = None  # (positions, decoded present mask)
        self._fraction: tuple | None = None  # (positions, fraction())
        self._shown: tuple | None = None  # the positions the visuals show (None: not synchronised yet)

    def positions(self) -> tuple:
        """The dirt-state joints' positions, a tuple of Python floats (the key of the decoded caches)."""
        return tuple(self._qpos[self._index].tolist())

    def present(self) -> np.ndarray:
        """Bool (N * K,), read-only: the markers not wiped (decoded once per joint positions).

        Raises [DirtStateError][tableclean_suite.environments.dirt_state.DirtStateError] when a joint
        holds no valid code (e.g. a state of another model was restored)."""
        positions = self.positions()
        if self._present is None or self._present[0] != positions:
            k = self.markers_per_segment
            wiped = [dirt_state.decode(x, k, j) for x, j in zip(positions, self.joints)]
            present = ~np.concatenate(wiped)
            present.flags.writeable = False
            self._present = (positions, present)
        return self._present[1]

    def fraction(self) -> np.ndarray:
        """(N,) fraction of each segment's markers still present (1.0: all dirty), a new array."""
        positions = self.positions()
        if self._fraction is None or self._fraction[0] != positions:
            self._fraction = (positions, self.present().reshape(len(self.joints), -1).mean(axis=1))
        return self._fraction[1].copy()

    def write(self, present: np.ndarray) -> None:
        """Store bool (N * K,) ``present`` in the joints' ``qpos`` (their velocities zeroed)."""
        data = self.data
        per_segment = np.asarray(present, dtype=bool).reshape(len(self.joints), self.markers_per_segment)
        for qpos_addr, qvel_addr, flags in zip(self.qpos_addr, self.qvel_addr, per_segment):
            data.qpos[qpos_addr] = dirt_state.encode(~flags)
            data.qvel[qvel_addr] = 0.0

    def show(self) -> None:
        """The markers' visuals follow their flags: alpha 0 for wiped markers, 1 for present ones (nothing
        to do while the flags are those shown last)."""
        positions = self.positions()
        if positions == self._shown:
            return
        self._rgba[self._geom_ids, 3] = self.present().astype(float)
        self._shown = positions


class Contacts:
    """Contact queries on one raw ``MjModel``/``MjData``: the grasp test and the sponge's press on the table top
    (``table``, ``sponge``, each of the M ``objects`` and the two finger ``pads``: bool (ngeom,) geom masks)."""

    def __init__(self, model, data, table: np.ndarray, sponge: np.ndarray, objects: Sequence[np.ndarray],
                 pads: tuple[np.ndarray, np.ndarray]):
        self.model, self.data = model, data
        self.table, self.sponge, self.objects, self.pads = table, sponge, tuple(objects), pads
        # each geom's pad bits and body (object 0 .. M - 1, the sponge M, -1 for neither): grasped_bodies' table
        lookup = np.zeros((sponge.size, 2), dtype=np.int64)
        lookup[:, LOOKUP_BODY] = -1
        for j, mask in enumerate(self.objects):
            lookup[mask, LOOKUP_BODY] = j
        lookup[sponge, LOOKUP_BODY] = len(self.objects)
        lookup[pads[0], LOOKUP_PADS] |= PAD_A
        lookup[pads[1], LOOKUP_PADS] |= PAD_B
        self._lookup, self._bodies = lookup, len(self.objects) + 1

    def grasped(self) -> np.ndarray:
        """Bool (M + 1,), a new array: for each object, then the sponge, whether both finger pads touch it
        (robosuite's grasp criterion), in one compiled pass over the active contacts."""
        # data.contact holds the ncon active contacts (none: an empty view, no body grasped)
        return grasped_bodies(self.data.contact.geom, self._lookup, self._bodies)

    def sponge_on_table(self, within: float) -> bool:
        """Whether a contact between the sponge and the table top is at most ``within`` [m] apart."""
        data = self.data
        ncon, contact = data.ncon, data.contact
        return contact_within(contact.geom1[:ncon], contact.geom2[:ncon], contact.dist[:ncon], self.sponge,
                              self.table, float(within))

    def press_force(self) -> float:
        """Normal force [N] (>= 0) the sponge presses on the table top: the sum of ``mj_contactForce`` over
        their contacts, in contact order."""
        data = self.data
        contact = data.contact
        wrench = np.zeros(CONTACT_WRENCH_SIZE)
        total = 0.0
        for i in contacts_between(contact.geom1, contact.geom2, self.sponge, self.table).tolist():
            mujoco.mj_contactForce(self.model, data, i, wrench)
            total += float(wrench[0])
        return max(total, 0.0)
