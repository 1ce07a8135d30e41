"""Compiled contact queries the skills ask every control step (imported by the physics path only)."""

from __future__ import annotations

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic


#: Bits of a geom's pad entry in [`grasped_bodies`][tableclean_suite.environments.contact_kernels.grasped_bodies]' lookup: finger pad a's geoms, pad b's; both (a grasp).
PAD_A = 1
PAD_B = 2
BOTH_PADS = PAD_A | PAD_B
#: Columns of [`grasped_bodies`][tableclean_suite.environments.contact_kernels.grasped_bodies]' lookup: the geom's pad bits, the body (0 .. bodies - 1) it belongs to (-1: none).
LOOKUP_PADS = 0
LOOKUP_BODY = 1


@numba.njit(cache=True)
def grasped_bodies(geom: np.ndarray, lookup: np.ndarray, bodies: int) -> np.ndarray:
    """Bool (bodies,) (a new array): whether both finger pads touch each body (robosuite's grasp criterion),
    in one pass over the contacts.

    Args:
        geom: (ncon, 2) geom ids of MuJoCo's active contacts (``data.contact.geom``).
        lookup: (ngeom, 2) int64 per geom id: column `LOOKUP_PADS` its pad bits (`PAD_A`,
            `PAD_B`, 0 for no pad), column `LOOKUP_BODY` the body it belongs to (-1: none).
        bodies: how many bodies the lookup names.
    """
    touched = np.zeros(bodies, dtype=np.int64)  # per body: the pad bits of the geoms touching it
    for i in range(geom.shape[0]):
        g1, g2 = geom[i, 0], geom[i, 1]
        body1, body2 = lookup[g1, LOOKUP_BODY], lookup[g2, LOOKUP_BODY]
        if body2 >= 0:
            touched[body2] |= lookup[g1, LOOKUP_PADS]
        if body1 >= 0:
            touched[body1] |= lookup[g2, LOOKUP_PADS]
    grasped = np.empty(bodies, dtype=np.bool_)
    for body in range(bodies):
        grasped[body] = (touched[body] & BOTH_PADS) == BOTH_PADS
    return grasped


@numba.njit(cache=True)
def contacts_between(geom1: np.ndarray, geom2: np.ndarray, mask_a: np.ndarray, mask_b: np.ndarray) -> np.ndarray:
    """Indexes (int64, ascending) of the contacts pairing a geom of ``mask_a`` with a geom of ``mask_b`` (either order).

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

    ``dist``: (ncon,) MuJoCo's contact distances (m, negative: penetration); the rest as [`contacts_between`][tableclean_suite.environments.contact_kernels.contacts_between].
    """
    for i in range(geom1.size):
        g1, g2 = geom1[i], geom2[i]
        if ((mask_a[g1] and mask_b[g2]) or (mask_a[g2] and mask_b[g1])) and dist[i] <= max_dist:
            return True
    return False


def _c_function(restype):
    """An intrinsic ``call(fn, *args)`` calling the C function at the integer address ``fn`` with return type
    ``restype`` (``types.void`` or ``types.float64``): ``int32`` arguments are C ints, other integers
    pointers.  Addresses arrive as integers, so the functions using it stay cacheable."""
    llvm_restype = ir.VoidType() if restype == types.void else ir.DoubleType()

    @intrinsic
    def call(typingctx, fn, *args):
        def codegen(context, builder, sig, llvm_args):
            pointer = ir.IntType(8).as_pointer()
            params = [ir.IntType(32) if a == types.int32 else pointer for a in args]
            function = builder.inttoptr(llvm_args[0], ir.FunctionType(llvm_restype, params).as_pointer())
            packed = llvm_args[1]
            values = [builder.extract_value(packed, i) for i in range(len(args))]
            result = builder.call(function, [v if a == types.int32 else builder.inttoptr(v, pointer)
                                             for a, v in zip(args, values)])
            return context.get_dummy_value() if restype == types.void else result

        return restype(fn, types.StarArgTuple.from_types(args)), codegen

    return call


#: ``c_call(fn, *args)``: a ``void`` C function; ``c_call_double(fn, *args)``: one returning a ``double``.
c_call = _c_function(types.void)
c_call_double = _c_function(types.float64)
