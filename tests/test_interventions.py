"""``tableclean-bench interventions``: one factor changed per intervention, figures per arm, tiny sizes."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from tableclean_suite.bench import commands, interventions

TINY = ["--runs", "6", "--scale", "0.05", "--seed", "2"]


def test_each_intervention_changes_exactly_its_one_factor():
    known = interventions.interventions()
    assert {"q_init", "routine_reward", "loop_memory", "epsilon", "max_itr", "budget_r3", "budget_sarsa",
            "gamma_r3", "gamma_sarsa"} <= set(known)
    for item in known.values():
        before, after = item.settings("before"), item.settings("after")
        changed = interventions.changed_text(before, after)  # "key old -> new", comma-separated
        assert changed.count(" -> ") == 1, (item.name, changed)
        assert item.figure in interventions.FIGURES and item.direction in (-1, 1)
    routine = known["routine_reward"].settings("after")["reward"]
    assert routine.routine == 0.0 and routine.terminal == 1.0  # r3 with only the routine reward changed
    assert known["loop_memory"].settings("after")["reward"].looping_memory == 0


def test_tiny_run_writes_both_arms_and_is_deterministic(tmp_path, capsys):
    out = tmp_path / "iv"
    argv = [*TINY, "--only", "epsilon,q_init", "--out", str(out)]
    assert interventions.main(argv) == 0
    printed = capsys.readouterr().out
    frame = pd.read_csv(out / "interventions.csv")
    assert list(frame["intervention"]) == ["epsilon", "epsilon", "q_init", "q_init"]
    assert list(frame["arm"]) == ["before", "after"] * 2
    assert list(frame["iterations"]) == [200, 200, 200, 200]  # 4000 x 0.05
    epsilon = frame[frame["intervention"] == "epsilon"].set_index("arm")
    assert epsilon.loc["before", "epsilon"] == 0.1 and epsilon.loc["after", "epsilon"] == 0.01
    for name in ("censored_share", "success_plateau", "never_terminal_share"):
        assert (frame[f"{name}_low"] <= frame[name]).all() and (frame[name] <= frame[f"{name}_high"]).all()
    finite = np.isfinite(frame["learning_time"])
    assert (frame.loc[finite, "learning_time"] <= frame.loc[finite, "iterations"]).all()
    for name, arms in frame.groupby("intervention", sort=False):  # one change per intervention, as the rule gives
        item = interventions.interventions()[name]
        before, after = (arms[arms["arm"] == arm].iloc[0].to_dict() for arm in ("before", "after"))
        assert set(arms["change"]) == {interventions.observed_change(item, before, after)}
    assert "verdict" not in frame.columns
    assert "epsilon 0.1 -> 0.01" in printed and "q_init None -> 1.0" in printed
    assert max(map(len, printed.splitlines())) <= 120
    assert interventions.main([*argv[:-1], str(tmp_path / "again")]) == 0
    again = pd.read_csv(tmp_path / "again" / "interventions.csv")
    pd.testing.assert_frame_equal(again.drop(columns="seconds"), frame.drop(columns="seconds"))


def test_the_plateau_is_the_exact_success_of_the_final_policies():
    from tableclean_suite import asymptotes
    from tableclean_suite.learners import train
    from tableclean_suite.task import TaskModel

    settings = interventions.interventions()["epsilon"].settings("after", 0.05)
    arm = interventions.measure_arm(settings, 5, 1)
    model = TaskModel()
    result = train("q_learning", "r4", runs=5, iterations=settings["iterations"], epsilon=0.01, seed=1, task=model)
    exact = asymptotes.greedy_asymptotes(result.q, 0.01, asymptotes.EpisodeChain.build(model, "r4"), 500).success
    assert arm["success_plateau"] == pytest.approx(float(np.mean(exact)))
    assert arm["censored_share"] == pytest.approx(float(np.mean(result.learned_at < 0)))


@pytest.mark.parametrize(("figure", "direction", "before", "after", "expected"), [
    ("censored_share", -1, (0.8, 0.7, 0.9), (0.1, 0.0, 0.2), "in the predicted direction"),
    ("censored_share", -1, (0.1, 0.0, 0.2), (0.8, 0.7, 0.9), "in the opposite direction"),
    ("censored_share", -1, (0.5, 0.3, 0.7), (0.4, 0.2, 0.6), "no clear change"),
    ("censored_share", -1, (0.5, 0.3, 0.7), (0.2, 0.1, 0.3), "no clear change"),  # touching intervals overlap
    ("success_plateau", 1, (0.87, 0.86, 0.88), (0.98, 0.97, 0.99), "in the predicted direction"),
    ("success_plateau", 1, (0.98, 0.97, 0.99), (0.87, 0.86, 0.88), "in the opposite direction"),
    ("learning_time", -1, (math.inf, 900.0, math.inf), (300.0, 250.0, 350.0), "in the predicted direction"),
])
def test_a_change_needs_separated_intervals(figure, direction, before, after, expected):
    item = interventions.Intervention("x", "claim", "factor", {}, {}, figure, direction)

    def arm(values):
        return {figure: values[0], f"{figure}_low": values[1], f"{figure}_high": values[2]}

    assert interventions.observed_change(item, arm(before), arm(after)) == expected


@pytest.mark.parametrize("flag", [["--only", "nope"], ["--only", "q_init,nope"], ["--runs", "0"],
                                  ["--scale", "0"], ["--scale", "2"], ["--seed", "-1"]])
def test_bad_input_is_one_line_and_exit_2(flag, tmp_path, capsys):
    code = commands.main(["interventions", *flag, "--out", str(tmp_path / "iv")], prog="tableclean-bench")
    error = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(error) == 1 and "error" in error[0], error
    assert flag[1] in error[0] or flag[1].split(",")[-1] in error[0]
    assert not (tmp_path / "iv" / "interventions.csv").exists()


def test_ctrl_c_is_one_line_and_exit_130(tmp_path, capsys, monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(interventions, "measure_arm", interrupted)
    code = commands.main(["interventions", *TINY, "--out", str(tmp_path / "iv")], prog="tableclean-bench")
    error = capsys.readouterr().err.strip().splitlines()
    assert code == 130 and len(error) == 1 and "interrupted" in error[0], error
    assert not (tmp_path / "iv" / "interventions.csv").exists()
