"""A kinematic stand-in for TableClean that skills can run on (shared by the skill tests).

The end-effector jumps to each commanded position; nothing else moves.  Subclasses change what
the fingers report (:meth:`KinematicEnv.finger_position`).
"""

from types import SimpleNamespace

import numpy as np

from tableclean_suite.controllers import MoveSkill
from tableclean_suite.controllers.osc import ACTION_DIM
from tableclean_suite.task import TaskState

#: Segment centres (2, 3) [m] of the stand-in table, row 0 = segment 1.
CENTERS = ((0.0, -0.14, 0.8), (0.0, 0.14, 0.8))
#: Open Panda fingers [m].
OPEN_FINGERS = 0.04


def fake_robot(name: str = "OSC_POSE", input_type: str = "absolute", input_ref_frame: str = "world",
               robot: str | None = None) -> SimpleNamespace:
    """The part of a robosuite robot that ``check_skill_env`` reads: its arm's controller (and its name)."""
    controller = SimpleNamespace(name=name, input_type=input_type, input_ref_frame=input_ref_frame)
    robot_fields = {} if robot is None else {"name": robot}
    return SimpleNamespace(arms=["right"], part_controllers={"right": controller}, **robot_fields)


class KinematicEnv:
    """Kinematic stand-in: the end-effector jumps to each commanded position; nothing else moves.

    ``frozen=True`` keeps the end-effector where it is (to exhaust step budgets).
    """

    control_freq = 20
    action_dim = ACTION_DIM

    def __init__(self, arm_segment: int = 0, frozen: bool = False, robot: SimpleNamespace | None = None):
        self.robots = [robot if robot is not None else fake_robot()]
        self.centers = np.array(CENTERS)
        self.eef = self.centers[int(arm_segment)] + [0.0, 0.0, MoveSkill.DEFAULT_CONFIG["hover_height"]]
        self.frozen = frozen
        self.steps = 0

    def finger_position(self) -> float:
        """Each finger's joint position [m] (mirrored on the other finger)."""
        return OPEN_FINGERS

    def skill_info(self):
        q = self.finger_position()
        return {
            "eef_pos": self.eef.copy(),
            "eef_quat": np.array([0.70710678, 0.70710678, 0.0, 0.0]),  # pointing down, yaw pi/2
            "gripper_qpos": np.array([q, -q]),
            "segment_centers": self.centers,
            "table_top_z": 0.8,
        }

    def symbolic_state(self, check_sponge=True):
        arm = int(np.argmin(np.abs(self.centers[:, 1] - self.eef[1])))
        return TaskState((False, False), (1,), arm)

    def step(self, action):
        self.steps += 1
        if not self.frozen:
            self.eef = np.asarray(action[:3], dtype=float).copy()
