"""A fast control path for the skills: robosuite's OSC_POSE control law without its per-substep Python.

robosuite's ``env.step`` spends most of its time in Python around the physics: per
physics substep it rebuilds the arm's Jacobians and mass matrix through several
wrapper layers, runs the OSC and the gripper controller, re-checks action limits
and updates every observable.  [`FastSkillStepper`][tableclean_suite.controllers.fast_control.FastSkillStepper] executes one control step
of a skill env ([`make_skill_env`][tableclean_suite.controllers.make.make_skill_env]) for an
absolute world-frame command ``[x, y, z, rx, ry, rz, gripper]`` with the *same*
control law:

- once per control step (robosuite's ``policy_step``): the goal pose from the
  command (``Rotation.from_rotvec``, as robosuite's absolute OSC), the gripper's
  ``format_action`` (its rate-limited internal command) and its ``SimpleGripController``
  mapping to the finger actuators' control range;
- per physics substep, as ``MujocoEnv.step`` with ``lite_physics``: ``mj_step1``;
  the OSC torques from MuJoCo's own mass matrix (``mj_fullM``) and grip-site
  Jacobians (``mj_jacSite``), computed in a numba kernel that writes out robosuite's
  ``orientation_error`` and ``nullspace_torques`` and mirrors its ``opspace_matrices``
  with Cholesky inverses of the positive definite matrices (robosuite's SVD
  pseudo-inverses near a singularity), small products in plain loops and few
  temporaries (numpy's ``dot`` per product and the allocations cost more than the arithmetic): same kp, kd, decoupling,
  nullspace pull towards the controller's ``initial_joint``, gravity compensation,
  clipping to the actuators' ctrlrange, and robosuite's reuse of the reset-time arm
  state on an episode's first substep ([`FastSkillStepper.cached_arm_torques`][tableclean_suite.controllers.fast_control.FastSkillStepper.cached_arm_torques]);
  the env's wiping check; ``mj_step2``.  With the native loop (default when MuJoCo's
  shared library is found) the substeps run in one compiled function that calls
  MuJoCo's C API directly and returns to Python only for substeps where the sponge is
  near the table top over a marker not yet wiped, so the env's own wiping check
  (``record_wiping_substep()``) decides (elsewhere that check changes nothing);
- once per control step at the end: the env's timestep and clock, the hidden dirt
  markers, and the controllers' goal and refresh state, so ``env.step`` can take over.

A phase the skill can hand over runs further: after the skill's first Python step in it,
[control_loop][tableclean_suite.controllers.fast_control.control_loop] runs its control steps
in one compiled call.  Per step: the skill's checks, its waypoint, its setpoint and command
([advance_command][tableclean_suite.controllers.setpoint.advance_command], the function the
skill's own step uses), the gripper control (robosuite's rate-limited command tabulated ahead),
the substeps as above, and a state log ([ControlStepLog][tableclean_suite.controllers.fast_control.ControlStepLog]).
The skill's state arrives as typed records
(`SKILL_STATE`,
`WIPE_STATE`).  Two kinds of phase run there:

- a phase whose waypoint is fixed (``Waypoint.fixed``: the grasp's CLOSE, the release's RELEASE;
  [FastSkillStepper.run_phase][tableclean_suite.controllers.fast_control.FastSkillStepper.run_phase]);
- the clean skill's PRESS, WIPE and SHIFT, whose waypoint follows the measured press force and
  the sponge ([FastSkillStepper.run_press_phase][tableclean_suite.controllers.fast_control.FastSkillStepper.run_press_phase],
  from ``Wipe.run_loop``): the wipe's force loop and waypoint, the same operations on the same
  values; the press force is the env's own ``sponge_press_force()``, called back once per control
  step (`FORCE_CALLBACK`, timed in ``callback_seconds``).

The loop returns to Python only at the phase's boundary: before a step whose completion check
might pass (the skill then decides exactly), before a step it cannot take exactly (the sponge near
``contact_slack`` above the table), at the step budget or the env's horizon, and for substeps the
env's wiping check must see (then it resumes).  The results are bit-identical to the per-step path
(``FastSkillStepper.phase_loop = False``).

What the fast path does **not** do: it does not refresh robosuite's observables
(``env._get_observations(force_update=True)`` does), the robot's proprioception
history buffers (``recent_qpos``, ``recent_ee_*``), nor compute the reward.  The
skills read none of these: ``env.skill_info()`` and ``env.symbolic_state()`` read
the simulation data directly.

The kernels are compiled by numba on first use (~20-25 s, the control loop included) and cached
in ``__pycache__`` (later processes load them in ~0.2 s).

Only the configuration the skills use is supported (one fixed-base arm, OSC_POSE,
absolute world-frame input, fixed impedance, no interpolators, a simple grip
gripper); anything else raises ``NotImplementedError`` at construction.
"""

from __future__ import annotations

import ctypes
import time
from typing import NamedTuple

import mujoco
import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic
from robosuite.controllers.parts.arm.osc import OperationalSpaceController
from robosuite.controllers.parts.gripper.simple_grip import SimpleGripController
from robosuite.utils.control_utils import opspace_matrices

from robosuite.models.grippers.panda_gripper import PandaGripper

from tableclean_suite.controllers.loop_state import MODE_FIXED, MODE_SHIFT, MODE_WIPE, WIPE_STATE
from tableclean_suite.controllers.osc import ACTION_DIM
from tableclean_suite.controllers.setpoint import GRIPPER_INDEX, advance_command
from tableclean_suite.environments.table_clean import PRESS_PREFILTER_SLACK
from tableclean_suite.robosuite_adapter import (
    actuator_indexes,
    gripper_joint_pos_indexes,
    advance_clock,
    c_address,
    controller_needs_update,
    fast_path_allowed,
    finish_control_step,
    hand_back_controller_state,
    mj_data,
    mj_model,
    mujoco_function_addresses,
    require_checked_versions,
    set_gripper_state,
)

