"""robosuite's OSC_POSE control law for the skills, compiled, without its per-substep Python.

[`FastSkillStepper.step`][tableclean_suite.controllers.fast_control.FastSkillStepper.step] replaces
``env.step`` for an absolute world-frame command ``[x, y, z, rx, ry, rz, gripper]`` with the same
control law, the same MuJoCo states after every control step:

- per control step: the goal pose (scipy's ``Rotation.from_rotvec``, as robosuite's absolute OSC) and
  the gripper's rate-limited command and actuator controls;
- per physics substep: ``mj_step1``, the OSC torques from MuJoCo's ``mj_fullM`` and ``mj_jacSite``
  (robosuite's ``run_controller``, with Cholesky inverses of its positive definite matrices; its SVD
  pseudo-inverses near a singularity), clipping, the env's wiping check, ``mj_step2``.  The native loop
  calls MuJoCo's C API from numba and returns to Python only for a substep the env's wiping check must
  see (the sponge near the table over a marker not yet wiped);
- robosuite's reuse of the reset-time arm state on an episode's first substep
  ([`cached_arm_torques`][tableclean_suite.controllers.fast_control.FastSkillStepper.cached_arm_torques]).

A skill phase whose waypoint is fixed, and the clean skill's PRESS, WIPE and SHIFT, run further in
[`control_loop`][tableclean_suite.controllers.fast_control.control_loop]: the skill's state as typed
records ([`loop_state`][tableclean_suite.controllers.loop_state]), its setpoint
([`advance_command`][tableclean_suite.controllers.setpoint.advance_command]) and the substeps in one
compiled call, returning at the phase's boundary (a step whose completion check might pass, a step it
cannot take exactly, the budget).

Not done: robosuite's observables, proprioception buffers and reward (the skills read the simulation
data directly).  Only the skills' configuration is supported (one fixed-base arm, absolute world-frame
OSC_POSE, fixed impedance, no interpolators, a simple grip gripper); anything else raises
``NotImplementedError``.  The kernels compile on first use and are cached in ``__pycache__``.
"""

from __future__ import annotations

import ctypes
import operator
import time
from typing import NamedTuple

import mujoco
import numba
import numpy as np
from robosuite.controllers.parts.arm.osc import OperationalSpaceController
from robosuite.controllers.parts.gripper.simple_grip import SimpleGripController
from robosuite.models.grippers.panda_gripper import PandaGripper
from robosuite.utils.control_utils import opspace_matrices

from tableclean_suite.controllers.geometry import clip_scalar
from tableclean_suite.controllers.loop_state import MODE_FIXED, MODE_SHIFT, MODE_WIPE, WIPE_STATE
from tableclean_suite.controllers.osc import ACTION_DIM
from tableclean_suite.controllers.setpoint import GRIPPER_INDEX, advance_command
from tableclean_suite.environments import wiping
from tableclean_suite.environments.contact_kernels import c_call, c_call_double
from tableclean_suite.environments.table_clean import PRESS_PREFILTER_SLACK
from tableclean_suite.robosuite_adapter import (
    actuator_indexes,
    advance_clock,
    c_address,
    controller_needs_update,
    fast_path_allowed,
    gripper_joint_pos_indexes,
    hand_back_controller_state,
    mj_data,
    mj_model,
    mujoco_function_addresses,
    require_checked_versions,
    set_gripper_state,
)

#: A Cholesky pivot below this fraction of the largest diagonal entry sends the operational-space
#: matrices to robosuite's own SVD pseudo-inverses (near a singularity).
CHOLESKY_PIVOT_RTOL = 1e-10
#: m added to the env's marker reach when the native loop asks whether a present marker lies under the
#: sponge (a superset of the env's own test, which then decides).
MARKER_REACH_SLACK = 1e-9
#: Joint stiffness (1/s^2) of robosuite's nullspace posture term.
NULLSPACE_JOINT_KP = 10.0
#: rad: below this angle [`rotvec_matrix`][tableclean_suite.controllers.fast_control.rotvec_matrix] uses the Taylor series of sin(a/2)/a (as scipy).
ROTVEC_SMALL_ANGLE = 1e-3
#: Relative slack of the control loop's "this step cannot complete the phase" test on the position error.
POSITION_CHECK_RTOL = 1e-9
#: The control loop's stop reasons: a step whose completion check might pass (left to the skill), the
#: skill's step budget, the caller's step limit, a substep for the env's wiping check, a step the loop
#: cannot take exactly (left to the skill).
PHASE_MAYBE_COMPLETE, PHASE_BUDGET, PHASE_LIMIT, PHASE_WIPE, PHASE_HANDOFF = 0, 1, 2, 3, 4
#: m: within this of ``contact_slack`` the control loop hands a wipe step to the skill (rounding).
GAP_CHECK_SLACK = 1e-9
#: C type of the press-force callback (``double f(void)``, N) the control loop calls once per wipe step.
FORCE_CALLBACK = ctypes.CFUNCTYPE(ctypes.c_double)
#: Most gripper control steps the control loop tabulates ahead (the Panda's command settles within 10).
GRIP_TABLE_ROWS = 32
#: mjData fields [`ControlStepLog`][tableclean_suite.controllers.fast_control.ControlStepLog] records at the start of every control step.
LOG_FIELDS = ("qpos", "qvel", "act", "ctrl", "qacc_warmstart")


