"""The grasp's hover wait: the descent starts once the hand is nearly still over the body (``hover_still_speed``)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from tableclean_suite.controllers.primitives import SPONGE, Grasp
from tableclean_suite.environments.robot_registry import skill_overrides

DT = 0.05  # s, one control step at 20 Hz


def _skill(still, steps=0):
    return SimpleNamespace(config={"hover_still_speed": still}, steps=steps, dt=DT)


def _hover_checks(still, xy_per_step, steps=4):
    """ready("HOVER") at successive control steps while the hand moves ``xy_per_step`` (2,) m per step."""
    grasp = Grasp(SPONGE, "sponge grasp")
    grasp._hover_seen = None
    skill = _skill(still)
    answers = []
    for step in range(steps):
        skill.steps = step
        info = {"eef_pos": np.array([0.1 + step * xy_per_step[0], 0.2 + step * xy_per_step[1], 0.9])}
        answers.append(grasp.ready(skill, info, "HOVER"))
    return answers


def test_hand_arriving_fast_waits_at_the_hover_point():
    # 0.24 m/s along y (the Kinova3's measured arrival): not settled at 0.05 m/s
    assert _hover_checks(0.05, (0.0, 0.24 * DT)) == [False] * 4


def test_nearly_still_hand_descends_after_one_measured_step():
    # 0.02 m/s: the first check has no speed yet, the next ones pass
    assert _hover_checks(0.05, (0.02 * DT, 0.0)) == [False, True, True, True]


def test_without_the_setting_the_descent_starts_on_arrival():
    assert _hover_checks(None, (0.0, 0.24 * DT)) == [True] * 4


def test_a_gap_in_the_checks_measures_no_speed():
    grasp = Grasp(SPONGE, "sponge grasp")
    grasp._hover_seen = (3, np.array([0.1, 0.2]))  # seen 2 steps ago: no one-step speed
    info = {"eef_pos": np.array([0.1, 0.2, 0.9])}
    assert not grasp.ready(_skill(0.05, steps=5), info, "HOVER")
    assert grasp.ready(_skill(0.05, steps=6), info, "HOVER")


def test_only_the_kinova3_clean_waits():
    assert skill_overrides("Kinova3", "clean")["hover_still_speed"] > 0.0
    assert "hover_still_speed" not in skill_overrides("Panda", "clean")
    assert "hover_still_speed" not in skill_overrides("Kinova3", "pick")