#: Slices of the skill action (7,): position (m), rotation vector (rad), gripper command in [-1, 1].
POS_SLICE, ROTVEC_SLICE, GRIPPER_SLICE = slice(0, 3), slice(3, 6), slice(6, 7)
#: Extra height (m) above the env's own wiping prefilter under which the native loop hands a substep
#: to the env's wiping check; any value >= 0 is exact (the env re-checks), larger ones cost time.
WIPE_CHECK_MARGIN = 0.0
#: A Cholesky pivot below this fraction of the largest diagonal entry sends the operational-space
#: matrices to robosuite's own SVD pseudo-inverses (near a singularity, where the two would differ).
CHOLESKY_PIVOT_RTOL = 1e-10
#: Slack (m) added to the env's marker reach when the native loop asks whether a present marker lies
#: under the sponge: a superset of the env's own test despite rounding, so the env still decides.
MARKER_REACH_SLACK = 1e-9
#: Joint stiffness (1/s^2) of robosuite's nullspace posture term (``nullspace_torques``' default ``joint_kp``).
NULLSPACE_JOINT_KP = 10.0
#: Rotation angle (rad) under which [`rotvec_matrix`][tableclean_suite.controllers.fast_control.rotvec_matrix] uses the Taylor series of sin(a/2)/a (as scipy).
ROTVEC_SMALL_ANGLE = 1e-3
#: Relative slack of the control loop's "this step cannot complete the phase" test on the position error: the
#: skill's own check (``np.linalg.norm``) may round differently, so the loop stops a little early and the skill decides.
POSITION_CHECK_RTOL = 1e-9
#: The control loop's stop reasons: a step whose completion check might pass (left to the skill), the skill's
#: step budget, the caller's step limit, a substep handed to the env's wiping check, a step whose update the
#: loop cannot take exactly (a wipe phase: the sponge's lowest corner may be above the table by more than
#: ``contact_slack``, or the measured force is NaN; left to the skill).
PHASE_MAYBE_COMPLETE, PHASE_BUDGET, PHASE_LIMIT, PHASE_WIPE, PHASE_HANDOFF = 0, 1, 2, 3, 4
#: m of slack of the control loop's "the sponge is on the table" test: the wipe's own gap (``Wipe._sponge_gap``,
#: from the sponge's quaternion) and the loop's (from its rotation matrix) differ by rounding (~1e-16 m); within
#: this band of ``contact_slack`` the loop hands the step to the skill, which decides exactly.
GAP_CHECK_SLACK = 1e-9
#: C type of the press-force callback the control loop calls once per wipe step (``double f(void)``, N).
FORCE_CALLBACK = ctypes.CFUNCTYPE(ctypes.c_double)
#: Most gripper control steps the control loop tabulates ahead (robosuite's rate-limited gripper command
#: reaches its fixed point within 1 / 0.2 = 5 steps per unit of command change, 10 at most for the Panda).
GRIP_TABLE_ROWS = 32
#: mjData fields [`ControlStepLog`][tableclean_suite.controllers.fast_control.ControlStepLog] records at the start of every control step (enough to replay it).
LOG_FIELDS = ("qpos", "qvel", "act", "ctrl", "qacc_warmstart")


class Plant(NamedTuple):
    """What the compiled kernels read and write of the simulation, and the arm's control law.

    Built by [FastSkillStepper][tableclean_suite.controllers.fast_control.FastSkillStepper] when it binds a
    simulation; the law's fields (``gains``, ``initial_joint``, ``uncouple``) are replaced when robosuite
    makes new controllers or gains.  Arrays are float64 unless noted; n arm joints, nv dofs.
    """

    functions: tuple  # addresses of mj_step1, mj_step2, mj_fullM, mj_jacSite
    model: int  # address of the C mjModel
    data: int  # address of the C mjData
    substeps: int  # physics substeps per control step
    full_mass: np.ndarray  # (nv, nv) scratch: mj_fullM's output
    jacp: np.ndarray  # (3, nv) scratch: the grip site's translational Jacobian
    jacr: np.ndarray  # (3, nv) scratch: its rotational Jacobian
    torques: np.ndarray  # (n,) output: the last OSC torques (N m), unclipped
    q_m: np.ndarray  # mjData views: qM
    qpos: np.ndarray  # (nq,)
    qvel: np.ndarray  # (nv,)
    qfrc_bias: np.ndarray  # (nv,)
    ctrl: np.ndarray  # (nu,)
    site_id: int  # the OSC's grip site
    site_pos: np.ndarray  # (3,) its world position (m), live
    site_mat: np.ndarray  # (9,) its row-major world rotation, live
    eef_pos: np.ndarray  # (3,) the skill's end-effector site position (m), live
    finger_index: np.ndarray  # (F,) int64 qpos indexes of the finger joints
    sponge_pos: np.ndarray  # (3,) the sponge's world position (m), live
    sponge_mat: np.ndarray  # (9,) its row-major world rotation, live
    sponge_half: np.ndarray  # (3,) its half size (m)
    wipe_z: float  # m: a substep whose sponge's lowest corner is below goes to the env's wiping check
    marker_reach: float  # m: the env's marker reach
    indexes: np.ndarray  # (2, n) int64 rows: the arm's dof (qvel) indexes, its qpos indexes
    arm_actuators: np.ndarray  # (n,) int64
    grip_actuators: np.ndarray  # (G,) int64
    limits: np.ndarray  # (2, n) the arm actuators' ctrl range (N m), low and high
    gains: np.ndarray  # (2, 6) the OSC's kp (1/s^2) and kd (1/s) rows, see osc_law
    initial_joint: np.ndarray  # (n,) rad, the nullspace term's posture
    uncouple: bool  # decouple the position and orientation wrenches
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

    scipy's ``Rotation.from_rotvec(rotvec).as_matrix()`` (robosuite's absolute OSC goal) with
    the same operations: the unit quaternion (Taylor series of sin(a/2)/a below
    `ROTVEC_SMALL_ANGLE`), then its matrix; bit-identical on scipy 1.17.
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

    Reads the lower triangle of ``a`` only; ``low`` and ``inv_low``: (>= n, >= n) scratch.  Returns
    False (``out`` undefined) when a pivot falls below `CHOLESKY_PIVOT_RTOL` times the largest
    diagonal entry.
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
    """``out = a @ b`` for small matrices, (n, k) times (k, m), in plain loops (numpy's dot calls BLAS per product)."""
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
    """``out = a @ x`` for a small matrix (n, k) and vector (k,), in plain loops."""
    n, k = a.shape
    for i in range(n):
        value = 0.0
        for p in range(k):
            value += a[i, p] * x[p]
        out[i] = value



class OscWork(NamedTuple):
    """The OSC kernels' temporaries for an arm of n joints (float64; m = max(n, 6)), made by [`osc_work`][tableclean_suite.controllers.fast_control.osc_work].

    Allocated once per call of the compiled loops instead of once per substep (~20 allocations per substep
    cost ~1-2 us of its ~4 us).  Every entry is written before it is read in each use (the orientation
    error is zeroed where it accumulates).
    """

    low: np.ndarray  # (m, m) Cholesky factor
    inv_low: np.ndarray  # (m, m) its inverse
    mass_inv: np.ndarray  # (n, n)
    lambda_full: np.ndarray  # (6, 6) operational-space inertia
    lambda_pos: np.ndarray  # (3, 3)
    lambda_ori: np.ndarray  # (3, 3)
    nullspace: np.ndarray  # (n, n) nullspace projector
    j_minv: np.ndarray  # (6, n) J M^-1
    lambda_full_inv: np.ndarray  # (6, 6)
    j_bar: np.ndarray  # (n, 6) M^-1 J^T lambda
    desired: np.ndarray  # (6,) desired force and torque
    error: np.ndarray  # (3,) orientation error
    wrench: np.ndarray  # (6,)
    posture: np.ndarray  # (n,) nullspace posture acceleration
    pose_torques: np.ndarray  # (n,)
    mass: np.ndarray  # (n, n) the arm's mass matrix gathered by osc_torques
    j_full: np.ndarray  # (6, n) its Jacobian
    joint_pos: np.ndarray  # (n,)
    joint_vel: np.ndarray  # (n,)
    bias: np.ndarray  # (n,)
    ref_vel: np.ndarray  # (6,) grip-site velocity


