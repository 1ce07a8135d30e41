"""In-process tests of report modules the other tests reach only through a new process or MuJoCo
(``--describe`` and the skills' speed report), so the quick tier covers their logic too."""

import pytest

from tableclean_suite.bench import describe, skill_speed
from tableclean_suite.task import TaskModel


def test_describe_reports_the_paper_models_reachability_plan_and_table1_gaps():
    text = describe.describe(TaskModel())
    assert "20 states = 18 non-terminal + 2 terminal" in text
    assert "Shortest plan from Table 1 state 4 (code 0): 8 actions" in text
    assert "Table 1 rows never reachable: 14, 15, 16, 18" in text
    assert "r4" in text and "sarsa" in text and "q_learning" in text


def test_describe_of_another_spec_counts_its_states_without_the_papers_table1():
    model = TaskModel(spec="three_segments")
    text = describe.describe(model)
    assert f"{model.n_states} state codes (3 segments, 1 object" in text
    assert f"{len(model.reachable_states())} states = " in text
    assert "Table 1 rows never reachable" not in text


def _episode(steps, wall_s, env_s, terminal=True, actions=8):
    return {"steps": steps, "wall_s": wall_s, "env_s": env_s, "terminal": terminal, "actions": actions}


def test_skill_speed_goal_numbers_divide_what_the_records_hold():
    comparison = {
        "robosuite": {"episodes": [_episode(600, 4.0, 3.0), _episode(600, 4.0, 3.0)]},
        "fast": {"episodes": [_episode(600, 1.2, 1.0), _episode(600, 1.0, 1.0)]},
        "mujoco": {"steps": 1200, "seconds": 1.0, "substeps": 25},
    }
    goals = skill_speed.goal_numbers(comparison)
    assert goals["episode_s"] == pytest.approx(1.1)
    assert goals["overhead"] == pytest.approx(0.1)  # (2.2 - 2.0) / 2.0
    assert goals["speedup"] == pytest.approx(3.0)  # 600 steps/s against 200 steps/s
    assert goals["raw_ratio"] == pytest.approx(0.5)  # 600 steps/s against 1200 steps/s
    table = skill_speed.format_comparison(comparison)
    assert "fast / robosuite: 3.00x (goal >= 5x: NOT met)" in table
    assert "fast / raw MuJoCo: 0.50 (goal >= 0.8: NOT met)" in table
    for episode in comparison["fast"]["episodes"]:
        episode["env_s"] = 0.5  # 1200 steps/s: 6x robosuite's, raw MuJoCo's rate
    table = skill_speed.format_comparison(comparison)
    assert "fast / robosuite: 6.00x (goal >= 5x: met)" in table
    assert "fast / raw MuJoCo: 1.00 (goal >= 0.8: met)" in table


def test_skill_speed_report_counts_failures_and_terminal_episodes():
    records = {
        "actions": [{"action": "move", "steps": 10, "wall_s": 0.02, "env_s": 0.01, "success": True},
                    {"action": "move", "steps": 20, "wall_s": 0.04, "env_s": 0.03, "success": False},
                    {"action": "clean", "steps": 250, "wall_s": 0.5, "env_s": 0.4, "success": True}],
        "episodes": [_episode(640, 1.3, 1.0), _episode(650, 1.2, 1.0, terminal=False)],
    }
    text = skill_speed.format_report(records)
    move = next(line for line in text.splitlines() if line.startswith("move"))
    assert move.split() == ["move", "2", "15.0", "0.030", "0.020", "1"]
    assert "episode wall time: mean 1.25 s, max 1.30 s" in text
    assert "executor overhead over env.step: 25.00%" in text
    assert "episodes reaching the terminal state: 1/2" in text
