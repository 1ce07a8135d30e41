"""A restorable copy of a ``TableClean`` scene: MuJoCo state (dirt markers included) and gripper commands."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SceneState:
    """What :meth:`TableClean.set_scene_state` needs to put a scene back.

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