@numba.njit(cache=True)
def osc_work(n: int) -> OscWork:
    """The OSC kernels' scratch arrays for an arm of ``n`` joints ([`OscWork`][tableclean_suite.controllers.fast_control.OscWork])."""
    size = max(n, 6)
    return OscWork(np.empty((size, size)), np.empty((size, size)), np.empty((n, n)), np.empty((6, 6)), np.empty((3, 3)),
                   np.empty((3, 3)), np.empty((n, n)), np.empty((6, n)), np.empty((6, 6)), np.empty((n, 6)), np.empty(6),
                   np.empty(3), np.empty(6), np.empty(n), np.empty(n), np.empty((n, n)), np.empty((6, n)), np.empty(n),
                   np.empty(n), np.empty(n), np.empty(6))


@numba.njit(cache=True)
def _opspace_into(mass: np.ndarray, j_full: np.ndarray, work):
    """robosuite's ``opspace_matrices`` with Cholesky inverses of its symmetric positive definite matrices.

    Same formulas (M^-1; lambda = (J M^-1 J^T)^-1 for the full, position and orientation
    Jacobians; nullspace I - M^-1 J^T lambda J); where robosuite takes SVD pseudo-inverses the
    matrices are positive definite, so the inverses agree to rounding.  Falls back to
    robosuite's own function when any pivot is tiny (near a singularity).

    Args:
        mass: (n, n) arm mass matrix; j_full: (6, n) Jacobian, translational rows then rotational rows.
        work: the [OscWork][tableclean_suite.controllers.fast_control.OscWork] scratch for n joints.

    Returns:
        (lambda_full (6, 6), lambda_pos (3, 3), lambda_ori (3, 3), nullspace_matrix (n, n)): views of ``work``.
    """
    n = mass.shape[0]
    low, inv_low, mass_inv, nullspace_matrix = work.low, work.inv_low, work.mass_inv, work.nullspace
    lambda_full, lambda_pos, lambda_ori = work.lambda_full, work.lambda_pos, work.lambda_ori
    if spd_inverse(mass, mass_inv, low, inv_low):
        j_minv = work.j_minv
        small_matmul(j_full, mass_inv, j_minv)
        lambda_full_inv = work.lambda_full_inv
        small_matmul(j_minv, j_full.T, lambda_full_inv)
        ok = spd_inverse(lambda_full_inv, lambda_full, low, inv_low)
        ok = ok and spd_inverse(lambda_full_inv[0:3, 0:3], lambda_pos, low, inv_low)
        ok = ok and spd_inverse(lambda_full_inv[3:6, 3:6], lambda_ori, low, inv_low)
        if ok:
            j_bar = work.j_bar
            small_matmul(j_minv.T, lambda_full, j_bar)  # M^-1 J^T lambda (M^-1 symmetric)
            small_matmul(j_bar, j_full, nullspace_matrix)
            for i in range(n):
                for j in range(n):
                    nullspace_matrix[i, j] = (1.0 if i == j else 0.0) - nullspace_matrix[i, j]
            return lambda_full, lambda_pos, lambda_ori, nullspace_matrix
    exact = opspace_matrices(mass, j_full, np.ascontiguousarray(j_full[0:3]), np.ascontiguousarray(j_full[3:6]))
    lambda_full[:] = exact[0]
    lambda_pos[:] = exact[1]
    lambda_ori[:] = exact[2]
    nullspace_matrix[:] = exact[3]
    return lambda_full, lambda_pos, lambda_ori, nullspace_matrix


@numba.njit(cache=True)
def osc_law(arm, goal_pos: np.ndarray, goal_ori: np.ndarray, plant, work=None) -> None:
    """robosuite's ``OperationalSpaceController.run_controller`` torques for an absolute world-frame goal.

    Args:
        arm: the arm's [ArmState][tableclean_suite.controllers.fast_control.ArmState].
        goal_pos: (3,) goal position (m); goal_ori: (3, 3) goal rotation matrix, world frame.
        plant: the stepper's [Plant][tableclean_suite.controllers.fast_control.Plant]: the law's ``gains``
            (rows kp (1/s^2) and kd (1/s), columns x, y, z, rx, ry, rz), ``initial_joint`` (the posture the
            nullspace term pulls towards) and ``uncouple`` (robosuite's ``uncouple_pos_ori``); the torques
            (n,) N m, before clipping to the actuators' range, are written to ``plant.torques``.
        work: the [OscWork][tableclean_suite.controllers.fast_control.OscWork] scratch for n joints (the compiled
            loops pass theirs, allocated once for all substeps); None: allocated for this call.

    The base velocity term of robosuite's law is zero here: callers check that the arm's
    base is welded to the world.  robosuite's ``orientation_error`` and ``nullspace_torques``
    (joint kp `NULLSPACE_JOINT_KP`, critical damping) are written out with the same
    formulas, without temporaries; the small products run in plain loops ([`small_matmul`][tableclean_suite.controllers.fast_control.small_matmul]).
    """
    mass, j_full, ref_pos, ref_ori_mat, ref_vel, joint_pos, joint_vel, bias = arm
    gains, initial_joint, torques = plant.gains, plant.initial_joint, plant.torques
    if work is None:
        work = osc_work(mass.shape[0])
    n = mass.shape[0]
    desired = work.desired  # desired force (3) and torque (3)
    for r in range(3):
        desired[r] = (goal_pos[r] - ref_pos[r]) * gains[0, r] + (-ref_vel[r]) * gains[1, r]
    error = work.error  # robosuite's orientation_error: half the sum of the columns' cross products
    error[0] = 0.0
    error[1] = 0.0
    error[2] = 0.0
    for c in range(3):
        a0, a1, a2 = ref_ori_mat[0, c], ref_ori_mat[1, c], ref_ori_mat[2, c]
        b0, b1, b2 = goal_ori[0, c], goal_ori[1, c], goal_ori[2, c]
        error[0] += a1 * b2 - a2 * b1
        error[1] += a2 * b0 - a0 * b2
        error[2] += a0 * b1 - a1 * b0
    for r in range(3):
        desired[3 + r] = 0.5 * error[r] * gains[0, 3 + r] + (-ref_vel[3 + r]) * gains[1, 3 + r]
    lambda_full, lambda_pos, lambda_ori, nullspace_matrix = _opspace_into(mass, j_full, work)
    wrench = work.wrench
    if plant.uncouple:
        small_matvec(lambda_pos, desired[0:3], wrench[0:3])
        small_matvec(lambda_ori, desired[3:6], wrench[3:6])
    else:
        small_matvec(lambda_full, desired, wrench)
    small_matvec(j_full.T, wrench, torques)
    joint_kv = np.sqrt(NULLSPACE_JOINT_KP) * 2
    posture = work.posture
    for i in range(n):
        posture[i] = NULLSPACE_JOINT_KP * (initial_joint[i] - joint_pos[i]) - joint_kv * joint_vel[i]
    pose_torques = work.pose_torques
    small_matvec(mass, posture, pose_torques)
    for i in range(n):
        value = 0.0
        for k in range(n):
            value += nullspace_matrix[k, i] * pose_torques[k]
        torques[i] = (torques[i] + bias[i]) + value


