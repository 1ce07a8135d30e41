"""The one place that touches robosuite's and MuJoCo's internals, with the versions it was checked against.

Each internal the package needs (the raw ``MjModel`` / ``MjData`` behind robosuite's wrappers, the robot's
index lists, the env's clock, the controllers' refresh flags and goals, the gripper's rate-limited command,
MuJoCo's C functions by address) is one small function here, so an upgrade has one module to re-check.
The fast control path runs only on the versions in `CHECKED_VERSIONS`:
[`require_checked_versions`][tableclean_suite.robosuite_adapter.require_checked_versions] raises
[`UncheckedVersionError`][tableclean_suite.robosuite_adapter.UncheckedVersionError] naming the installed and
checked versions; [`fast_path_allowed`][tableclean_suite.robosuite_adapter.fast_path_allowed] warns once per
process and says no (a skill env then runs on robosuite's own ``env.step``).
"""

from __future__ import annotations

import ctypes
import functools
import glob
import logging
import os
import sys
import warnings

import wrapt

#: The logger robosuite writes to.
ROBOSUITE_LOGGER = "robosuite_logs"


class _DropDuringImport(logging.Filter):
    """Drops records until `stop` (robosuite's import has finished)."""

    dropping = True

    def filter(self, record) -> bool:
        return not self.dropping

    def stop(self, _module=None) -> None:
        self.dropping = False


def quiet_robosuite_startup() -> logging.Filter | None:
    """Drop the log records robosuite emits while it is being imported (from now on); returns the filter,
    or None when robosuite is already imported (its start-up messages are then already out)."""
    if "robosuite" in sys.modules:
        return None
    holder = _DropDuringImport()
    logging.getLogger(ROBOSUITE_LOGGER).addFilter(holder)
    wrapt.register_post_import_hook(holder.stop, "robosuite")
    return holder


def apply_verbosity(verbose: bool) -> None:
    """Unless ``verbose``: drop robosuite's import-time warnings and its INFO/DEBUG messages from now on."""
    if not verbose:
        quiet_robosuite_startup()
        logging.getLogger(ROBOSUITE_LOGGER).addFilter(lambda record: record.levelno >= logging.WARNING)


#: Versions the internals used here were checked against (package name -> exact versions).
CHECKED_VERSIONS: dict[str, tuple[str, ...]] = {
    "robosuite": ("1.5.2",),
    "mujoco": ("3.9.0",),
}
#: The MuJoCo C functions the compiled control loop calls, in the order of [`mujoco_function_addresses`][tableclean_suite.robosuite_adapter.mujoco_function_addresses].
NATIVE_FUNCTIONS = ("mj_step1", "mj_step2", "mj_fullM", "mj_jacSite")

_warned: set[tuple[str, ...]] = set()  # the unchecked-version messages already warned about (said once)


class UncheckedVersionError(RuntimeError):
    """The installed robosuite or MuJoCo is not a version `CHECKED_VERSIONS` lists."""


def installed_versions() -> dict[str, str]:
    """The installed versions of the packages in `CHECKED_VERSIONS` (their ``__version__``)."""
    import mujoco
    import robosuite

    return {"robosuite": str(robosuite.__version__), "mujoco": str(mujoco.__version__)}


def unchecked_versions(installed: dict[str, str] | None = None) -> list[str]:
    """One line per installed package whose version is not checked, e.g. ``"mujoco 3.10.0 (checked: 3.9.0)"``.

    ``installed``: package name -> version (default: [`installed_versions`][tableclean_suite.robosuite_adapter.installed_versions]).  Empty when all are checked.
    """
    installed = installed_versions() if installed is None else installed
    return [
        f"{name} {installed[name]} (checked: {', '.join(checked)})"
        for name, checked in CHECKED_VERSIONS.items()
        if installed.get(name) not in checked
    ]


def _unchecked_message(lines: list[str]) -> str:
    return "robosuite/MuJoCo internals were not checked against the installed " + "; ".join(lines)


def require_checked_versions() -> None:
    """Raise [`UncheckedVersionError`][tableclean_suite.robosuite_adapter.UncheckedVersionError] naming the installed and checked versions unless all are checked."""
    lines = unchecked_versions()
    if lines:
        raise UncheckedVersionError(_unchecked_message(lines) + "; use fast_control=False (robosuite's env.step)")


