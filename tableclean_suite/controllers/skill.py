"""The skill interface: a MAPLE-style state machine over end-effector waypoints.

A skill is created per execution.  Every control step [`Skill.step`][tableclean_suite.controllers.skill.Skill.step] reads
``env.skill_info()`` (the only grounding a skill uses), decides from the
*achieved* pose whether the current phase's waypoint is done, advances the phase
if so, and returns the next absolute OSC setpoint, rate-limited towards the
waypoint.  Subclasses only say which waypoint each phase aims at
([`Skill.waypoint`][tableclean_suite.controllers.skill.Skill.waypoint]) and what follows a completed phase
([`Skill.next_phase`][tableclean_suite.controllers.skill.Skill.next_phase]); the waypoint following, rate limiting, gripper
settling and step budget live here once.

Subclasses define:
- ``action``: the [`Action`][tableclean_suite.task.actions.Action] the skill implements,
- ``Phase``: an `enum.Enum` of phases whose last member ends the skill,
- ``Config``: its typed, frozen settings (a [`SkillConfig`][tableclean_suite.controllers.configs.SkillConfig] subclass, units and
  ranges in its field docstrings) and ``DEFAULT_CONFIG``, their defaults as a dict
  (``Config().as_dict()``, extending `BASE_CONFIG`).
"""

from __future__ import annotations

import abc
import collections
import enum
import functools
import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, ClassVar, Mapping, Protocol, runtime_checkable

import numpy as np

from tableclean_suite.controllers.configs import SkillConfig, checked_skill_config
from tableclean_suite.controllers.geometry import box_lowest_z, gripper_yaw, quat_to_matrix
from tableclean_suite.controllers.loop_state import SKILL_STATE, loop_record
from tableclean_suite.controllers.osc import ACTION_DIM
from tableclean_suite.controllers.setpoint import advance_command
from tableclean_suite.environments.object_geometry import world_z_range, wrap_angle
from tableclean_suite.task import Action, Outcome, TaskModel, TaskState

#: The dict form of [`SkillConfig`][tableclean_suite.controllers.configs.SkillConfig]'s defaults: the settings every skill understands
#: (units and ranges in its field docstrings); each skill's ``DEFAULT_CONFIG`` extends these.
BASE_CONFIG: dict[str, Any] = SkillConfig().as_dict()


