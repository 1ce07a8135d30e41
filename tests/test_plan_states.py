"""``SkillController.execute_plan`` reads the symbolic state once per action boundary: an action starts from the
state the one before ended in (nothing moves in between), and a subclass's own ``execute`` is still called."""

from __future__ import annotations

import pytest

from kinematic_env import KinematicEnv
from tableclean_suite.controllers import SkillController
from tableclean_suite.task import TaskModel

pytestmark = pytest.mark.quick


class CountingEnv(KinematicEnv):
    """The kinematic stand-in counting its symbolic-state reads."""

    def __init__(self):
        super().__init__(arm_segment=0)
        self.reads = 0

    def symbolic_state(self, check_sponge=True):
        self.reads += 1
        return super().symbolic_state(check_sponge)


def test_a_plan_reads_the_state_once_per_action_boundary():
    env = CountingEnv()
    results = SkillController(env, TaskModel()).execute_plan(["move", "move"])
    assert [r.success for r in results] == [True, True]
    assert results[1].state_before == results[0].state_after and results[0].state_after.arm == 1
    assert env.reads == len(results) + 1  # before the first action, then after each


def test_an_overridden_execute_runs_for_every_action_of_a_plan():
    class Logging(SkillController):
        def execute(self, action):
            self.seen.append(action)
            return super().execute(action)

    env = CountingEnv()
    controller = Logging(env, TaskModel())
    controller.seen = []
    results = controller.execute_plan(["move", "move"])
    assert controller.seen == ["move", "move"] and [r.success for r in results] == [True, True]
    assert env.reads == 2 * len(results)  # each execute reads its own start
