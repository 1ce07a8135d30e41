"""``tableclean-bench speed`` (:mod:`tableclean_suite.bench.speed`): what its tables compute from the
measurements, the page it writes, and the measurements themselves on tiny sizes."""

import sys

import numpy as np
import pytest

from tableclean_suite.bench import speed


def _episode(steps, wall_s, env_s, terminal=True):
    return {"steps": steps, "wall_s": wall_s, "env_s": env_s, "terminal": terminal}


def test_the_skill_table_divides_the_rates_measured_on_each_path():
    measured = {"robosuite": [_episode(600, 4.0, 3.0), _episode(600, 4.0, 3.0)],  # 200 steps/s
                "compiled": [_episode(600, 1.2, 1.0), _episode(600, 1.0, 1.0)],  # 600 steps/s
                "mujoco_s": 1.0}  # the compiled episodes' 1200 steps in 1 s
    rows = {row["path"]: row for row in speed.skill_rows(measured)}
    assert rows["compiled skills"]["rate / robosuite env.step"] == "3.00"
    assert rows["compiled skills"]["rate / raw MuJoCo"] == "0.50"
    assert rows["raw MuJoCo mj_step"]["control steps/s"] == "1200"
    assert rows["robosuite env.step"]["s per episode"] == "4.00" and rows["raw MuJoCo mj_step"]["s per episode"] == "-"
    assert speed.executor_overhead(measured["compiled"]) == pytest.approx(0.1)  # (2.2 - 2.0) / 2.0


def test_every_learner_is_timed_against_q_learning_with_planning_counted_apart():
    from tableclean_suite.learners import learner_names

    table = speed.learner_table("r4", runs=2, iterations=50, repeat=1)
    rows = {row["learner"]: row for row in table.rows}
    assert list(rows) == list(learner_names())
    assert rows["q_learning"]["time per update / Q-learning's"] == "1.00"
    assert float(rows["dyna_q"]["planning M updates/s"]) > 0
    assert all(row["planning M updates/s"] == "0.00" for name, row in rows.items() if name != "dyna_q")


def test_the_compiled_learners_are_compared_with_the_reference_engine():
    table = speed.plain_loop_table(runs=50, iterations=40, repeat=1)
    assert [row["learner"] for row in table.rows] == list(speed.PLAIN_LOOP_LEARNERS)
    assert all(float(row["step-at-a-time M updates/s"]) > 0 for row in table.rows)


def test_the_page_is_stamped_with_the_machine_and_marks_a_failed_section():
    stamp = speed.machine()
    assert {"CPU", "cores", "OS", "Python", "numba", "mujoco", "date (UTC)"} <= set(stamp)
    sections = {"learners": speed.Section([speed.Table("Learners", [{"learner": "q_learning", "M updates/s": "5.0"}],
                                                       "how")]),
                "cold-start": speed.Section([speed.Table("Cold", [{"seconds": "9.00"}])], failed=True)}
    text = speed.page(sections, stamp)
    assert text.startswith("# Measurements\n")
    assert f"| Python | {stamp['Python']} |" in text
    assert "### Learners\n\n| learner | M updates/s |\n|---|---|\n| q_learning | 5.0 |\n\nhow" in text
    assert "## learners\n" in text and "## cold-start (a measurement failed)" in text


def test_a_timed_process_runs_this_package(tmp_path):
    seconds, finished = speed.time_process(["-c", "import tableclean_suite, os; print(tableclean_suite.__file__, "
                                                  "os.environ['MARK'])"], tmp_path, MARK="seen")
    import tableclean_suite

    assert finished.returncode == 0 and seconds > 0
    assert finished.stdout.split() == [tableclean_suite.__file__, "seen"]


def test_the_command_writes_the_page_it_printed(tmp_path, capsys):
    page = tmp_path / "docs" / "measurements.md"
    assert speed.main(["--sections", "learners", "--runs", "2", "--iterations", "50", "--repeat", "1",
                       "--markdown", str(page)]) == 0
    printed = capsys.readouterr().out
    text = page.read_text()
    assert "== learners ==" in printed and "Compiled learners against the step-at-a-time loop" in printed
    assert "## learners" in text and "### Compiled learners against the step-at-a-time loop" in text
    assert "## skills" not in text


@pytest.mark.slow
def test_a_compiled_episode_records_every_control_steps_state_for_the_replay():
    from tableclean_suite.controllers import make_skill_env
    from tableclean_suite.controllers.fast_control import LOG_FIELDS, fast_stepper_of

    env = make_skill_env(1, 1, seed=1, hard_reset=False)
    try:
        episode, states = speed.run_episode(env, record_states=True)
        assert episode["terminal"] and episode["steps"] == len(states) > 0
        assert fast_stepper_of(env).state_log is None  # handed over: the stepper no longer logs
        assert all(set(state) == set(LOG_FIELDS) for state in states)
        assert all(not np.array_equal(a["qpos"], b["qpos"]) for a, b in zip(states, states[1:]))
        assert speed.replay_mujoco(env, states) > 0
    finally:
        env.close()
    robosuite_path = make_skill_env(1, 1, seed=1, fast_control=False)
    try:
        with pytest.raises(ValueError, match="stepper"):
            speed.run_episode(robosuite_path, record_states=True)
    finally:
        robosuite_path.close()


@pytest.mark.cli
def test_the_old_entry_point_runs_the_command(tmp_path):
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    finished = subprocess.run([sys.executable, "-m", "benchmarks.speed", "--sections", "nope"], cwd=root,
                              capture_output=True, text=True)
    assert finished.returncode == 2
    assert finished.stderr.strip().startswith("python -m benchmarks.speed: error: argument --sections")
