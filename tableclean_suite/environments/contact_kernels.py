"""Compiled contact queries the skills ask every control step (imported by the physics path only)."""

from __future__ import annotations

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic


@numba.njit(cache=True)
def bodies_touched_by_both(geom: np.ndarray, pad_a: np.ndarray, pad_b: np.ndarray, group: np.ndarray,
                           touched: np.ndarray) -> None:
    """Which bodies each finger pad touches, into ``touched`` (2, bodies) bool: row 0 pad a, row 1 pad b
    (robosuite's grasp criterion is both rows).

    Args:
        geom: (ncon, 2) geom ids of MuJoCo's active contacts (``data.contact.geom``).
        pad_a, pad_b: bool lookups over all geom ids, the two finger pads' geoms.
        group: (ngeom,) int, the body (0 .. bodies - 1) each geom belongs to, -1 for none.
        touched: (2, bodies) bool output (overwritten; the caller's scratch, no allocation per call).
    """
    touched[:] = False
    for i in range(geom.shape[0]):
        g1, g2 = geom[i, 0], geom[i, 1]
        body1, body2 = group[g1], group[g2]
        if body2 >= 0:
            touched[0, body2] |= pad_a[g1]
            touched[1, body2] |= pad_b[g1]
        if body1 >= 0:
            touched[0, body1] |= pad_a[g2]
            touched[1, body1] |= pad_b[g2]


@numba.njit(cache=True)
def contacts_between(geom1: np.ndarray, geom2: np.ndarray, mask_a: np.ndarray, mask_b: np.ndarray) -> np.ndarray:
    """Indexes (int64, ascending) of the contacts pairing a geom of ``mask_a`` with a geom of ``mask_b`` (either order).

    :func:`~tableclean_suite.environments.wiping.any_contact`'s contacts in one compiled pass (its
    four numpy lookups cost ~5 us).

    Args:
        geom1, geom2: (ncon,) geom ids of MuJoCo's active contacts.
        mask_a, mask_b: bool lookups over all geom ids.
    """
    found = np.empty(geom1.size, dtype=np.int64)
    count = 0
    for i in range(geom1.size):
        g1, g2 = geom1[i], geom2[i]
        if (mask_a[g1] and mask_b[g2]) or (mask_a[g2] and mask_b[g1]):
            found[count] = i
            count += 1
    return found[:count]


@numba.njit(cache=True)
def contact_within(geom1: np.ndarray, geom2: np.ndarray, dist: np.ndarray, mask_a: np.ndarray, mask_b: np.ndarray,
                   max_dist: float) -> bool:
    """Whether a contact pairing a geom of ``mask_a`` with one of ``mask_b`` has ``dist`` <= ``max_dist`` [m].

    ``dist``: (ncon,) MuJoCo's contact distances (m, negative: penetration); the rest as :func:`contacts_between`.
    """
    for i in range(geom1.size):
        g1, g2 = geom1[i], geom2[i]
        if ((mask_a[g1] and mask_b[g2]) or (mask_a[g2] and mask_b[g1])) and dist[i] <= max_dist:
            return True
    return False


def _contact_force_codegen(context, builder, sig, args):
    """LLVM code calling C ``void f(const mjModel*, const mjData*, int, mjtNum*)`` at the address ``args[0]``."""
    void_ptr = ir.IntType(8).as_pointer()
    function_type = ir.FunctionType(ir.VoidType(), [void_ptr, void_ptr, ir.IntType(32), void_ptr])
    function = builder.inttoptr(args[0], function_type.as_pointer())
    builder.call(function, [builder.inttoptr(args[1], void_ptr), builder.inttoptr(args[2], void_ptr), args[3],
                            builder.inttoptr(args[4], void_ptr)])
    return context.get_dummy_value()


@intrinsic
def _call_contact_force(typingctx, function, model, data, index, result):
    """``function(model, data, index, result)`` for MuJoCo's ``mj_contactForce``; pointers arrive as integers
    (so the functions using it stay cacheable: no address is baked into the compiled code)."""
    return types.void(types.intp, types.intp, types.intp, types.int32, types.intp), _contact_force_codegen


@numba.njit(cache=True)
def normal_force_between(contact_force: int, model: int, data: int, geom1: np.ndarray, geom2: np.ndarray,
                         mask_a: np.ndarray, mask_b: np.ndarray, wrench: np.ndarray) -> float:
    """Sum [N] of the normal forces (``mj_contactForce``'s first entry) of the contacts pairing a geom of
    ``mask_a`` with one of ``mask_b`` (either order), in contact order: the env's press-force loop in one call.

    Args:
        contact_force: address of ``mj_contactForce``; model, data: ``mjModel*`` / ``mjData*`` addresses.
        geom1, geom2: (ncon,) geom ids of the active contacts; mask_a, mask_b: bool lookups over all geom ids.
        wrench: (6,) float64 C-contiguous scratch (overwritten).
    """
    total = 0.0
    for i in range(geom1.size):
        g1, g2 = geom1[i], geom2[i]
        if (mask_a[g1] and mask_b[g2]) or (mask_a[g2] and mask_b[g1]):
            _call_contact_force(contact_force, model, data, np.int32(i), wrench.ctypes.data)
            total += wrench[0]
    return total