def object_heights(info: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """``(tops, bottoms)`` (M,) world z [m] of each object's highest and lowest collision point as it lies now
    (its ``objects_geometry`` at its pose; its bounding half size about its centre without geometry)."""
    positions = np.asarray(info["objects_pos"], dtype=float)
    if "objects_geometry" not in info:
        halves = np.asarray(info["objects_half_size"], dtype=float)
        return positions[:, 2] + halves[:, 2], positions[:, 2] - halves[:, 2]
    ranges = np.array([world_z_range(shape, pos, quat_to_matrix(quat)) for pos, quat, shape
                       in zip(positions, info["objects_quat"], info["objects_geometry"])], dtype=float).reshape(-1, 2)
    return ranges[:, 1], ranges[:, 0]


@runtime_checkable
class SkillEnv(Protocol):
    """What skills and the [`SkillController`][tableclean_suite.controllers.skill_controller.SkillController] need from an env.

    ``TableClean`` made by [`make_skill_env`][tableclean_suite.controllers.make.make_skill_env] is one; test
    doubles implement these members only.
    """

    control_freq: float  # Hz, control steps per second

    def skill_info(self) -> dict:
        """Grounding in the world frame (keys as ``TableClean.skill_info``)."""

    def sponge_press_force(self) -> float:
        """N (>= 0) the sponge presses on the table top (the clean skill's force loop)."""

    def symbolic_state(self, check_sponge: bool = True) -> TaskState:
        """The current task state through the abstraction (raises ``AbstractionError`` on a fault)."""

    def step(self, action): 
        """One control step with the (7,) absolute OSC_POSE + gripper command."""


class SkillFailure(RuntimeError):
    """Raised inside a skill when it cannot continue (e.g. the grasp was not confirmed).

    ``redo``: None, the skill fails; else the part that failed may start again from the scene as it is now
    measured ([`Skill.restart`][tableclean_suite.controllers.skill.Skill.restart]), within the config's ``retries``:
    0 the primitive that failed, 1 the one before it (a wipe that lost the sponge grasps it again), ..."""

    def __init__(self, message: str, redo: int | None = None):
        super().__init__(message)
        self.redo = redo


@dataclass(frozen=True)
class Waypoint:
    """A target of the current phase.

    Attributes:
        pos: (3,) world position (m) of the end-effector (grip site).
        gripper: gripper command in [-1, 1] (-1 open, +1 closed).
        tolerance: m; the waypoint is reached when the achieved position is this close.
        xy_only: judge "reached" in the horizontal plane only (for pressing
            moves whose z lies below the table surface and is never reached).
        min_steps: control steps to spend in the phase at least (e.g. to let a grasp tighten).
        speed: m/s cap of the setpoint's speed towards ``pos``; ``None``: the skill's ``speed``.
        fixed: the primitive promises that this waypoint stays the same until the phase ends and that
            its ``update()`` changes nothing meanwhile, so a compiled loop may run the phase's control
            steps without asking again ([`Skill.run_fixed_phase`][tableclean_suite.controllers.skill.Skill.run_fixed_phase]); the completion check stays exact.
        loop: the waypoint moves, but the primitive runs the phase's further control steps in its own
            compiled loop ([`Skill.run_loop_phase`][tableclean_suite.controllers.skill.Skill.run_loop_phase], e.g. the wipe's press and strokes), exactly as its
            ``update()`` and ``waypoint()`` would.
    """

    pos: np.ndarray
    gripper: float
    tolerance: float
    xy_only: bool = False
    min_steps: int = 0
    speed: float | None = None
    fixed: bool = False
    loop: bool = False


class Skill(abc.ABC):
    """Base class of all skills: waypoint following with phases, a budget and checks.

    Args:
        env: anything with ``skill_info() -> dict`` (as [`tableclean_suite.environments.TableClean.skill_info`][tableclean_suite.environments.table_clean.TableClean.skill_info]),
            ``symbolic_state() -> TaskState`` and ``control_freq`` (Hz).
        config: overrides of ``DEFAULT_CONFIG`` (an unknown key, or a value outside its field's range in
            ``Config``, raises [`SkillConfigError`][tableclean_suite.controllers.configs.SkillConfigError], a ``KeyError`` and a ``ValueError``,
            naming the skill, the key and the allowed keys or range).

    Attributes:
        settings: the validated, frozen ``Config`` the skill runs with.
        config: the same values as a read-only mapping (``skill.config["speed"]``).
    """

    action: ClassVar[Action]
    Phase: ClassVar[type[enum.Enum]]
    Config: ClassVar[type[SkillConfig]] = SkillConfig
    DEFAULT_CONFIG: ClassVar[dict[str, Any]] = BASE_CONFIG

    def __init__(self, env: SkillEnv, config: Mapping[str, Any] | None = None):
        # validated once; keys of a subclass's DEFAULT_CONFIG that its Config lacks pass through unchecked
        merged, self.settings = checked_skill_config(type(self).__name__, self.Config, self.DEFAULT_CONFIG, config)
        self.config = MappingProxyType(merged)
        self.env = env
        self.dt = 1.0 / float(env.control_freq)
        self.fixed_waypoint: Waypoint | None = None  # the last step's waypoint when fixed or loop (see run_fixed_phase)
        window = self.config["gripper_window"]
        self._finger_history: collections.deque = collections.deque(maxlen=2 * int(window or 0))
        self._begin(None, np.zeros(3), None, 0.0)

    # -- what subclasses provide ---------------------------------------------------
    @abc.abstractmethod
    def waypoint(self, info: Mapping[str, Any]) -> Waypoint:
        """The waypoint of ``self.phase``, computed from the current ``skill_info()``."""
        raise NotImplementedError

    @abc.abstractmethod
    def next_phase(self, info: Mapping[str, Any]) -> enum.Enum:
        """The phase after ``self.phase`` once its waypoint is done; may raise [`SkillFailure`][tableclean_suite.controllers.skill.SkillFailure]."""
        raise NotImplementedError

    def on_reset(self, info: Mapping[str, Any]) -> None:
        """Hook: per-execution set-up from the first ``skill_info()`` (after the base reset)."""

    def update(self, info: Mapping[str, Any]) -> None:
        """Hook: per-step bookkeeping from the current ``skill_info()``, before the phase is evaluated."""

    def phase_ready(self, info: Mapping[str, Any]) -> bool:
        """Hook: an extra condition for leaving ``self.phase`` (e.g. "the object is released"); default True."""
        return True

    def restart(self, info: Mapping[str, Any], redo: int) -> bool:
        """Hook: after a [`SkillFailure`][tableclean_suite.controllers.skill.SkillFailure] with ``redo``, start the failed
        part again from the scene ``info`` as measured now (set ``self.phase``); False: it cannot (default)."""
        return False

    # -- checks through the abstraction ---------------------------------------------------
    @classmethod
    def precondition(cls, state: TaskState, model: TaskModel) -> bool:
        """Whether to run from the symbolic ``state``: the model calls the action neither improper nor ineffective."""
        return model.step(state, cls.action)[1] not in (Outcome.IMPROPER, Outcome.INEFFECTIVE)

    @classmethod
    def is_success(cls, state_before: TaskState, state_after: TaskState | None, model: TaskModel) -> bool:
        """Whether the abstraction's state after the skill is the task model's successor of ``state_before``."""
        return state_after is not None and state_after == model.step(state_before, cls.action)[0]

    # -- shared machinery ------------------------------------------------------------
    @functools.cached_property
    def final_phase(self) -> enum.Enum:
        """The phase that ends the skill (the last member of ``Phase``)."""
        return list(self.Phase)[-1]

    @property
    def done(self) -> bool:
        """Whether the skill finished (reached its final phase) or failed."""
        return self.failure is not None or self.phase == self.final_phase

    @property
    def succeeded(self) -> bool:
        """Whether the skill's motion completed; the abstraction's check is the controller's job."""
        return self.failure is None and self.phase == self.final_phase

    @functools.cached_property
    def max_steps(self) -> int:
        """Step budget (control steps; the config is read-only, so kept)."""
        return int(self.config["max_steps"])

    def reset(self, state: TaskState) -> None:
        """Start an execution from the symbolic ``state`` (read through the abstraction)."""
        info = self.env.skill_info()
        self._begin(state, np.array(info["eef_pos"], dtype=float), np.array(info["gripper_qpos"], dtype=float),
                    gripper_yaw(info["eef_quat"]))
        self.on_reset(info)

    def _begin(self, state: TaskState | None, setpoint: np.ndarray, fingers: np.ndarray | None, yaw: float) -> None:
        """An execution's start from ``state``: the first phase, no steps, retries or failure; the position
        ``setpoint`` (3,) m, the finger positions ``fingers`` and the gripper ``yaw`` (rad) as they are."""
        self.state = state
        self.phase: enum.Enum = next(iter(self.Phase))
        self.steps = self._phase_steps = 0
        self.retries = 0  # restarts after retryable failures in this execution (at most config["retries"])
        self.failure: str | None = None
        self.phase_steps: dict[str, int] = {}
        self._setpoint, self._last_fingers = setpoint, fingers
        self.yaw = self._yaw_setpoint = yaw  # rad, target gripper yaw; the commanded yaw turns towards it at yaw_rate
        self._finger_history.clear()

    def step(self) -> np.ndarray | None:
        """One control step: update the phase from the achieved pose, return the env action (7,).

        Returns ``None`` once the skill is done (finished, failed or out of budget).  Afterwards
        `fixed_waypoint` is the step's waypoint when it is ``fixed`` or ``loop`` (else ``None``).
        """
        self.fixed_waypoint = None
        final = self.final_phase
        if self.failure is not None or self.phase == final:  # self.done
            return None
        if self.steps >= self.budget and not self._retry(self.stall_redo()):
            self.failure = f"step budget of {self.max_steps} exhausted in phase {self.phase.name}"
            return None
        info = self.env.skill_info()
        fingers = np.array(info["gripper_qpos"], dtype=float)
        # the largest change, of Python floats (exact, as numpy's)
        finger_motion = max([abs(a - b) for a, b in zip(fingers.tolist(), self._last_fingers.tolist())])
        self._last_fingers = fingers
        if self._finger_history.maxlen:
            self._finger_history.append(fingers)
        try:
            try:
                self.update(info)
                target = self.waypoint(info)
                if self._phase_complete(target, info, finger_motion) and self._yaw_reached(info):
                    self.phase = self.next_phase(info)
                    self._phase_steps = 0
                    if self.failure is not None or self.phase == final:  # self.done
                        return None
                    target = self.waypoint(info)
            except SkillFailure as failure:  # a retry re-measures the scene and starts the failed part again
                if not self._retry(failure.redo, info):
                    raise
                target = self.waypoint(info)
        except SkillFailure as failure:
            self.failure = f"{self.phase.name}: {failure}"
            return None
        action = self._advance_setpoint(target)
        self._count(1)
        if target.fixed or target.loop:
            self.fixed_waypoint = target
        return action

    @property
    def budget(self) -> int:
        """Control steps the execution may take so far: ``max_steps`` per try (the first and each retry)."""
        return self.max_steps * (self.retries + 1)

    def stall_redo(self) -> int | None:
        """Hook: the ``redo`` of [`SkillFailure`][tableclean_suite.controllers.skill.SkillFailure] when the budget runs
        out in the current phase (a descent held up by what it met); None: the skill fails (default)."""
        return None

    def _retry(self, redo: int | None, info: Mapping[str, Any] | None = None) -> bool:
        """Whether a retry was left and [`restart`][tableclean_suite.controllers.skill.Skill.restart] started the part
        ``redo`` (None: no retry) again from the scene ``info`` (None: measured now); a retry has a fresh budget."""
        if redo is None or self.retries >= self.config["retries"] or not self.restart(
                self.env.skill_info() if info is None else info, redo):
            return False
        self.retries += 1
        self._phase_steps = 0
        return True

    def run_fixed_phase(self, stepper) -> int:
        """Hand the current phase's next control steps to ``stepper``'s compiled phase loop; returns how many ran.

        Only after a [`step`][tableclean_suite.controllers.skill.Skill.step] whose waypoint was ``fixed`` (`fixed_waypoint`; a ``loop`` one goes
        to [`run_loop_phase`][tableclean_suite.controllers.skill.Skill.run_loop_phase]) and without the windowed gripper rule (``gripper_window``); otherwise
        runs nothing.  ``stepper`` is a
        [`FastSkillStepper`][tableclean_suite.controllers.fast_control.FastSkillStepper]: it runs control steps
        exactly as [`step`][tableclean_suite.controllers.skill.Skill.step] followed by ``stepper.step`` would, stopping before any step whose
        completion check might pass (that step is left to [`step`][tableclean_suite.controllers.skill.Skill.step]), at the step budget, and
        at the env's horizon.
        """
        target = self.fixed_waypoint
        self.fixed_waypoint = None
        if target is None or self._finger_history.maxlen:
            return 0
        if target.loop:
            return self.run_loop_phase(stepper)
        state = self.loop_state(target)
        ran = stepper.run_phase(state, self._last_fingers)
        self.count_loop_steps(ran, state)
        return ran

    def run_loop_phase(self, stepper) -> int:
        """Hook: run the current phase's next control steps in the primitive's compiled loop (a ``loop``
        waypoint, see [`Waypoint`][tableclean_suite.controllers.skill.Waypoint]); returns how many ran (default: none, every step through [`step`][tableclean_suite.controllers.skill.Skill.step])."""
        return 0

    def loop_state(self, waypoint: Waypoint) -> np.ndarray:
        """The skill's state as the compiled control loop takes it: a (1,) `SKILL_STATE` record of a phase towards
        ``waypoint``; read back with [count_loop_steps][tableclean_suite.controllers.skill.Skill.count_loop_steps]."""
        timeout = self.config["gripper_timeout"]
        max_move, max_turn = self._step_limits(waypoint)
        return loop_record(
            SKILL_STATE, setpoint=self._setpoint, target=waypoint.pos, yaw_setpoint=self._yaw_setpoint, yaw=self.yaw,
            max_move=max_move, max_turn=max_turn, gripper=waypoint.gripper,
            tolerance=waypoint.tolerance, gripper_still=self.config["gripper_still"], steps=self.steps,
            max_steps=self.budget, phase_steps=self._phase_steps, min_steps=waypoint.min_steps,
            gripper_timeout=-1 if timeout is None else timeout, xy_only=waypoint.xy_only)

    def count_loop_steps(self, ran: int, state: np.ndarray) -> None:
        """Take over ``ran`` control steps the compiled loop ran in the current phase from its ``state`` (the
        record of [`loop_state`][tableclean_suite.controllers.skill.Skill.loop_state]): the setpoint, the yaw setpoint, the step counts."""
        if ran:
            self._setpoint[:] = state["setpoint"][0]
            self._yaw_setpoint = float(state["yaw_setpoint"][0])
            self._count(ran)

    def _count(self, steps: int) -> None:
        """Count ``steps`` more control steps of the current phase."""
        self.steps += steps
        self._phase_steps += steps
        self.phase_steps[self.phase.name] = self.phase_steps.get(self.phase.name, 0) + steps

    def _phase_complete(self, target: Waypoint, info: Mapping[str, Any], finger_motion: float) -> bool:
        """Whether the phase of ``target`` is done: position reached, at least ``min_steps`` in the phase,
        fingers settled and the skill's [`phase_ready`][tableclean_suite.controllers.skill.Skill.phase_ready] (asked last: it may read contacts)."""
        if self._phase_steps < target.min_steps:
            return False
        error = np.asarray(info["eef_pos"], dtype=float) - target.pos
        if target.xy_only:
            error = error[:2]
        if not math.sqrt(error.dot(error)) <= target.tolerance:
            return False
        return self.gripper_settled(finger_motion) and self.phase_ready(info)

    def gripper_settled(self, finger_motion: float) -> bool:
        """Whether the fingers have settled, by any of three rules (per-robot settings in the config).

        1. ``finger_motion`` (the largest finger joint change over the last control step, joint
           units: m or rad) is at most ``gripper_still``: fingers that come to rest (the Panda's).
        2. Windowed drift (``gripper_window`` = W steps, not None): the mean finger positions of the
           last W steps and of the W steps before differ by at most ``gripper_drift`` * W in every
           joint: a gripper that jitters about a fixed pose (an under-actuated linkage) settles, one
           still opening or closing does not.  The history spans phases.
        3. Timeout (``gripper_timeout`` steps in the current phase, not None): a backstop for a gripper
           whose jitter outgrows the drift bound; the phase's other conditions (position reached,
           ``min_steps``, the primitive's own check such as "the body is grasped") still apply.
        """
        if finger_motion <= self.config["gripper_still"]:
            return True
        history = self._finger_history
        if history.maxlen and len(history) == history.maxlen:
            window = history.maxlen // 2
            samples = np.asarray(history)
            drift = np.max(np.abs(samples[window:].mean(axis=0) - samples[:window].mean(axis=0))) / window
            if drift <= self.config["gripper_drift"]:
                return True
        timeout = self.config["gripper_timeout"]
        return timeout is not None and self._phase_steps >= timeout

    def _yaw_reached(self, info: Mapping[str, Any]) -> bool:
        """Whether the gripper's yaw (from ``eef_quat``) is within ``yaw_tolerance`` of `yaw`."""
        return abs(wrap_angle(gripper_yaw(info["eef_quat"]) - self.yaw)) <= self.config["yaw_tolerance"]

    def _advance_setpoint(self, target: Waypoint) -> np.ndarray:
        """Move the setpoint (and the yaw setpoint) one control step towards ``target``; returns the env action (7,).

        The compiled [`advance_command`][tableclean_suite.controllers.setpoint.advance_command], which the
        compiled phase loop also runs: both give bit-identical commands.
        """
        max_move, max_turn = self._step_limits(target)
        pos = np.ascontiguousarray(target.pos, dtype=float)
        action = np.empty(ACTION_DIM)
        self._yaw_setpoint = advance_command(self._setpoint, float(self._yaw_setpoint), float(self.yaw), pos,
                                             max_move, max_turn, float(target.gripper), action)
        return action

    def _step_limits(self, waypoint: Waypoint) -> tuple[float, float]:
        """(m, rad) how far the setpoint may move and turn in one control step towards ``waypoint`` (the Python
        step and the compiled loop take the same two numbers)."""
        speed = self.config["speed"] if waypoint.speed is None else waypoint.speed
        return float(speed * self.dt), float(self.config["yaw_rate"] * self.dt)

    # -- helpers for subclasses ----------------------------------------------------------
    def hover_point(self, info: Mapping[str, Any], xy: np.ndarray) -> np.ndarray:
        """(3,) the travel point above horizontal position ``xy`` (2,) at [`hover_z`][tableclean_suite.controllers.skill.Skill.hover_z]."""
        return np.array([xy[0], xy[1], self.hover_z(info)])

    def hover_z(self, info: Mapping[str, Any]) -> float:
        """World z [m] at which the gripper travels: ``hover_height`` above the table top, raised when needed.

        Read from the scene at every call: the open fingertips (``fingertip_depth`` below the grip
        site) stay each lying object's approach clearance above its top; a carried body (a grasped
        object or the sponge) keeps its lowest point ``carry_lift`` above the table top and
        ``carry_clearance`` above every lying object's top.  Tops and bottoms are the objects'
        collision geometry at their current poses (``objects_geometry``; bounding boxes without it).
        """
        config = self.config
        table = float(info["table_top_z"])
        z = table + config["hover_height"]
        if "objects_pos" not in info:
            return z
        tops, bottoms = (heights.tolist() for heights in object_heights(info))
        grasped = np.asarray(info["objects_grasped"], dtype=bool).tolist()
        eef_z = float(info["eef_pos"][2])
        drop = None  # how far the carried body's lowest point hangs below the grip site
        if True in grasped:
            drop = eef_z - bottoms[grasped.index(True)]
        elif bool(info["sponge_grasped"]):
            drop = eef_z - box_lowest_z(info["sponge_pos"], info["sponge_quat"], info["sponge_half_size"])
        if drop is not None:
            z = max(z, table + max(drop, 0.0) + config["carry_lift"])
        for j, (held, top) in enumerate(zip(grasped, tops)):
            if not held:
                clearance = (config["fingertip_depth"] + info["object_types"][j].clearance() if drop is None
                             else max(drop, 0.0) + config["carry_clearance"])
                z = max(z, top + clearance)
        return z

    def segment_center(self, info: Mapping[str, Any], segment: int) -> np.ndarray:
        """(3,) table-top surface point at the centre of ``segment`` (0-based)."""
        return np.asarray(info["segment_centers"], dtype=float)[int(segment)]