class Plant(NamedTuple):
    """What the compiled kernels read and write of the simulation, and the arm's control law.

    Arrays float64 unless noted; n arm joints, nv dofs; "live": views of mjData.
    """

    functions: tuple  # addresses of mj_step1, mj_step2, mj_fullM, mj_jacSite (zeros without the native loop)
    model: int  # address of the C mjModel
    data: int  # address of the C mjData
    substeps: int  # physics substeps per control step
    full_mass: np.ndarray  # (nv, nv) scratch: mj_fullM's output
    jacp: np.ndarray  # (3, nv) scratch: the grip site's translational Jacobian
    jacr: np.ndarray  # (3, nv) scratch: its rotational Jacobian
    torques: np.ndarray  # (n,) output: the last OSC torques (N m), unclipped
    q_m: np.ndarray  # live qM
    qpos: np.ndarray  # live (nq,)
    qvel: np.ndarray  # live (nv,)
    qfrc_bias: np.ndarray  # live (nv,)
    ctrl: np.ndarray  # live (nu,)
    site_id: int  # the OSC's grip site
    site_pos: np.ndarray  # live (3,) its world position (m)
    site_mat: np.ndarray  # live (9,) its row-major world rotation
    eef_pos: np.ndarray  # live (3,) the skill's end-effector site position (m)
    finger_index: np.ndarray  # (F,) int64 qpos indexes of the finger joints
    sponge_pos: np.ndarray  # live (3,) the sponge's world position (m)
    sponge_mat: np.ndarray  # live (9,) its row-major world rotation
    sponge_half: np.ndarray  # (3,) its half size (m)
    wipe_z: float  # m: a substep whose sponge's lowest corner is below goes to the env's wiping check
    marker_reach: float  # m: the env's marker reach
    indexes: np.ndarray  # (2, n) int64 rows: the arm's dof (qvel) indexes, its qpos indexes
    arm_actuators: np.ndarray  # (n,) int64
    grip_actuators: np.ndarray  # (G,) int64
    limits: np.ndarray  # (2, n) the arm actuators' ctrl range (N m), low and high
    gains: np.ndarray  # (2, 6) the OSC's kp (1/s^2) and kd (1/s) rows, columns x, y, z, rx, ry, rz
    initial_joint: np.ndarray  # (n,) rad, the nullspace term's posture
    uncouple: bool  # decouple the position and orientation wrenches (robosuite's uncouple_pos_ori)
    log_live: tuple  # the mjData views of LOG_FIELDS


class ArmState(NamedTuple):
    """The arm's state the OSC law reads, for n arm joints (float64 arrays)."""

    mass: np.ndarray  # (n, n) arm block of the joint-space mass matrix (kg m^2)
    j_full: np.ndarray  # (6, n) grip-site Jacobian, translational rows then rotational rows
    ref_pos: np.ndarray  # (3,) grip-site world position (m)
    ref_ori_mat: np.ndarray  # (3, 3) its world rotation
    ref_vel: np.ndarray  # (6,) its linear (m/s) and angular (rad/s) world velocity
    joint_pos: np.ndarray  # (n,) joint positions (rad)
    joint_vel: np.ndarray  # (n,) joint velocities (rad/s)
    bias: np.ndarray  # (n,) gravity, Coriolis and centrifugal joint forces (N m), the compensation term


@numba.njit(cache=True)
def rotvec_matrix(rotvec: np.ndarray, out: np.ndarray) -> None:
    """Rotation matrix (3, 3) into ``out`` of the rotation vector ``rotvec`` (3,) rad.

    scipy's ``Rotation.from_rotvec(rotvec).as_matrix()`` with the same operations (bit-identical on scipy 1.17).
    """
    angle = np.sqrt(rotvec[0] * rotvec[0] + rotvec[1] * rotvec[1] + rotvec[2] * rotvec[2])
    if angle <= ROTVEC_SMALL_ANGLE:
        angle2 = angle * angle
        scale = 0.5 - angle2 / 48 + angle2 * angle2 / 3840
    else:
        scale = np.sin(angle / 2) / angle
    x, y, z, w = scale * rotvec[0], scale * rotvec[1], scale * rotvec[2], np.cos(angle / 2)
    x2, y2, z2, w2 = x * x, y * y, z * z, w * w
    xy, zw, xz, yw, yz, xw = x * y, z * w, x * z, y * w, y * z, x * w
    out[0, 0], out[1, 0], out[2, 0] = x2 - y2 - z2 + w2, 2 * (xy + zw), 2 * (xz - yw)
    out[0, 1], out[1, 1], out[2, 1] = 2 * (xy - zw), -x2 + y2 - z2 + w2, 2 * (yz + xw)
    out[0, 2], out[1, 2], out[2, 2] = 2 * (xz + yw), 2 * (yz - xw), -x2 - y2 + z2 + w2


@numba.njit(cache=True)
def spd_inverse(a: np.ndarray, out: np.ndarray, low: np.ndarray, inv_low: np.ndarray) -> bool:
    """Inverse of the symmetric positive definite ``a`` (n, n) into ``out`` (n, n) by Cholesky.

    Reads the lower triangle of ``a``; ``low``, ``inv_low``: (>= n, >= n) scratch.  False (``out``
    undefined) when a pivot falls below `CHOLESKY_PIVOT_RTOL` times the largest diagonal entry.
    """
    n = a.shape[0]
    scale = 0.0
    for i in range(n):
        scale = max(scale, a[i, i])
    for j in range(n):
        pivot = a[j, j]
        for k in range(j):
            pivot -= low[j, k] * low[j, k]
        if not pivot > CHOLESKY_PIVOT_RTOL * scale:
            return False
        low[j, j] = np.sqrt(pivot)
        for i in range(j + 1, n):
            value = a[i, j]
            for k in range(j):
                value -= low[i, k] * low[j, k]
            low[i, j] = value / low[j, j]
    for i in range(n):  # L^-1, lower triangular
        inv_low[i, i] = 1.0 / low[i, i]
        for j in range(i):
            value = 0.0
            for k in range(j, i):
                value -= low[i, k] * inv_low[k, j]
            inv_low[i, j] = value / low[i, i]
    for i in range(n):  # a^-1 = L^-T L^-1
        for j in range(i + 1):
            value = 0.0
            for k in range(i, n):
                value += inv_low[k, i] * inv_low[k, j]
            out[i, j] = value
            out[j, i] = value
    return True


