"""Fault battery, reports: nothing printed or written that claims what was not measured or hides what it is."""

import pandas as pd
import pytest

from tableclean_suite.bench import experiments, fidelity, tables


def _record(**extra):
    base = {"max_success_iterations": 100, "max_success_episodes": 5.5, "reward_convergence_iterations": 120,
            "reward_convergence_episodes": 6.25, "success_plateau": 0.875, "max_average_reward": 0.25,
            "average_reward_plateau": 0.2, "terminal_plateau": 0.9,
            **dict.fromkeys(("success_window_mean", "average_reward_window_mean", "held_success_iterations",
                             "held_success_episodes", "greedy_success_plateau", "never_terminal_share"))}
    cell = experiments.Cell("q_learning", "r4", 0.3, 0.3)
    return {"cell_id": cell.label, "learner": "q_learning", "reward": "r4", "alpha": 0.3, "gamma": 0.3,
            "experiment": "main", **base, **extra}


@pytest.mark.parametrize("checkpoint, written", [(None, None), (0, None), (2250, 2250)])
def test_an_unmeasured_checkpoint_is_empty_not_zero(tmp_path, checkpoint, written):
    frame = tables.table3([_record(checkpoint_iteration=checkpoint)])
    value = frame["checkpoint_iteration"].iloc[0]
    assert (value is pd.NA) if written is None else (value == written)
    path = tmp_path / "table3.csv"
    frame.to_csv(path, index=False)
    cell = pd.read_csv(path, dtype=str, keep_default_na=False)["checkpoint_iteration"].iloc[0]
    assert cell == ("" if written is None else str(written))


def test_the_printed_table3_names_its_backend(capsys):
    from tableclean_suite.bench import run
    from tableclean_suite.bench.config import RunConfig

    config = RunConfig(out="unused", backend="calibrated", transitions="t.json")
    frame = tables.table3([_record(checkpoint_iteration=None)])
    run._print_tables(config, frame, tables.table4(frame), "paper", True)
    printed = capsys.readouterr().out
    header = printed[printed.index("Table 3:"):].split("\n\n")[0]  # the title, wrapped over its lines
    assert "calibrated backend" in " ".join(header.split())


def test_episode_failure_reasons_name_actions_not_numbers(monkeypatch):
    from tableclean_suite import controllers

    class Result:
        def __init__(self, action, success, reason=""):
            self.action, self.success, self.reason = action, success, reason
            self.state_after, self.expected, self.retries = None, None, 0

    class FakeController:
        def __init__(self, env):
            from tableclean_suite.task import TaskModel

            self.model = TaskModel()

        def execute_plan(self, plan):
            return [Result(0, True), Result(3, False, "the sponge slipped")]

    class FakeEnv:
        def reset(self):
            pass

        def symbolic_state(self):
            from tableclean_suite.task import TaskModel

            return TaskModel().start_state

        def close(self):
            pass

    monkeypatch.setattr(controllers, "SkillController", FakeController)
    monkeypatch.setattr(controllers, "make_skill_env", lambda *a, **k: FakeEnv())
    result = fidelity.play_episodes(1, log=None, robots="Panda", task="paper")
    (episode, reason, _), = result["failures"]
    assert reason == "clean: the sponge slipped"
    assert result["successes"] == 0 and result["skills"] == {"move": [1, 1, 0, 0], "clean": [1, 0, 0, 0]}