@numba.njit(cache=True)
def osc_torques(plant, goal_pos: np.ndarray, goal_ori: np.ndarray, work=None) -> None:
    """[`osc_law`][tableclean_suite.controllers.fast_control.osc_law] on MuJoCo's whole-model arrays, gathering the arm's entries as robosuite's ``update()``.

    Reads the [Plant][tableclean_suite.controllers.fast_control.Plant]'s ``full_mass`` (``mj_fullM`` of
    ``qM``), ``jacp`` and ``jacr`` (``mj_jacSite`` of the grip site), ``qpos``, ``qvel``, ``qfrc_bias``,
    the grip site's ``site_pos`` and ``site_mat`` and the arm's ``indexes``; writes ``plant.torques``.
    ``goal_pos``, ``goal_ori``: as [`osc_law`][tableclean_suite.controllers.fast_control.osc_law]; ``work``: as there (its entries for the arm's n joints
    are this function's scratch, too).
    """
    indexes, jacp, jacr, qvel = plant.indexes, plant.jacp, plant.jacr, plant.qvel
    if work is None:
        work = osc_work(indexes.shape[1])
    dofs = indexes[0]
    n = dofs.size
    mass, j_full, joint_pos, joint_vel, bias = work.mass, work.j_full, work.joint_pos, work.joint_vel, work.bias
    for i in range(n):
        for k in range(n):
            mass[i, k] = plant.full_mass[dofs[i], dofs[k]]
        for r in range(3):
            j_full[r, i] = jacp[r, dofs[i]]
            j_full[r + 3, i] = jacr[r, dofs[i]]
        joint_pos[i] = plant.qpos[indexes[1, i]]
        joint_vel[i] = qvel[dofs[i]]
        bias[i] = plant.qfrc_bias[dofs[i]]
    ref_vel = work.ref_vel
    small_matvec(jacp, qvel, ref_vel[0:3])  # robosuite's get_site_xvelp: the full Jacobian times all velocities
    small_matvec(jacr, qvel, ref_vel[3:6])
    ref_ori_mat = np.ascontiguousarray(plant.site_mat.reshape((3, 3)))
    arm = ArmState(mass, j_full, plant.site_pos, ref_ori_mat, ref_vel, joint_pos, joint_vel, bias)
    osc_law(arm, goal_pos, goal_ori, plant, work)


def _c_call_codegen(n_pointers: int, trailing_int: bool):
    """LLVM code calling ``void f(void*, ... n_pointers, [int])`` at the address in the first argument.

    The address and the pointers arrive as integers, so the functions using it stay cacheable
    (no address is baked into the compiled code).
    """

    def codegen(context, builder, sig, llvm_args):
        void_ptr = ir.IntType(8).as_pointer()
        params = [void_ptr] * n_pointers + ([ir.IntType(32)] if trailing_int else [])
        fn = builder.inttoptr(llvm_args[0], ir.FunctionType(ir.VoidType(), params).as_pointer())
        values = [builder.inttoptr(v, void_ptr) for v in llvm_args[1:1 + n_pointers]]
        builder.call(fn, values + ([llvm_args[-1]] if trailing_int else []))
        return context.get_dummy_value()

    return codegen


@intrinsic
def _call_2(typingctx, fn, a, b):
    """``fn(a, b)`` for C ``void f(void*, void*)`` (mj_step1, mj_step2); all arguments integers."""
    return types.void(types.intp, types.intp, types.intp), _c_call_codegen(2, trailing_int=False)


@intrinsic
def _call_3(typingctx, fn, a, b, c):
    """``fn(a, b, c)`` for C ``void f(void*, void*, void*)`` (mj_fullM)."""
    return types.void(types.intp, types.intp, types.intp, types.intp), _c_call_codegen(3, trailing_int=False)


@intrinsic
def _call_4i(typingctx, fn, a, b, c, d, i):
    """``fn(a, b, c, d, i)`` for C ``void f(void*, void*, void*, void*, int)`` (mj_jacSite)."""
    signature = types.void(types.intp, types.intp, types.intp, types.intp, types.intp, types.int32)
    return signature, _c_call_codegen(4, trailing_int=True)



@numba.njit(cache=True)
def native_substeps(plant, dirt, first, goal_pos, goal_ori, grip_ctrl):
    """Run substeps ``first``..``plant.substeps - 1``: step1, OSC torques, ctrl, [wiping hand-off], step2.

    Args:
        plant: the stepper's [Plant][tableclean_suite.controllers.fast_control.Plant].
        dirt: (markers (N, 3) dirt marker world positions (m), present (N,) bool: not yet wiped).
        first: the first substep to run (int64).
        goal_pos: (3,) goal position (m); goal_ori: (3, 3) goal rotation matrix, world frame.
        grip_ctrl: (G,) gripper actuator controls, written at substep 0.

    The env's wiping check changes something only for a present marker under the sponge, so only
    a substep whose sponge is below ``plant.wipe_z`` over such a marker is handed to it.

    Returns ``plant.substeps`` when done, or ``-(k + 1)`` after substep k's control when the caller
    must run the env's wiping check and ``mj_step2`` for it, then call again from ``k + 1``.
    """
    step1, step2, full_m, jac_site = plant.functions
    markers, present = dirt
    arm_act, grip_act, ctrl = plant.arm_actuators, plant.grip_actuators, plant.ctrl
    torques, limits = plant.torques, plant.limits
    work = osc_work(plant.indexes.shape[1])  # the OSC's temporaries, once for all substeps
    for k in range(first, plant.substeps):
        _call_2(step1, plant.model, plant.data)
        _call_3(full_m, plant.model, plant.full_mass.ctypes.data, plant.q_m.ctypes.data)
        _call_4i(jac_site, plant.model, plant.data, plant.jacp.ctypes.data, plant.jacr.ctypes.data,
                 np.int32(plant.site_id))
        osc_torques(plant, goal_pos, goal_ori, work)
        for i in range(arm_act.size):
            ctrl[arm_act[i]] = min(max(torques[i], limits[0, i]), limits[1, i])
        if k == 0:
            for i in range(grip_act.size):
                ctrl[grip_act[i]] = grip_ctrl[i]
        if (box_lowest_z(plant.sponge_pos, plant.sponge_mat, plant.sponge_half) <= plant.wipe_z
                and present_marker_under_box(markers, present, plant.sponge_pos, plant.sponge_mat, plant.sponge_half,
                                             plant.marker_reach)):
            return -(k + 1)  # mj_step2 of substep k is left to the caller, after the env's wiping check
        _call_2(step2, plant.model, plant.data)
    return plant.substeps


@numba.njit(cache=True)
def present_marker_under_box(markers, present, pos, mat, half_size, reach) -> bool:
    """Whether a ``present`` (N,) marker of ``markers`` (N, 3) m lies within ``reach`` (m) of the box.

    The box: centre ``pos`` (3,), row-major rotation ``mat`` (9,), ``half_size`` (3,) m.  The
    env's ``markers_under_box`` test in the box frame, widened by `MARKER_REACH_SLACK`.
    """
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


@numba.njit(cache=True)
def box_lowest_z(pos: np.ndarray, mat: np.ndarray, half_size: np.ndarray) -> float:
    """World z (m) of the lowest corner of a box: centre ``pos`` (3,), row-major rotation ``mat`` (9,), ``half_size`` (3,)."""
    return pos[2] - (abs(mat[6]) * half_size[0] + abs(mat[7]) * half_size[1] + abs(mat[8]) * half_size[2])