@numba.njit(cache=True)
def small_matmul(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """``out = a @ b``, (n, k) times (k, m), in plain loops (a fixed order of operations, no BLAS call)."""
    n, k = a.shape
    m = b.shape[1]
    for i in range(n):
        for j in range(m):
            out[i, j] = 0.0
        for p in range(k):
            factor = a[i, p]
            for j in range(m):
                out[i, j] += factor * b[p, j]


@numba.njit(cache=True)
def small_matvec(a: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
    """``out = a @ x`` for a matrix (n, k) and a vector (k,), in plain loops."""
    n, k = a.shape
    for i in range(n):
        value = 0.0
        for p in range(k):
            value += a[i, p] * x[p]
        out[i] = value


@numba.njit(cache=True)
def opspace(mass: np.ndarray, j_full: np.ndarray):
    """robosuite's ``opspace_matrices`` (lambda_full (6, 6), lambda_pos (3, 3), lambda_ori (3, 3), nullspace (n, n))
    of the arm's ``mass`` (n, n) and Jacobian ``j_full`` (6, n), with Cholesky inverses of its positive
    definite matrices; robosuite's own function when a pivot is tiny (near a singularity)."""
    n = mass.shape[0]
    size = max(n, 6)
    low, inv_low, mass_inv = np.empty((size, size)), np.empty((size, size)), np.empty((n, n))
    lambda_full, lambda_pos, lambda_ori = np.empty((6, 6)), np.empty((3, 3)), np.empty((3, 3))
    if spd_inverse(mass, mass_inv, low, inv_low):
        j_minv = np.empty((6, n))
        small_matmul(j_full, mass_inv, j_minv)
        lambda_full_inv = np.empty((6, 6))
        small_matmul(j_minv, j_full.T, lambda_full_inv)
        ok = spd_inverse(lambda_full_inv, lambda_full, low, inv_low)
        ok = ok and spd_inverse(lambda_full_inv[0:3, 0:3], lambda_pos, low, inv_low)
        ok = ok and spd_inverse(lambda_full_inv[3:6, 3:6], lambda_ori, low, inv_low)
        if ok:
            j_bar = np.empty((n, 6))
            small_matmul(j_minv.T, lambda_full, j_bar)  # M^-1 J^T lambda (M^-1 symmetric)
            nullspace = np.empty((n, n))
            small_matmul(j_bar, j_full, nullspace)
            for i in range(n):
                for j in range(n):
                    nullspace[i, j] = (1.0 if i == j else 0.0) - nullspace[i, j]
            return lambda_full, lambda_pos, lambda_ori, nullspace
    exact = opspace_matrices(mass, j_full, np.ascontiguousarray(j_full[0:3]), np.ascontiguousarray(j_full[3:6]))
    nullspace = np.empty((n, n))
    lambda_full[:] = exact[0]
    lambda_pos[:] = exact[1]
    lambda_ori[:] = exact[2]
    nullspace[:] = exact[3]
    return lambda_full, lambda_pos, lambda_ori, nullspace


@numba.njit(cache=True)
def osc_law(arm, goal_pos: np.ndarray, goal_ori: np.ndarray, plant) -> None:
    """robosuite's ``OperationalSpaceController.run_controller`` torques for an absolute world-frame goal.

    ``arm``: the [ArmState][tableclean_suite.controllers.fast_control.ArmState]; ``goal_pos`` (3,) m and
    ``goal_ori`` (3, 3), world frame; ``plant``: the [Plant][tableclean_suite.controllers.fast_control.Plant]
    whose ``gains``, ``initial_joint`` and ``uncouple`` are the law.  Writes the torques (n,) N m, before
    clipping, to ``plant.torques``.  The base velocity term is zero (the arm's base is welded to the world).
    """
    mass, j_full, ref_pos, ref_ori_mat, ref_vel, joint_pos, joint_vel, bias = arm
    gains, initial_joint, torques = plant.gains, plant.initial_joint, plant.torques
    n = mass.shape[0]
    desired = np.empty(6)  # desired force (3) and torque (3)
    for r in range(3):
        desired[r] = (goal_pos[r] - ref_pos[r]) * gains[0, r] + (-ref_vel[r]) * gains[1, r]
    error = np.zeros(3)  # robosuite's orientation_error: half the sum of the columns' cross products
    for c in range(3):
        a0, a1, a2 = ref_ori_mat[0, c], ref_ori_mat[1, c], ref_ori_mat[2, c]
        b0, b1, b2 = goal_ori[0, c], goal_ori[1, c], goal_ori[2, c]
        error[0] += a1 * b2 - a2 * b1
        error[1] += a2 * b0 - a0 * b2
        error[2] += a0 * b1 - a1 * b0
    for r in range(3):
        desired[3 + r] = 0.5 * error[r] * gains[0, 3 + r] + (-ref_vel[3 + r]) * gains[1, 3 + r]
    lambda_full, lambda_pos, lambda_ori, nullspace = opspace(mass, j_full)
    wrench = np.empty(6)
    if plant.uncouple:
        small_matvec(lambda_pos, desired[0:3], wrench[0:3])
        small_matvec(lambda_ori, desired[3:6], wrench[3:6])
    else:
        small_matvec(lambda_full, desired, wrench)
    small_matvec(j_full.T, wrench, torques)
    joint_kv = np.sqrt(NULLSPACE_JOINT_KP) * 2  # robosuite's nullspace_torques: critical damping
    posture = np.empty(n)
    for i in range(n):
        posture[i] = NULLSPACE_JOINT_KP * (initial_joint[i] - joint_pos[i]) - joint_kv * joint_vel[i]
    pose_torques = np.empty(n)
    small_matvec(mass, posture, pose_torques)
    for i in range(n):
        value = 0.0
        for k in range(n):
            value += nullspace[k, i] * pose_torques[k]
        torques[i] = (torques[i] + bias[i]) + value


@numba.njit(cache=True)
def osc_torques(plant, goal_pos: np.ndarray, goal_ori: np.ndarray) -> None:
    """[`osc_law`][tableclean_suite.controllers.fast_control.osc_law] on the plant's whole-model arrays
    (``full_mass``, ``jacp``, ``jacr`` filled by ``mj_fullM`` and ``mj_jacSite``), gathering the arm's
    entries as robosuite's ``update()``."""
    dofs = plant.indexes[0]
    n = dofs.size
    mass, j_full = np.empty((n, n)), np.empty((6, n))
    for i in range(n):
        for k in range(n):
            mass[i, k] = plant.full_mass[dofs[i], dofs[k]]
        for r in range(3):
            j_full[r, i] = plant.jacp[r, dofs[i]]
            j_full[r + 3, i] = plant.jacr[r, dofs[i]]
    ref_vel = np.empty(6)
    small_matvec(plant.jacp, plant.qvel, ref_vel[0:3])  # robosuite's get_site_xvelp: all dofs' velocities
    small_matvec(plant.jacr, plant.qvel, ref_vel[3:6])
    ref_ori_mat = np.ascontiguousarray(plant.site_mat.reshape((3, 3)))
    arm = ArmState(mass, j_full, plant.site_pos, ref_ori_mat, ref_vel, plant.qpos[plant.indexes[1]],
                   plant.qvel[dofs], plant.qfrc_bias[dofs])
    osc_law(arm, goal_pos, goal_ori, plant)


@numba.njit(cache=True)
def native_substeps(plant, dirt, first, goal_pos, goal_ori, grip_ctrl):
    """Substeps ``first``..``plant.substeps - 1``: step1, OSC torques, ctrl, [wiping hand-off], step2.

    ``dirt``: (markers (N, 3) m, present (N,) bool); ``first``: int64; ``goal_pos`` (3,) m, ``goal_ori``
    (3, 3); ``grip_ctrl`` (G,): the gripper actuator controls, written at substep 0.  Returns
    ``plant.substeps`` when done, or ``-(k + 1)`` after substep k's control when the sponge is below
    ``plant.wipe_z`` over a present marker: the caller runs the env's wiping check and ``mj_step2``,
    then calls again from ``k + 1``.
    """
    step1, step2, full_m, jac_site = plant.functions
    markers, present = dirt
    arm_act, grip_act, ctrl = plant.arm_actuators, plant.grip_actuators, plant.ctrl
    torques, limits = plant.torques, plant.limits
    for k in range(first, plant.substeps):
        c_call(step1, plant.model, plant.data)
        c_call(full_m, plant.model, plant.full_mass.ctypes.data, plant.q_m.ctypes.data)
        c_call(jac_site, plant.model, plant.data, plant.jacp.ctypes.data, plant.jacr.ctypes.data,
               np.int32(plant.site_id))
        osc_torques(plant, goal_pos, goal_ori)
        for i in range(arm_act.size):
            ctrl[arm_act[i]] = min(max(torques[i], limits[0, i]), limits[1, i])
        if k == 0:
            for i in range(grip_act.size):
                ctrl[grip_act[i]] = grip_ctrl[i]
        if (box_lowest_z(plant.sponge_pos, plant.sponge_mat, plant.sponge_half) <= plant.wipe_z
                and present_marker_under_box(markers, present, plant.sponge_pos, plant.sponge_mat, plant.sponge_half,
                                             plant.marker_reach)):
            return -(k + 1)
        c_call(step2, plant.model, plant.data)
    return plant.substeps


@numba.njit(cache=True)
def present_marker_under_box(markers, present, pos, mat, half_size, reach) -> bool:
    """Whether a ``present`` (N,) marker of ``markers`` (N, 3) m lies within ``reach`` (m) of a box
    (centre ``pos`` (3,), row-major rotation ``mat`` (9,), ``half_size`` (3,) m): the env's
    ``markers_under_box`` test in the box frame, widened by `MARKER_REACH_SLACK`."""
    for m in range(markers.shape[0]):
        if not present[m]:
            continue
        inside = True
        for axis in range(3):
            local = 0.0
            for r in range(3):
                local += (markers[m, r] - pos[r]) * mat[3 * r + axis]
            if abs(local) > half_size[axis] + reach + MARKER_REACH_SLACK:
                inside = False
                break
        if inside:
            return True
    return False


_clip = numba.njit(cache=True)(clip_scalar)
box_lowest_z = numba.njit(cache=True)(wiping.box_lowest_z)


@numba.njit(cache=True)
def wipe_waypoint(plant, wipe, setpoint, phase_steps, tolerance):
    """One control step of the clean skill's wipe (``Wipe.update``, ``Wipe.waypoint``, ``Wipe.ready``), compiled.

    ``wipe``: a `WIPE_STATE` record (read only); ``setpoint`` (3,) m; ``phase_steps``: control steps in
    the phase; ``tolerance``: m.  Returns (stop, waypoint x, y, z (m), depth (m), force (N), lifted,
    ready, tolerance (m)): ``stop`` is `PHASE_HANDOFF` for a step the skill must take (the sponge within
    `GAP_CHECK_SLACK` of ``contact_slack``, or above it while wiping; a NaN force), else -1.
    """
    wiping = wipe.mode == MODE_WIPE
    shifting = wipe.mode == MODE_SHIFT
    lifted = wipe.lifted
    slack = wipe.contact_slack
    table, half_z, hold = wipe.table_z, wipe.half_z, wipe.hold
    force = wipe.force
    depth = wipe.depth
    now_lifted = lifted
    if not (shifting and lifted):
        force = c_call_double(wipe.force_fn)
        if force != force:
            return PHASE_HANDOFF, 0.0, 0.0, 0.0, depth, force, lifted, False, tolerance
    if shifting:  # Wipe._update_lift: on once no force is measured and the sponge is off the table
        if not lifted:
            gap = box_lowest_z(plant.sponge_pos, plant.sponge_mat, plant.sponge_half) - table
            if force <= 0.0 and abs(gap - slack) <= GAP_CHECK_SLACK:  # too close to call: the skill takes this step
                return PHASE_HANDOFF, 0.0, 0.0, 0.0, depth, force, lifted, False, tolerance
            now_lifted = (force <= 0.0 and gap > slack) or phase_steps >= wipe.lift_max_steps
        p0 = (wipe.stroke[0] if now_lifted else wipe.lift[0]) + hold[0]
        p1 = (wipe.stroke[1] if now_lifted else wipe.lift[1]) + hold[1]
        p2 = table - wipe.shift_depth + half_z + hold[2]
    else:  # Wipe.update: the depth follows the force error (pressing: once arrived or touching)
        target_z = table - depth + half_z + hold[2]
        arrived = abs(setpoint[2] - target_z) <= wipe.arrival
        if wiping or force > 0.0 or arrived:
            error = wipe.press_force - force
            gap = 0.0
            lowest = box_lowest_z(plant.sponge_pos, plant.sponge_mat, plant.sponge_half)
            if wiping and lowest - table - slack > -GAP_CHECK_SLACK:  # the gap term may be positive: the skill decides
                return PHASE_HANDOFF, 0.0, 0.0, 0.0, depth, force, lifted, False, tolerance
            rate = wipe.force_gain * error + wipe.gap_gain * gap
            depth = _clip(depth + rate * wipe.dt, wipe.min_depth, wipe.max_depth)
        # Wipe.waypoint
        p0 = wipe.stroke[0] + hold[0]
        p1 = wipe.stroke[1] + hold[1]
        p2 = table - depth + half_z + hold[2]
    if wiping:
        axis = wipe.axis
        bound = wipe.drift_bound
        drift = _clip(plant.eef_pos[axis] - plant.sponge_pos[axis] - hold[axis], -bound, bound)
        p0 = _clip(p0 + (drift if axis == 0 else 0.0), wipe.low[0], wipe.high[0])
        p1 = _clip(p1 + (drift if axis == 1 else 0.0), wipe.low[1], wipe.high[1])
        if phase_steps >= wipe.stroke_max_steps:
            tolerance = np.inf
    if shifting:
        ready = now_lifted
    else:
        ready = wiping or force >= wipe.touch_force or phase_steps >= wipe.press_timeout
    return -1, p0, p1, p2, depth, force, now_lifted, ready, tolerance


@numba.njit(cache=True)
def control_loop(plant, dirt, skill, fingers, wipe, grip_table, goal, log, limit):
    """Control steps of a skill phase, as ``Skill.step`` then ``FastSkillStepper.step``, in one compiled call.

    Args:
        plant, dirt: as [`native_substeps`][tableclean_suite.controllers.fast_control.native_substeps].
        skill: (1,) `SKILL_STATE` record, updated in place.
        fingers: (F,) finger positions at the last step (rad or m), updated in place.
        wipe: (1,) `WIPE_STATE` record (mode ``MODE_FIXED``: a fixed waypoint), updated in place.
        grip_table: (R, G) gripper actuator controls, row k for the loop's k-th step (the last beyond).
        goal: outputs (action (7,), goal_pos (3,) m, goal_ori (3, 3)) of the last step.
        log: arrays (rows, size) receiving `LOG_FIELDS` at the start of each step (none without rows).
        limit: most control steps to run.

    Returns:
        (stop reason, control steps started, substep): with `PHASE_WIPE` the last step stopped after
        substep's control (the caller runs the env's wiping check, ``mj_step2`` and the rest).
    """
    s = skill[0]
    w = wipe[0]
    action, goal_pos, goal_ori = goal
    setpoint, target = s.setpoint, s.target
    fixed = w.mode == MODE_FIXED
    yaw_setpoint, steps, phase_steps = s.yaw_setpoint, s.steps, s.phase_steps
    qpos, finger_index, eef_pos = plant.qpos, plant.finger_index, plant.eef_pos
    logging = log[0].shape[0] > 0
    ran = 0
    status = PHASE_LIMIT
    substep = 0
    while ran < limit:
        if steps >= s.max_steps:
            status = PHASE_BUDGET
            break
        motion = 0.0
        for i in range(finger_index.size):
            motion = max(motion, abs(qpos[finger_index[i]] - fingers[i]))
        if fixed:
            stop, p0, p1, p2, depth, force, lifted, ready, tolerance = (
                -1, target[0], target[1], target[2], 0.0, 0.0, False, True, s.tolerance)
        else:
            stop, p0, p1, p2, depth, force, lifted, ready, tolerance = wipe_waypoint(
                plant, w, setpoint, phase_steps, s.tolerance)
            if stop >= 0:
                status = stop
                break
        # Skill._phase_complete (and the wipe's ready): stop where it might pass
        settled = motion <= s.gripper_still or (s.gripper_timeout >= 0 and phase_steps >= s.gripper_timeout)
        if settled and ready and phase_steps >= s.min_steps:
            e0, e1, e2 = eef_pos[0] - p0, eef_pos[1] - p1, eef_pos[2] - p2
            distance = np.sqrt(e0 * e0 + e1 * e1 + (0.0 if s.xy_only else e2 * e2))
            if not distance * (1.0 - POSITION_CHECK_RTOL) > tolerance:
                status = PHASE_MAYBE_COMPLETE
                break
        # the step is taken
        if not fixed:
            w.depth = depth
            w.force = force
            w.lifted = lifted
            target[0], target[1], target[2] = p0, p1, p2
        for i in range(finger_index.size):
            fingers[i] = qpos[finger_index[i]]
        yaw_setpoint = advance_command(setpoint, yaw_setpoint, s.yaw, target, s.max_move, s.max_turn, s.gripper,
                                       action)
        steps += 1
        phase_steps += 1
        goal_pos[:] = action[0:3]
        rotvec_matrix(action[3:6], goal_ori)
        grip = grip_table[min(ran, grip_table.shape[0] - 1)]
        if logging:
            for f in range(len(log)):
                log[f][ran, :] = plant.log_live[f]
        # np.int64(0), not the literal 0: a literal argument would compile a second specialisation of native_substeps
        done = native_substeps(plant, dirt, np.int64(0), goal_pos, goal_ori, grip)
        ran += 1
        if done < 0:
            status = PHASE_WIPE
            substep = -done - 1
            break
    s.yaw_setpoint = yaw_setpoint
    s.steps = steps
    s.phase_steps = phase_steps
    return status, ran, substep


class ControlStepLog:
    """The simulation state (mjData's `LOG_FIELDS`) at the start of every control step a stepper runs.

    ``stepper.state_log = ControlStepLog(stepper)``: the per-step path and the compiled control loop both
    append a row per control step.
    """

    def __init__(self, stepper: "FastSkillStepper"):
        self._data = stepper.data
        self.rows = 0
        self._arrays = tuple(np.empty((0, getattr(self._data, f).size)) for f in LOG_FIELDS)

    def reserve(self, rows: int) -> tuple[np.ndarray, ...]:
        """The (capacity, size) arrays, grown to hold at least ``rows`` more rows."""
        need = self.rows + rows
        if need > self._arrays[0].shape[0]:
            capacity = max(need, 2 * self._arrays[0].shape[0])
            grown = tuple(np.empty((capacity, old.shape[1])) for old in self._arrays)
            for new, old in zip(grown, self._arrays):
                new[: self.rows] = old[: self.rows]
            self._arrays = grown
        return self._arrays

    def append(self) -> None:
        """Record the current state as the next row."""
        for array, field in zip(self.reserve(1), LOG_FIELDS):
            array[self.rows] = getattr(self._data, field)
        self.rows += 1

    def states(self) -> list[dict[str, np.ndarray]]:
        """One dict per logged control step: field name -> the field's values (copies)."""
        return [{f: array[row].copy() for f, array in zip(LOG_FIELDS, self._arrays)} for row in range(self.rows)]


def native_available() -> bool:
    """Whether the native substep loop (MuJoCo's C API called from numba) can be used here."""
    try:
        mujoco_function_addresses()
    except OSError:
        return False
    return True


def _check_supported(env) -> None:
    """Raise ``NotImplementedError`` unless ``env`` uses the configuration the fast path reproduces."""
    if len(env.robots) != 1 or len(env.robots[0].arms) != 1:
        raise NotImplementedError("the fast control path supports one robot with one arm")
    robot = env.robots[0]
    arm = robot.arms[0]
    controllers = robot.composite_controller.part_controllers
    osc = controllers.get(arm)
    grip = controllers.get(robot.get_gripper_name(arm))
    checks = {
        "lite_physics": env.lite_physics,
        "an OSC arm controller": isinstance(osc, OperationalSpaceController),
        "a simple grip gripper controller": isinstance(grip, SimpleGripController),
    }
    if isinstance(osc, OperationalSpaceController):
        checks.update({
            "OSC_POSE (orientation control)": osc.use_ori,
            "absolute input": osc.input_type == "absolute",
            "world-frame input": osc.input_ref_frame == "world",
            "fixed impedance": osc.impedance_mode == "fixed",
            "no OSC interpolators": osc.interpolator_pos is None and osc.interpolator_ori is None,
            "no OSC goal limits": osc.position_limits is None and not np.array(osc.orientation_limits).any(),
        })
    if isinstance(grip, SimpleGripController):
        checks["no gripper interpolator"] = grip.interpolator is None
    missing = [name for name, ok in checks.items() if not ok]
    if missing:
        raise NotImplementedError(f"the fast control path needs {', '.join(missing)}")


class FastSkillStepper:
    """Executes control steps of a skill env with robosuite's OSC_POSE law, without its per-substep Python.

    Args:
        env: a TableClean env made by [`make_skill_env`][tableclean_suite.controllers.make.make_skill_env].
        native: run the substeps in the compiled loop calling MuJoCo's C API (``None``: when
            [`native_available`][tableclean_suite.controllers.fast_control.native_available]); ``False``:
            in Python through the mujoco bindings (same results, slower).
        phase_loop: let [`run_phase`][tableclean_suite.controllers.fast_control.FastSkillStepper.run_phase]
            run phases in the compiled loop (needs ``native``); ``False``: every step through
            [`step`][tableclean_suite.controllers.fast_control.FastSkillStepper.step] (same results).

    Attributes: ``state_log`` (a [`ControlStepLog`][tableclean_suite.controllers.fast_control.ControlStepLog]
    or None), ``callback_seconds`` (s the compiled loop spent in the skill's force callback, which a
    caller timing the physics subtracts), ``last_status`` (the ``PHASE_*`` stop reason of the last
    compiled loop).  The env keeps working with ``env.step`` in between; new controllers (each reset)
    and a new simulation (hard reset) are picked up.
    """

    def __init__(self, env, native: bool | None = None, phase_loop: bool = True):
        require_checked_versions()
        _check_supported(env)
        self.env = env
        self.native = native_available() if native is None else bool(native)
        self.phase_loop = bool(phase_loop)
        self.state_log: ControlStepLog | None = None
        self.callback_seconds = 0.0
        self.last_status = PHASE_LIMIT
        self._sim = None
        self._bind()

    def _bind(self) -> None:
        """Cache the simulation's ids, index arrays, data views and buffers in the plant (again after a hard reset)."""
        env = self.env
        sim = env.sim
        robot = env.robots[0]
        arm = robot.arms[0]
        self._find_controllers()
        model, self.model, self.data = sim.model, mj_model(sim), mj_data(sim)
        data = self.data
        base_site = model.site_name2id(f"{self.osc.naming_prefix}{self.osc.part_name}_center")
        if self.model.body_weldid[self.model.site_bodyid[base_site]] != 0:
            raise NotImplementedError("the fast control path needs the arm's base welded to the world")
        site_id = model.site_name2id(self.osc.ref_name)
        arm_actuators = np.asarray(actuator_indexes(robot, arm), dtype=np.int64)
        grip_actuators = np.asarray(actuator_indexes(robot, self.grip_controller.part_name), dtype=np.int64)
        ctrlrange = self.model.actuator_ctrlrange
        self.grip_limits = np.ascontiguousarray(ctrlrange[grip_actuators].T)  # (2, G) low, high
        self.substeps = int(env.control_timestep / env.model_timestep)
        self._no_log = tuple(np.empty((0, getattr(data, f).size)) for f in LOG_FIELDS)
        self._plant_key = (None,) * 4  # (osc, kp, kd, initial_joint) of the plant's law
        # the env's own early exit in record_wiping_substep: below this height it must decide
        contact = max(float(env.task_config["wipe_contact_dist"]), 0.0)
        native, nv = self.native, self.model.nv
        self._plant = Plant(
            functions=mujoco_function_addresses() if native else (0, 0, 0, 0),
            model=c_address(self.model) if native else 0, data=c_address(data) if native else 0,
            substeps=self.substeps, full_mass=np.zeros((nv, nv)), jacp=np.zeros((3, nv)), jacr=np.zeros((3, nv)),
            torques=np.zeros(len(arm_actuators)), q_m=data.qM, qpos=data.qpos, qvel=data.qvel,
            qfrc_bias=data.qfrc_bias, ctrl=data.ctrl, site_id=int(site_id), site_pos=data.site_xpos[site_id],
            site_mat=data.site_xmat[site_id], eef_pos=data.site_xpos[robot.eef_site_id[arm]],
            finger_index=np.asarray(gripper_joint_pos_indexes(robot, arm), dtype=np.int64),
            sponge_pos=data.xpos[env.sponge_body_id], sponge_mat=data.xmat[env.sponge_body_id],
            sponge_half=np.asarray(env.task_config["sponge_half_size"], dtype=float),
            wipe_z=float(env.geometry.table_top_z) + contact + PRESS_PREFILTER_SLACK,
            marker_reach=float(env.task_config["wipe_marker_reach"]),
            indexes=np.array([self.osc.qvel_index, self.osc.qpos_index], dtype=np.int64),
            arm_actuators=arm_actuators, grip_actuators=grip_actuators,
            limits=np.ascontiguousarray(ctrlrange[arm_actuators].T), gains=np.zeros((2, 6)),
            initial_joint=np.zeros(len(arm_actuators)), uncouple=False,
            log_live=tuple(getattr(data, f) for f in LOG_FIELDS),
        )
        self._sim = sim

    def _find_controllers(self) -> None:
        """The robot's current OSC, gripper controller and gripper (robosuite makes new controllers at each reset)."""
        robot = self.env.robots[0]
        arm = robot.arms[0]
        controllers = robot.composite_controller.part_controllers
        self.osc = controllers[arm]
        self.grip_controller = controllers[robot.get_gripper_name(arm)]
        self.gripper = robot.gripper[arm]

    def _refresh(self) -> None:
        """Follow a new simulation (hard reset) or new controllers (each reset)."""
        if self.env.sim is not self._sim:
            self._bind()
        else:
            self._find_controllers()

    def _current_plant(self) -> Plant:
        """The plant with the current OSC's law, rebuilt when the OSC or its kp, kd or posture arrays are new
        (fixed impedance: robosuite never changes them in place)."""
        osc = self.osc
        key = (osc, osc.kp, osc.kd, osc.initial_joint)
        if any(map(operator.is_not, key, self._plant_key)):
            self._plant = self._plant._replace(gains=np.array((osc.kp, osc.kd), dtype=float),
                                               initial_joint=np.asarray(osc.initial_joint, dtype=float),
                                               uncouple=bool(osc.uncoupling))
            self._plant_key = key
        return self._plant

    def goal(self, action: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Goal position (3,) m and rotation matrix (3, 3) of the absolute world-frame ``action`` (7,), as robosuite."""
        goal_pos = np.array(action[0:3], dtype=float)
        goal_ori = np.empty((3, 3))
        rotvec_matrix(np.ascontiguousarray(action[3:6], dtype=float), goal_ori)
        return goal_pos, goal_ori

    def gripper_ctrl(self, action: np.ndarray) -> np.ndarray:
        """Finger actuator controls (G,) for ``action``'s gripper command; advances the gripper's state.

        As robosuite's policy step: ``gripper.format_action`` (rate-limited command), the controller's
        input scaling, its mapping onto the actuators' control range and the robot's clipping to it.
        """
        controller, gripper = self.grip_controller, self.gripper
        goal_qvel = gripper.format_action(np.asarray(action[GRIPPER_INDEX:], dtype=float))
        if controller.use_action_scaling:
            goal_qvel = controller.scale_action(goal_qvel)
        controller.goal_qvel = goal_qvel
        desired = np.array(goal_qvel, dtype=float)
        if controller.use_action_scaling:
            low, high = controller.actuator_min, controller.actuator_max
            desired = 0.5 * (high + low) + 0.5 * (high - low) * desired
        return np.minimum(np.maximum(desired, self.grip_limits[0]), self.grip_limits[1])

    def arm_torques(self, goal_pos: np.ndarray, goal_ori: np.ndarray) -> np.ndarray:
        """OSC torques (n,) N m, unclipped, for the current simulation data (after ``mj_step1`` or ``mj_forward``);
        the plant's ``torques`` array, overwritten on the next call."""
        plant = self._current_plant()
        mujoco.mj_fullM(self.model, plant.full_mass, self.data.qM)
        mujoco.mj_jacSite(self.model, self.data, plant.jacp, plant.jacr, plant.site_id)
        osc_torques(plant, goal_pos, goal_ori)
        return plant.torques

    def cached_arm_torques(self, goal_pos: np.ndarray, goal_ori: np.ndarray) -> np.ndarray:
        """OSC torques (n,) N m, unclipped, from the arm state robosuite's OSC cached at its last ``update()``.

        Right after a reset robosuite's controller does not re-read the simulation (its ``new_update``
        is off), so the episode's first substep uses the arm state cached at the reset.
        """
        osc, plant = self.osc, self._current_plant()
        arm = ArmState(
            mass=np.ascontiguousarray(osc.mass_matrix), j_full=np.ascontiguousarray(osc.J_full),
            ref_pos=np.asarray(osc.ref_pos, dtype=float), ref_ori_mat=np.ascontiguousarray(osc.ref_ori_mat),
            ref_vel=np.concatenate([osc.ref_pos_vel, osc.ref_ori_vel]),
            joint_pos=np.asarray(osc.joint_pos, dtype=float), joint_vel=np.asarray(osc.joint_vel, dtype=float),
            bias=self.data.qfrc_bias[plant.indexes[0]],  # robosuite reads the compensation live
        )
        osc_law(arm, goal_pos, goal_ori, plant)
        return plant.torques

    def step(self, action) -> None:
        """One control step (``control_timestep`` s of physics) towards the absolute command ``action`` (7,).

        Raises ``ValueError`` for a wrong action shape or when the env's episode is done (as ``env.step``).
        """
        env = self.env
        if env.done:
            raise ValueError("executing action in terminated episode")
        action = np.asarray(action, dtype=float)
        if action.shape != (ACTION_DIM,):
            raise ValueError(f"action must have shape ({ACTION_DIM},), got {action.shape}")
        self._refresh()
        env.timestep += 1
        if self.state_log is not None:
            self.state_log.append()
        goal_pos, goal_ori = self.goal(action)
        grip_ctrl = self.gripper_ctrl(action)
        first = 0
        if not controller_needs_update(self.osc):  # robosuite reuses its cached arm state once
            self._python_substep(0, goal_pos, goal_ori, grip_ctrl, cached=True)
            first = 1
        if self.native:
            self._native_substeps(first, goal_pos, goal_ori, grip_ctrl)
        else:
            for substep in range(first, self.substeps):
                self._python_substep(substep, goal_pos, goal_ori, grip_ctrl)
        # what env.step does once per control step and later steps rely on
        env.show_dirt()
        env.done = (env.timestep >= env.horizon) and not env.ignore_done
        advance_clock(env, env.control_timestep)
        hand_back_controller_state(self.osc, self.grip_controller, goal_pos, goal_ori, self._plant.torques)

    def run_phase(self, skill: np.ndarray, fingers: np.ndarray, wipe: np.ndarray | None = None, force=None) -> int:
        """Run control steps of a skill phase in the compiled
        [`control_loop`][tableclean_suite.controllers.fast_control.control_loop]; returns how many ran
        (``last_status``: why it stopped).

        ``skill``: the skill's (1,) `SKILL_STATE` record (its ``target`` a fixed phase's waypoint); ``fingers``: (F,)
        its finger positions at the last step; both updated in place.  ``wipe``: None for a fixed waypoint, else
        the clean skill's PRESS, WIPE or SHIFT as a (1,) `WIPE_STATE` record, updated in place (its ``force_fn``
        set here), with ``force`` returning the sponge's press force (N), called once per control step (an
        exception it raises is raised here after the loop stopped).  Runs nothing (returns 0) without the native
        loop, with ``phase_loop`` off, for a gripper other than the Panda's, on the first step after a reset or
        when the episode is done.
        """
        if wipe is None:
            return self._run_compiled(skill, fingers, np.zeros(1, WIPE_STATE))  # mode MODE_FIXED
        errors = []

        def measured() -> float:
            start = time.perf_counter()
            try:
                return force()
            except BaseException as error:  # noqa: BLE001 (raised again below, outside the compiled loop)
                errors.append(error)
                return np.nan
            finally:
                self.callback_seconds += time.perf_counter() - start

        callback = FORCE_CALLBACK(measured)  # kept alive while the loop runs
        wipe["force_fn"] = ctypes.cast(callback, ctypes.c_void_p).value
        ran = self._run_compiled(skill, fingers, wipe)
        if errors:
            raise errors[0]
        return ran

    def _run_compiled(self, skill: np.ndarray, fingers: np.ndarray, wipe: np.ndarray) -> int:
        """Run [`control_loop`][tableclean_suite.controllers.fast_control.control_loop] on the skill's state; sets ``last_status``."""
        env = self.env
        self.last_status = PHASE_LIMIT
        if not (self.native and self.phase_loop) or env.done:
            return 0
        self._refresh()
        if type(self.gripper).format_action is not PandaGripper.format_action or not controller_needs_update(self.osc):
            return 0
        limit = np.iinfo(np.int64).max if env.ignore_done else env.horizon - env.timestep
        table, states, settled = self._grip_table(float(skill["gripper"][0]))
        if not settled:
            limit = min(limit, len(table))
        plant = self._current_plant()
        markers = np.ascontiguousarray(env._marker_xyz, dtype=float)
        goal = (np.empty(ACTION_DIM), np.empty(3), np.empty((3, 3)))  # new arrays: the OSC keeps the goal's
        log = self.state_log
        total = 0
        status = PHASE_LIMIT
        while total < limit:
            present = np.ascontiguousarray(env.dirt.present())  # changes only in the env's wiping check
            if log is None:
                arrays = self._no_log
            else:
                budget = int(skill["max_steps"][0] - skill["steps"][0])
                arrays = tuple(a[log.rows:] for a in log.reserve(min(limit - total, budget)))
            status, ran, substep = control_loop(plant, (markers, present), skill, fingers, wipe,
                                                table[min(total, len(table) - 1):], goal, arrays, limit - total)
            if log is not None:
                log.rows += ran
            if status == PHASE_WIPE:  # finish that step: the env's wiping check, mj_step2, the other substeps
                self._native_substeps(-(substep + 1), goal[1], goal[2], table[min(total + ran - 1, len(table) - 1)])
            for _ in range(ran):
                env.timestep += 1
                advance_clock(env, env.control_timestep)
            env.show_dirt()
            total += ran
            if status != PHASE_WIPE:
                break
        self.last_status = status
        if total:
            current_action, goal_qvel = states[min(total, len(states)) - 1]
            set_gripper_state(self.gripper, self.grip_controller, current_action.copy(), goal_qvel.copy())
            env.done = (env.timestep >= env.horizon) and not env.ignore_done
            hand_back_controller_state(self.osc, self.grip_controller, goal[1], goal[2], plant.torques)
        return total

    def _grip_table(self, command: float) -> tuple[np.ndarray, list, bool]:
        """Gripper actuator controls (rows, G) of the next control steps under the constant gripper ``command``.

        Runs robosuite's gripper code ahead, then restores the gripper's state.  Returns (rows, the
        gripper's (current_action, goal_qvel) after each row, settled): ``settled`` when the last row
        repeats forever, else the table covers only its `GRIP_TABLE_ROWS` steps.
        """
        gripper, controller = self.gripper, self.grip_controller
        saved = (np.array(gripper.current_action, dtype=float), controller.goal_qvel)
        action = np.zeros(ACTION_DIM)
        action[GRIPPER_INDEX] = command
        rows, states, settled = [], [], False
        for _ in range(GRIP_TABLE_ROWS):
            rows.append(self.gripper_ctrl(action))
            states.append((np.array(gripper.current_action, dtype=float), np.array(controller.goal_qvel, dtype=float)))
            if len(rows) > 1 and np.array_equal(rows[-1], rows[-2]) and np.array_equal(states[-1][0], states[-2][0]):
                settled = True
                break
        set_gripper_state(gripper, controller, *saved)
        return np.ascontiguousarray(rows, dtype=float), states, settled

    def _python_substep(self, substep: int, goal_pos, goal_ori, grip_ctrl, cached: bool = False) -> None:
        """One physics substep through the mujoco bindings: step1, control, wiping check, step2."""
        model, data, plant = self.model, self.data, self._plant
        mujoco.mj_step1(model, data)
        torques = (self.cached_arm_torques if cached else self.arm_torques)(goal_pos, goal_ori)
        data.ctrl[plant.arm_actuators] = np.clip(torques, plant.limits[0], plant.limits[1])
        if substep == 0:
            data.ctrl[plant.grip_actuators] = grip_ctrl
        self.env.record_wiping_substep()
        mujoco.mj_step2(model, data)

    def _native_substeps(self, first: int, goal_pos, goal_ori, grip_ctrl) -> None:
        """Substeps ``first``.. of the control step in the compiled loop; the env checks wiping near the table
        (``first`` < 0, as `native_substeps` returns: substep ``-first - 1`` stopped there, finished first)."""
        plant = self._current_plant()
        done = first
        markers = np.ascontiguousarray(self.env._marker_xyz, dtype=float)
        while done < self.substeps:
            if done < 0:  # stopped after substep -done - 1's control: the env checks wiping, then step2
                done = -done
                self.env.record_wiping_substep()
                mujoco.mj_step2(self.model, self.data)
            else:
                present = np.ascontiguousarray(self.env.dirt.present())  # changes only in the wiping check
                done = native_substeps(plant, (markers, present), done, goal_pos, goal_ori, grip_ctrl)


#: Attribute under which [`attach_fast_stepper`][tableclean_suite.controllers.fast_control.attach_fast_stepper] stores an env's stepper.
STEPPER_ATTRIBUTE = "fast_stepper"


def attach_fast_stepper(env, native: bool | None = None) -> FastSkillStepper | None:
    """Give ``env`` a [`FastSkillStepper`][tableclean_suite.controllers.fast_control.FastSkillStepper] (``env.fast_stepper``), which the SkillController then uses.

    On robosuite / MuJoCo versions the adapter was not checked against attaches nothing, warns once per
    process and returns ``None`` (the env runs on ``env.step``).  Raises ``NotImplementedError`` when
    the env's controllers are not the ones the fast path reproduces.
    """
    if not fast_path_allowed():
        return None
    stepper = FastSkillStepper(env, native=native)
    setattr(env, STEPPER_ATTRIBUTE, stepper)
    return stepper


def fast_stepper_of(env) -> FastSkillStepper | None:
    """The stepper [`attach_fast_stepper`][tableclean_suite.controllers.fast_control.attach_fast_stepper] gave ``env``, or ``None`` (then ``env.step`` is the path)."""
    return getattr(env, STEPPER_ATTRIBUTE, None)
