"""A restorable copy of a ``TableClean`` scene: MuJoCo state (dirt markers included) and gripper commands."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SceneState:
    """What [`TableClean.set_scene_state`][tableclean_suite.environments.table_clean.TableClean.set_scene_state] needs to put a scene back.

    Attributes:
        time: simulation time [s].
        qpos, qvel, act, ctrl, qacc_warmstart: copies of MuJoCo's ``MjData`` arrays; ``qpos``
            holds the dirt markers' wiped flags (their slide joints).
        gripper_commands: each gripper's integrated command (robosuite's Panda gripper
            integrates its input, so a restored grasp would open without it).

    Controller-internal state (e.g. OSC's goal interpolation) is not part of it, so a
    restored scene continues to within ~1e-4 m of the original, not bit for bit.
    """

    time: float
    qpos: np.ndarray
    qvel: np.ndarray
    act: np.ndarray
    ctrl: np.ndarray
    qacc_warmstart: np.ndarray
    gripper_commands: tuple


def _grippers(robots) -> list:
    return [gripper for robot in robots for gripper in robot.gripper.values()]


#: The ``MjData`` arrays a [`SceneState`][tableclean_suite.environments.scene_state.SceneState] copies.
ARRAYS = ("qpos", "qvel", "act", "ctrl", "qacc_warmstart")


def read_scene_state(data, robots) -> SceneState:
    """A copy of the raw ``mujoco.MjData`` ``data``'s state and the grippers' commands of ``robots``."""
    return SceneState(float(data.time), *(getattr(data, name).copy() for name in ARRAYS),
                      gripper_commands=tuple(np.array(gripper.current_action, copy=True) for gripper in _grippers(robots)))


def write_scene_state(data, robots, state: SceneState) -> None:
    """Write ``state`` into ``data`` and the grippers of ``robots`` (the caller forwards the physics);
    ``ValueError`` when it comes from a model of another size."""
    if state.qpos.shape != data.qpos.shape:
        raise ValueError(f"scene state comes from a different TableClean model: qpos has shape {state.qpos.shape}, "
                         f"this model's {data.qpos.shape}")
    data.time = state.time
    for name in ARRAYS:
        getattr(data, name)[:] = getattr(state, name)
    for gripper, command in zip(_grippers(robots), state.gripper_commands):
        gripper.current_action = np.array(command, copy=True)