def fast_path_allowed() -> bool:
    """Whether the fast control path may run here; on unchecked versions warns once (``RuntimeWarning``) and says no."""
    lines = unchecked_versions()
    if not lines:
        return True
    key = tuple(lines)
    if key not in _warned:
        _warned.add(key)
        warnings.warn(_unchecked_message(lines) + "; the skills run on robosuite's own env.step path instead",
                      RuntimeWarning, stacklevel=2)
    return False


# -- raw MuJoCo objects ------------------------------------------------------------------------
def mj_model(sim):
    """The ``mujoco.MjModel`` behind robosuite's ``MjSim`` ``sim`` (its ``model._model``)."""
    return sim.model._model


def mj_data(sim):
    """The ``mujoco.MjData`` behind robosuite's ``MjSim`` ``sim`` (its ``data._data``)."""
    return sim.data._data


def c_address(mujoco_struct) -> int:
    """Address of the C ``mjModel`` / ``mjData`` behind a ``mujoco.MjModel`` / ``MjData`` (the bindings' ``_address``)."""
    return int(mujoco_struct._address)


@functools.lru_cache(maxsize=None)
def mujoco_function_addresses() -> tuple[int, ...]:
    """Addresses of `NATIVE_FUNCTIONS` in the MuJoCo library (``libmujoco.so*``) next to the mujoco package, the
    one the Python bindings use; ``OSError`` when that library is not found."""
    import mujoco

    paths = sorted(glob.glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco.so*")))
    if not paths:
        raise OSError("MuJoCo's shared library (libmujoco.so*) not found next to the mujoco package")
    lib = ctypes.CDLL(paths[0])
    return tuple(ctypes.cast(getattr(lib, name), ctypes.c_void_p).value for name in NATIVE_FUNCTIONS)


# -- the robot's index lists -----------------------------------------------------------------
def actuator_indexes(robot, part: str):
    """Actuator indexes (ints) of ``robot``'s part ``part`` (an arm or a gripper name)."""
    return robot._ref_actuators_indexes_dict[part]


def gripper_joint_pos_indexes(robot, arm: str):
    """qpos indexes (ints) of the finger joints of ``robot``'s gripper on ``arm``."""
    return robot._ref_gripper_joint_pos_indexes[arm]


def joint_vel_indexes(robot):
    """qvel indexes (ints) of ``robot``'s arm joints."""
    return robot._ref_joint_vel_indexes


# -- the env -------------------------------------------------------------------------------
def fresh_observations(env) -> dict:
    """``env``'s observations recomputed from the current simulation state (``_get_observations(force_update=True)``)."""
    return env._get_observations(force_update=True)


# -- env and controller state the fast path hands back ----------------------------------------
def advance_clock(env, seconds: float) -> None:
    """Advance ``env``'s simulation clock (``cur_time``, s) by ``seconds``, as ``MujocoEnv.step`` does."""
    env.cur_time += seconds


def controller_needs_update(controller) -> bool:
    """Whether robosuite's ``controller`` re-reads the simulation on its next ``update()`` (``new_update``)."""
    return bool(controller.new_update)


def set_gripper_state(gripper, grip, current_action, goal_qvel) -> None:
    """Set robosuite's gripper model ``gripper``'s rate-limited command (``current_action``, (2,) in [-1, 1]) and
    its controller ``grip``'s goal (``goal_qvel``), as after ``format_action`` and ``set_goal`` (the arrays are kept)."""
    gripper.current_action = current_action
    grip.goal_qvel = goal_qvel


def hand_back_controller_state(osc, grip, goal_pos, goal_ori, torques) -> None:
    """Leave robosuite's OSC ``osc`` and gripper controller ``grip`` as after ``run_controller``.

    ``goal_pos`` (3,) m and ``goal_ori`` (3, 3) the OSC's goal; ``torques`` (n,) N m its last
    torques (copied).  Both controllers re-read the simulation at their next ``update()``.
    """
    osc.goal_pos, osc.goal_ori = goal_pos, goal_ori
    osc.torques = torques.copy()
    osc.new_update = True
    grip.new_update = True