@numba.njit(cache=True)
def panda_gripper_control(current, command, speed, params, new_current, goal_qvel, ctrl) -> None:
    """robosuite's Panda gripper ``format_action`` and ``SimpleGripController`` mapping for one control step.

    Args:
        current: (2,) the gripper's rate-limited command (``current_action``); ``command``: the skill's
            gripper command in [-1, 1]; ``speed``: its change per control step (the gripper's ``speed``).
        params: (9, 2) rows: input min, input max, input centre, scale, output centre (``scale_action``),
            actuator min, actuator max, ctrl range low, high; all (2,) per finger actuator.
        new_current: (2,) output, the new ``current_action``; ``goal_qvel``: (2,) output, the
            controller's goal; ``ctrl``: (2,) output, the finger actuator controls.

    The same elementwise operations in the same order as robosuite's numpy code, so bit-identical.
    """
    sign = np.sign(command)
    for i in range(2):
        step = (-1.0 if i == 0 else 1.0) * speed * sign
        value = min(max(current[i] + step, -1.0), 1.0)
        new_current[i] = value
        scaled = min(max(value, params[0, i]), params[1, i])
        scaled = (scaled - params[2, i]) * params[3, i] + params[4, i]
        goal_qvel[i] = scaled
        high, low = params[6, i], params[5, i]
        desired = 0.5 * (high + low) + 0.5 * (high - low) * scaled
        ctrl[i] = min(max(desired, params[7, i]), params[8, i])


@numba.njit(cache=True)
def step_inputs(action, current, speed, params, goal_pos, goal_ori, new_current, goal_qvel, ctrl) -> None:
    """One control step's inputs from the absolute command ``action`` (7,) in one compiled call.

    The goal position ``goal_pos`` (3,) and rotation ``goal_ori`` (3, 3) (as
    [`FastSkillStepper.goal`][tableclean_suite.controllers.fast_control.FastSkillStepper.goal], [`rotvec_matrix`][tableclean_suite.controllers.fast_control.rotvec_matrix]) and the Panda gripper's outputs
    ``new_current``, ``goal_qvel``, ``ctrl`` (2,) each ([`panda_gripper_control`][tableclean_suite.controllers.fast_control.panda_gripper_control] from
    ``current``, ``speed``, ``params``); the same operations, so the same bits.
    """
    for i in range(3):
        goal_pos[i] = action[i]
    rotvec_matrix(action[3:6], goal_ori)
    panda_gripper_control(current, action[6], speed, params, new_current, goal_qvel, ctrl)


def _call_double_codegen(context, builder, sig, llvm_args):
    """LLVM code calling ``double f(void)`` at the address in the (integer) argument."""
    function = builder.inttoptr(llvm_args[0], ir.FunctionType(ir.DoubleType(), []).as_pointer())
    return builder.call(function, [])


@intrinsic
def _call_double(typingctx, fn):
    """``fn()`` for C ``double f(void)`` at the integer address ``fn`` (a `FORCE_CALLBACK`; cacheable: no
    address is baked into the compiled code)."""
    return types.float64(types.intp), _call_double_codegen


@numba.njit(cache=True)
def _clip(value: float, low: float, high: float) -> float:
    """[`clip_scalar`][tableclean_suite.controllers.geometry.clip_scalar] (numpy's clip of a scalar: its max, then min)."""
    value = low if low >= value else value
    return high if high <= value else value



@numba.njit(cache=True)
def wipe_waypoint(plant, wipe, setpoint, phase_steps, tolerance):
    """One control step of the clean skill's wipe (``Wipe.update``, ``Wipe.waypoint``, ``Wipe.ready``), compiled.

    The press force from ``wipe.force_fn``; pressing or wiping, the depth integrated from the force
    error and clipped; shifting, whether the sponge is off the table; the waypoint (the stroke point
    under the held sponge at the commanded depth; wiping, led by the sponge's drift along the stroke
    and clipped to the hand's bounds; shifting, the lift point until lifted, then the next stroke's
    start at the shift clearance); whether the phase is ready to end.  The same operations on the same
    values as the Python methods.

    Args:
        plant: the stepper's [Plant][tableclean_suite.controllers.fast_control.Plant].
        wipe: a `WIPE_STATE` record (read only here).
        setpoint: (3,) the skill's position setpoint (m); phase_steps: control steps in the phase.
        tolerance: m, the phase's position tolerance.

    Returns:
        (stop, waypoint x, y, z (m), depth (m), force (N), lifted, ready, tolerance (m)): ``stop`` is
        `PHASE_HANDOFF` for a step the skill must take (the sponge's lowest corner within
        `GAP_CHECK_SLACK` of ``contact_slack`` above the table or higher while wiping; shifting,
        unlifted without force, within it of ``contact_slack``; a NaN force), else -1.
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
        force = _call_double(wipe.force_fn)
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
            if wiping and box_lowest_z(plant.sponge_pos, plant.sponge_mat, plant.sponge_half) - table - slack > -GAP_CHECK_SLACK:
                return PHASE_HANDOFF, 0.0, 0.0, 0.0, depth, force, lifted, False, tolerance  # the gap term may be positive
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
    """Control steps of a skill phase, as ``Skill.step`` + ``FastSkillStepper.step``, in one compiled call.

    Per control step: stop if the step budget is spent; the waypoint (a fixed phase's ``target``, or
    the wipe's, [`wipe_waypoint`][tableclean_suite.controllers.fast_control.wipe_waypoint], which may hand the step to the skill); stop if the phase's
    completion check might pass (position within the tolerance (+ `POSITION_CHECK_RTOL`), at
    least ``min_steps`` in the phase, fingers settled by ``gripper_still`` or the timeout, the wipe
    ready); else take the step: record the finger positions, advance the setpoint
    ([advance_command][tableclean_suite.controllers.setpoint.advance_command]), take the goal of the
    command and the gripper control of row k of ``grip_table`` (its last row beyond), log the state,
    run the substeps ([`native_substeps`][tableclean_suite.controllers.fast_control.native_substeps]).

    Args:
        plant, dirt: as [`native_substeps`][tableclean_suite.controllers.fast_control.native_substeps].
        skill: (1,) `SKILL_STATE` record, updated in place.
        fingers: (F,) finger positions at the last step (rad or m), updated in place.
        wipe: (1,) `WIPE_STATE` record (mode
            ``MODE_FIXED``: a fixed waypoint), updated in place.
        grip_table: (R, G) gripper actuator controls, row k for the loop's k-th step.
        goal: outputs (action (7,), goal_pos (3,) m, goal_ori (3, 3)): the last step's command and goal.
        log: arrays (rows, size) receiving `LOG_FIELDS` at the start of each step from row 0 (no
            logging when they have no rows).
        limit: most control steps to run.

    Returns:
        (stop reason, control steps started, substep): with `PHASE_WIPE` the last step
        stopped after substep's control (the caller runs the env's wiping check, ``mj_step2`` and
        the remaining substeps); otherwise every started step is complete.
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

    Give one to a [`FastSkillStepper`][tableclean_suite.controllers.fast_control.FastSkillStepper] (``stepper.state_log = ControlStepLog(stepper)``): the
    per-step path and the compiled control loop both append a row per control step.
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
            grown = []
            for old in self._arrays:
                new = np.empty((capacity, old.shape[1]))
                new[: self.rows] = old[: self.rows]
                grown.append(new)
            self._arrays = tuple(grown)
        return self._arrays

    def live(self) -> tuple[np.ndarray, ...]:
        """Views of the logged mjData fields."""
        return tuple(getattr(self._data, f) for f in LOG_FIELDS)

    def append(self) -> None:
        """Record the current state as the next row."""
        arrays = self.reserve(1)
        for array, value in zip(arrays, self.live()):
            array[self.rows] = value
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
        env: a TableClean env made by [`make_skill_env`][tableclean_suite.controllers.make.make_skill_env]
            (one Panda, absolute world-frame OSC_POSE; see the module docstring).
        native: run the substeps in the compiled loop that calls MuJoCo's C API (``None``: when
            available, see [`native_available`][tableclean_suite.controllers.fast_control.native_available]); ``False`` runs them in Python through
            the mujoco bindings (same results, slower).

    [`step`][tableclean_suite.controllers.fast_control.FastSkillStepper.step] replaces ``env.step(action)`` for the skills; the env keeps working with
    ``env.step`` in between (the controllers' goals and refresh flags are kept current).
    The robot's controllers are looked up at every step (robosuite makes new ones at each
    reset); a hard reset (new simulation) is noticed and the cached ids and views are rebuilt.
    """

    def __init__(self, env, native: bool | None = None, phase_loop: bool = True):
        require_checked_versions()
        _check_supported(env)
        self.env = env
        self.native = native_available() if native is None else bool(native)
        #: whether [`run_phase`][tableclean_suite.controllers.fast_control.FastSkillStepper.run_phase] and [`run_press_phase`][tableclean_suite.controllers.fast_control.FastSkillStepper.run_press_phase] run a phase in the compiled [`control_loop`][tableclean_suite.controllers.fast_control.control_loop]
        #: (needs ``native``); ``False`` leaves every control step to the skill and [`step`][tableclean_suite.controllers.fast_control.FastSkillStepper.step] (same results)
        self.phase_loop = bool(phase_loop)
        #: a [`ControlStepLog`][tableclean_suite.controllers.fast_control.ControlStepLog] receiving the state at the start of every control step, or None
        self.state_log: ControlStepLog | None = None
        #: seconds (wall) the compiled loops spent in the skill's Python callbacks ([`run_press_phase`][tableclean_suite.controllers.fast_control.FastSkillStepper.run_press_phase]'s force
        #: reads): skill work, which a caller timing the stepper as the physics subtracts (the SkillController does)
        self.callback_seconds = 0.0
        #: the stop reason (``PHASE_*``) of the last compiled loop [`run_phase`][tableclean_suite.controllers.fast_control.FastSkillStepper.run_phase] / [`run_press_phase`][tableclean_suite.controllers.fast_control.FastSkillStepper.run_press_phase] ran
        self.last_status = PHASE_LIMIT
        self._sim = None
        self._bind()

    # -- set-up ------------------------------------------------------------------------------
    def _bind(self) -> None:
        """Cache the simulation's ids, index arrays, data views and buffers (again after a hard reset)."""
        env = self.env
        sim = env.sim
        robot = env.robots[0]
        arm = robot.arms[0]
        self._find_controllers()
        model, self.model, self.data = sim.model, mj_model(sim), mj_data(sim)
        base_site = model.site_name2id(f"{self.osc.naming_prefix}{self.osc.part_name}_center")
        if self.model.body_weldid[self.model.site_bodyid[base_site]] != 0:
            raise NotImplementedError("the fast control path needs the arm's base welded to the world")
        self.site_id = model.site_name2id(self.osc.ref_name)
        self.indexes = np.array([self.osc.qvel_index, self.osc.qpos_index], dtype=np.int64)
        self.arm_actuators = np.asarray(actuator_indexes(robot, arm), dtype=np.int64)
        self.grip_actuators = np.asarray(actuator_indexes(robot, self.grip_controller.part_name), dtype=np.int64)
        ctrlrange = self.model.actuator_ctrlrange
        self.arm_limits = np.ascontiguousarray(ctrlrange[self.arm_actuators].T)  # (2, n) low, high
        self.grip_limits = np.ascontiguousarray(ctrlrange[self.grip_actuators].T)
        nv = self.model.nv
        self.full_mass = np.zeros((nv, nv))
        self.jacp = np.zeros((3, nv))
        self.jacr = np.zeros((3, nv))
        self.torques = np.zeros(len(self.arm_actuators))
        self._grip_ctrl = np.zeros(len(self.grip_actuators))  # step()'s finger controls (copied into ctrl)
        self._gains = (None, None, None)  # (osc.kp, osc.kd, gains()) of the last step, see _current_gains()
        self.substeps = int(env.control_timestep / env.model_timestep)
        self._grip_params = None  # (controller, its panda_gripper_control parameters), see _panda_grip_params
        self.eef_site_id = robot.eef_site_id[arm]
        self.finger_index = np.asarray(gripper_joint_pos_indexes(robot, arm), dtype=np.int64)
        self._bind_plant()
        self._sim = sim

    def _find_controllers(self) -> None:
        """The robot's current OSC, gripper controller and gripper (robosuite makes new controllers at each reset)."""
        robot = self.env.robots[0]
        arm = robot.arms[0]
        self._composite = robot.composite_controller
        self._arm = arm
        controllers = robot.composite_controller.part_controllers
        self.osc = controllers[arm]
        self.grip_controller = controllers[robot.get_gripper_name(arm)]
        self.gripper = robot.gripper[arm]

    def _bind_plant(self) -> None:
        """The [Plant][tableclean_suite.controllers.fast_control.Plant] the compiled kernels read."""
        env, data = self.env, self.data
        # the env's own early exit in record_wiping_substep, plus a margin: below this it must decide
        contact = max(float(env.task_config["wipe_contact_dist"]), 0.0)
        self._no_log = tuple(np.empty((0, getattr(data, f).size)) for f in LOG_FIELDS)
        self._plant_key = (None, None, None)  # (osc, gains, initial_joint) of the plant's law, see _current_plant()
        native = self.native  # without the native loop the plant serves the OSC law only: no C addresses
        self._plant = Plant(
            functions=mujoco_function_addresses() if native else (0, 0, 0, 0),
            model=c_address(self.model) if native else 0, data=c_address(data) if native else 0,
            substeps=self.substeps, full_mass=self.full_mass, jacp=self.jacp, jacr=self.jacr, torques=self.torques,
            q_m=data.qM, qpos=data.qpos, qvel=data.qvel, qfrc_bias=data.qfrc_bias, ctrl=data.ctrl,
            site_id=int(self.site_id), site_pos=data.site_xpos[self.site_id], site_mat=data.site_xmat[self.site_id],
            eef_pos=data.site_xpos[self.eef_site_id], finger_index=self.finger_index,
            sponge_pos=data.xpos[env.sponge_body_id], sponge_mat=data.xmat[env.sponge_body_id],
            sponge_half=np.asarray(env.task_config["sponge_half_size"], dtype=float),
            wipe_z=float(env.geometry.table_top_z) + contact + PRESS_PREFILTER_SLACK + WIPE_CHECK_MARGIN,
            marker_reach=float(env.task_config["wipe_marker_reach"]), indexes=self.indexes,
            arm_actuators=self.arm_actuators, grip_actuators=self.grip_actuators, limits=self.arm_limits,
            gains=np.zeros((2, 6)), initial_joint=np.zeros(len(self.arm_actuators)), uncouple=False,
            log_live=tuple(getattr(data, f) for f in LOG_FIELDS),
        )

    def _current_gains(self) -> np.ndarray:
        """The OSC's (2, 6) gains ([`gains`][tableclean_suite.controllers.fast_control.FastSkillStepper.gains]), rebuilt only when robosuite assigns new kp or kd arrays
        (fixed impedance: it never changes them in place)."""
        osc = self.osc
        gains = self._gains
        if gains[0] is not osc.kp or gains[1] is not osc.kd:
            gains = self._gains = (osc.kp, osc.kd, self.gains())
        return gains[2]

    def _current_plant(self) -> Plant:
        """The plant with the current controllers' law (replaced when the OSC, its gains or its posture are new)."""
        osc = self.osc
        gains = self._current_gains()
        key = self._plant_key
        if key[0] is not osc or key[1] is not gains or key[2] is not osc.initial_joint:
            self._plant = self._plant._replace(gains=gains, initial_joint=np.asarray(osc.initial_joint, dtype=float),
                                               uncouple=bool(osc.uncoupling))
            self._plant_key = (osc, gains, osc.initial_joint)
        return self._plant

    # -- one control step --------------------------------------------------------------------
    def goal(self, action: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Goal position (3,) m and rotation matrix (3, 3) of the absolute world-frame ``action`` (7,), as robosuite."""
        goal_pos = np.array(action[POS_SLICE], dtype=float)
        goal_ori = np.empty((3, 3))
        rotvec_matrix(np.ascontiguousarray(action[ROTVEC_SLICE], dtype=float), goal_ori)
        return goal_pos, goal_ori

    def gripper_ctrl(self, action: np.ndarray) -> np.ndarray:
        """Finger actuator controls (n_fingers,) for ``action``'s gripper command; advances the gripper's state.

        As robosuite's policy step: ``gripper.format_action`` (rate-limited internal command),
        ``SimpleGripController.set_goal`` (input scaling), then its ``run_controller`` mapping
        onto the actuators' control range and the robot's clipping to it.
        """
        controller = self.grip_controller
        params = self._panda_grip_params()
        if params is not None:
            new_current, goal_qvel, ctrl = np.empty(2), np.empty(2), np.empty(2)
            panda_gripper_control(np.asarray(self.gripper.current_action, dtype=float), float(action[GRIPPER_INDEX]),
                                  float(self.gripper.speed), params, new_current, goal_qvel, ctrl)
            set_gripper_state(self.gripper, controller, new_current, goal_qvel)
            return ctrl
        goal_qvel = self.gripper.format_action(np.asarray(action[GRIPPER_SLICE], dtype=float))
        if controller.use_action_scaling:
            goal_qvel = controller.scale_action(goal_qvel)
        controller.goal_qvel = goal_qvel
        desired = np.array(goal_qvel, dtype=float)
        if controller.use_action_scaling:
            low, high = controller.actuator_min, controller.actuator_max
            desired = 0.5 * (high + low) + 0.5 * (high - low) * desired
        return np.minimum(np.maximum(desired, self.grip_limits[0]), self.grip_limits[1])  # np.clip, cheaper

    def _panda_grip_params(self) -> np.ndarray | None:
        """(9, 2) parameters of [`panda_gripper_control`][tableclean_suite.controllers.fast_control.panda_gripper_control] for the current gripper controller, or None
        (not robosuite's Panda gripper with action scaling: [`gripper_ctrl`][tableclean_suite.controllers.fast_control.FastSkillStepper.gripper_ctrl] then runs robosuite's code)."""
        controller = self.grip_controller
        cached = self._grip_params
        if cached is not None and cached[0] is controller:
            return cached[1]
        params = None
        if (type(self.gripper).format_action is PandaGripper.format_action and controller.use_action_scaling
                and self.grip_actuators.size == 2):
            if controller.action_scale is None:
                controller.scale_action(np.zeros(self.grip_actuators.size))  # robosuite sets its transforms lazily
            rows = (controller.input_min, controller.input_max, controller.action_input_transform,
                    controller.action_scale, controller.action_output_transform, controller.actuator_min,
                    controller.actuator_max, self.grip_limits[0], self.grip_limits[1])
            params = np.ascontiguousarray([np.broadcast_to(np.asarray(r, dtype=float), (2,)) for r in rows])
        self._grip_params = (controller, params)
        return params

    def gains(self) -> np.ndarray:
        """(2, 6) rows kp (1/s^2) and kd (1/s) of robosuite's OSC, read each control step."""
        return np.array((self.osc.kp, self.osc.kd), dtype=float)

    def arm_torques(self, goal_pos: np.ndarray, goal_ori: np.ndarray) -> np.ndarray:
        """OSC torques (n,) N m, unclipped, for the current simulation data (after ``mj_step1`` or ``mj_forward``).

        Fills `torques` and returns it (the same array, overwritten on the next call).
        """
        model, data = self.model, self.data
        mujoco.mj_fullM(model, self.full_mass, data.qM)
        mujoco.mj_jacSite(model, data, self.jacp, self.jacr, self.site_id)
        osc_torques(self._current_plant(), goal_pos, goal_ori)
        return self.torques

    def cached_arm_torques(self, goal_pos: np.ndarray, goal_ori: np.ndarray) -> np.ndarray:
        """OSC torques (n,) N m, unclipped, from the state robosuite's OSC cached at its last ``update()``.

        robosuite's controller re-reads the simulation only when its ``new_update`` flag is
        set; right after a reset it is not (the reset already read the state, before the
        objects and fingers were placed), so the episode's first substep uses the arm state
        cached at the reset.  This reproduces that.
        """
        osc = self.osc
        arm = ArmState(
            mass=np.ascontiguousarray(osc.mass_matrix), j_full=np.ascontiguousarray(osc.J_full),
            ref_pos=np.asarray(osc.ref_pos, dtype=float), ref_ori_mat=np.ascontiguousarray(osc.ref_ori_mat),
            ref_vel=np.concatenate([osc.ref_pos_vel, osc.ref_ori_vel]), joint_pos=np.asarray(osc.joint_pos, dtype=float),
            joint_vel=np.asarray(osc.joint_vel, dtype=float),
            bias=self.data.qfrc_bias[self.indexes[0]],  # robosuite reads the compensation live
        )
        osc_law(arm, goal_pos, goal_ori, self._current_plant())
        return self.torques

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
        if env.sim is not self._sim:
            self._bind()
        else:  # robosuite makes a new composite controller, with new parts, at each reset
            composite = env.robots[0].composite_controller
            if composite is not self._composite or composite.part_controllers[self._arm] is not self.osc:
                self._find_controllers()
        env.timestep += 1
        if self.state_log is not None:
            self.state_log.append()
        # (runs right after the physics, with cold CPU caches: few Python calls and allocations per step)
        osc = self.osc
        self._current_plant()  # the law of the current controllers and gains
        params = self._panda_grip_params()
        if params is not None:  # goal() and gripper_ctrl() in one compiled call
            gripper = self.gripper
            goal_pos, goal_ori, new_current, goal_qvel = np.empty(3), np.empty((3, 3)), np.empty(2), np.empty(2)
            grip_ctrl = self._grip_ctrl
            step_inputs(np.ascontiguousarray(action), np.asarray(gripper.current_action, dtype=float),
                        float(gripper.speed), params, goal_pos, goal_ori, new_current, goal_qvel, grip_ctrl)
            set_gripper_state(gripper, self.grip_controller, new_current, goal_qvel)
        else:
            goal_pos, goal_ori = self.goal(action)
            grip_ctrl = self.gripper_ctrl(action)
        first = 0
        if not controller_needs_update(osc):  # robosuite then reuses its cached arm state once (see cached_arm_torques)
            self._python_substep(0, goal_pos, goal_ori, grip_ctrl, cached=True)
            first = 1
        if self.native:
            self._native_substeps(first, goal_pos, goal_ori, grip_ctrl)
        else:
            for substep in range(first, self.substeps):
                self._python_substep(substep, goal_pos, goal_ori, grip_ctrl)
        # what env.step does once per control step and later steps rely on (the next update() re-reads the sim)
        env.show_dirt()
        env.done = (env.timestep >= env.horizon) and not env.ignore_done
        finish_control_step(env, osc, self.grip_controller, goal_pos, goal_ori, self.torques)

    # -- a phase in compiled code ----------------------------------------------------------------
    def run_phase(self, skill: np.ndarray, fingers: np.ndarray) -> int:
        """Run control steps of a skill phase with a fixed waypoint in [`control_loop`][tableclean_suite.controllers.fast_control.control_loop]; returns how many ran.

        ``skill``: the skill's (1,) `SKILL_STATE`
        record (its ``target`` the waypoint), ``fingers``: (F,) its finger positions at the last step; both
        updated in place.  Returns to Python only at the phase's boundaries (a step whose completion check
        might pass, the budget, the env's horizon) and for substeps the env's wiping check must see, after
        which the loop resumes.  Runs nothing (returns 0) without the native loop, with `phase_loop`
        off, for a gripper other than the Panda's (whose rate-limited command it tabulates), on the first
        step after a reset (robosuite's cached arm state, see [`cached_arm_torques`][tableclean_suite.controllers.fast_control.FastSkillStepper.cached_arm_torques]) or when the
        episode is done.
        """
        return self._run_compiled(skill, fingers, np.zeros(1, WIPE_STATE))  # mode MODE_FIXED

    def run_press_phase(self, skill: np.ndarray, fingers: np.ndarray, wipe: np.ndarray, force) -> tuple[int, int]:
        """Run control steps of the clean skill's PRESS, WIPE or SHIFT phase in [`control_loop`][tableclean_suite.controllers.fast_control.control_loop].

        As [`run_phase`][tableclean_suite.controllers.fast_control.FastSkillStepper.run_phase] (same conditions, the skill's state updated in place); ``wipe``: the wipe's (1,)
        `WIPE_STATE` record, updated in place (its
        ``force_fn`` is set here); ``force``: a Python function returning the sponge's press force (N),
        called once per control step from the compiled loop (its time is added to `callback_seconds`).
        Returns (control steps run, the loop's last stop reason).  An exception ``force`` raises is raised
        here after the loop stopped (the loop takes no step with it).
        """
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
        return ran, self.last_status

    def _run_compiled(self, skill: np.ndarray, fingers: np.ndarray, wipe: np.ndarray) -> int:
        """Run [`control_loop`][tableclean_suite.controllers.fast_control.control_loop] on the skill's state (see [`run_phase`][tableclean_suite.controllers.fast_control.FastSkillStepper.run_phase]); sets `last_status`."""
        env = self.env
        self.last_status = PHASE_LIMIT
        if not (self.native and self.phase_loop) or env.done:
            return 0
        if env.sim is not self._sim:
            self._bind()
        else:
            self._find_controllers()
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
            present = np.ascontiguousarray(env._marker_present())  # changes only in the env's wiping check
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
                env.record_wiping_substep()
                mujoco.mj_step2(self.model, self.data)
                self._native_substeps(substep + 1, goal[1], goal[2], table[min(total + ran - 1, len(table) - 1)])
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
            hand_back_controller_state(self.osc, self.grip_controller, goal[1], goal[2], self.torques)
        return total

    def _grip_table(self, command: float) -> tuple[np.ndarray, list, bool]:
        """Gripper actuator controls (rows, G) of the next control steps under the constant gripper ``command``.

        Runs robosuite's own gripper code ([`gripper_ctrl`][tableclean_suite.controllers.fast_control.FastSkillStepper.gripper_ctrl]) ahead, then restores the gripper's
        state.  Returns (rows, the gripper's (current_action, goal_qvel) after each row, settled):
        ``settled`` when the last row repeats forever (the rate-limited command reached its fixed
        point), else the table covers only its `GRIP_TABLE_ROWS` steps.
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
        model, data = self.model, self.data
        mujoco.mj_step1(model, data)
        torques = (self.cached_arm_torques if cached else self.arm_torques)(goal_pos, goal_ori)
        data.ctrl[self.arm_actuators] = np.clip(torques, self.arm_limits[0], self.arm_limits[1])
        if substep == 0:
            data.ctrl[self.grip_actuators] = grip_ctrl
        self.env.record_wiping_substep()
        mujoco.mj_step2(model, data)

    def _native_substeps(self, first: int, goal_pos, goal_ori, grip_ctrl) -> None:
        """Substeps ``first``.. of the control step in the compiled loop; the env checks wiping near the table."""
        plant = self._current_plant()
        done = first
        markers = np.ascontiguousarray(self.env._marker_xyz, dtype=float)
        while done < self.substeps:
            present = np.ascontiguousarray(self.env._marker_present())  # changes only in the env's wiping check
            done = native_substeps(plant, (markers, present), done, goal_pos, goal_ori, grip_ctrl)
            if done < 0:  # stopped after substep -done - 1's control: the env checks wiping, then step2
                done = -done
                self.env.record_wiping_substep()
                mujoco.mj_step2(self.model, self.data)
#: Attribute under which [`attach_fast_stepper`][tableclean_suite.controllers.fast_control.attach_fast_stepper] stores an env's stepper.
STEPPER_ATTRIBUTE = "fast_stepper"


def attach_fast_stepper(env, native: bool | None = None) -> FastSkillStepper | None:
    """Give ``env`` a [`FastSkillStepper`][tableclean_suite.controllers.fast_control.FastSkillStepper] (``env.fast_stepper``), which the SkillController then uses.

    On robosuite / MuJoCo versions the adapter was not checked against
    (`CHECKED_VERSIONS`) attaches nothing, warns once per
    process, and returns ``None``: the env then runs on robosuite's own ``env.step`` path.
    Raises ``NotImplementedError`` when the env's controllers are not the ones the fast path reproduces.
    """
    if not fast_path_allowed():
        return None
    stepper = FastSkillStepper(env, native=native)
    setattr(env, STEPPER_ATTRIBUTE, stepper)
    return stepper


def fast_stepper_of(env) -> FastSkillStepper | None:
    """The stepper [`attach_fast_stepper`][tableclean_suite.controllers.fast_control.attach_fast_stepper] gave ``env``, or ``None`` (then ``env.step`` is the path)."""
    return getattr(env, STEPPER_ATTRIBUTE, None)
