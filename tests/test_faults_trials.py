"""Fault battery, stored trials: corrupt or foreign fidelity trials, calibration inputs and robot tables are
refused with one line naming the file and the value, never resumed, converted or republished."""

import json

import pytest

from tableclean_suite.bench import calibrate, fidelity, robot_table, trial_store
from tableclean_suite.learners import TransitionTable
from tableclean_suite.task import Action, TaskModel

MODEL = TaskModel()
PAIRS = [(s.index, a) for s in MODEL.reachable_states() if not s.is_terminal for a in Action]


def trial(state, action, round_index=0, **changes):
    expected, outcome = MODEL.step(state, action)
    row = {
        "round": round_index, "seed": fidelity.round_seed(0, round_index), "layout": "1-1", "reached_by": "plan",
        "state": state, "action": action.name.lower(), "expected_state": expected.index,
        "expected_outcome": outcome.name.lower(), "observed_state": expected.index,
        "observed_outcome": outcome.name.lower(), "agree": 1, "success": 1, "improper": 0, "steps": 20,
        "retries": 0, "wall_time": 0.5, "env_time": 0.4, "reason": "ok",
    }
    row.update(changes)
    return row


def one_round(**changes_of_first):
    rows = [trial(s, a) for s, a in PAIRS]
    rows[0].update(changes_of_first)
    return rows


def write_trials(path, rows, model=MODEL, physics_options=None):
    trial_store.write_rows(path, rows)
    fidelity.configuration_path(path).write_text(json.dumps(fidelity.run_configuration(model, physics_options)))
    return path


CORRUPT_TRIALS = {
    "binary": b"\xff\xfe\x00garbage\x81\x82",
    "nul bytes": ",".join(trial_store.TRIAL_FIELDS).encode() + b"\n1,2\x00,3\n4,5,6\n",
    "other columns": b"a,b,c\n1,2,3\n",
    "blank line": ",".join(trial_store.TRIAL_FIELDS).encode() + b"\n\n1,2,3\n",
}


@pytest.mark.parametrize("kind", CORRUPT_TRIALS)
def test_a_corrupt_trials_file_is_one_resume_error(tmp_path, kind):
    path = tmp_path / fidelity.TRIALS_CSV
    path.write_bytes(CORRUPT_TRIALS[kind])
    with pytest.raises(trial_store.TrialStoreError) as caught:
        trial_store.read_rows(path)
    assert str(path) in str(caught.value) and "\n" not in str(caught.value)


@pytest.mark.parametrize("record", [b"{not json", b"\xff\xfe\x81", b"[1, 2]", b'{"physics_options": {}}'])
def test_a_corrupt_configuration_record_is_one_resume_error(tmp_path, record):
    path = write_trials(tmp_path / fidelity.TRIALS_CSV, one_round())
    fidelity.configuration_path(path).write_bytes(record)
    with pytest.raises(trial_store.TrialStoreError, match="config.json"):
        fidelity.check_configuration(path, fidelity.run_configuration(MODEL, None))


@pytest.mark.parametrize("change", [{"state": 99}, {"action": "wipe"}, {"observed_outcome": "teleported"},
                                    {"observed_state": 99}])
def test_stored_trials_that_do_not_fit_the_task_are_refused_on_resume(tmp_path, change):
    path = write_trials(tmp_path / fidelity.TRIALS_CSV, one_round(**change))
    with pytest.raises(trial_store.TrialStoreError, match=str(next(iter(change.values())))):
        fidelity.collect(1, 0, path, log=None, model=MODEL)


def test_a_deleted_configuration_record_is_not_resumed_as_another_robot(tmp_path):
    path = write_trials(tmp_path / fidelity.TRIALS_CSV, one_round(),
                        physics_options={"env_kwargs": fidelity.scene_env_kwargs("Panda", False)})
    fidelity.configuration_path(path).unlink()
    sawyer = fidelity.run_configuration(MODEL, {"env_kwargs": fidelity.scene_env_kwargs("Sawyer", False)})
    with pytest.raises(trial_store.TrialStoreError, match="unknown"):
        fidelity.check_configuration(path, sawyer)


def _calibrate(tmp_path, capsys, trials, *extra):
    out = tmp_path / "t.json"
    with pytest.raises(SystemExit) as caught:
        calibrate.main(["--from-trials", str(trials), "--out", str(out), "--quiet", *extra])
    error = capsys.readouterr().err.strip().splitlines()
    assert caught.value.code == 2 and len(error) == 1, error
    assert not out.exists()
    return error[0]


@pytest.mark.parametrize("change, named", [
    ({"observed_state": 99}, "99"),
    ({"observed_state": 23, "observed_outcome": "routine"}, "terminal"),  # 23: all clean, not TERMINAL
    ({"observed_outcome": "improper"}, "unchanged"),  # state 0 MOVE observed as improper with another state
    ({"action": "wipe"}, "wipe"),
])
def test_calibrate_validates_every_observed_transition(tmp_path, capsys, change, named):
    if change.get("observed_outcome") == "improper":
        change = {**change, "observed_state": 1}
    trials = write_trials(tmp_path / "trials.csv", one_round(**change))
    assert named in _calibrate(tmp_path, capsys, trials)


def test_calibrate_from_trials_of_another_spec_names_both(tmp_path, capsys):
    trials = write_trials(tmp_path / "trials.csv", one_round())
    message = _calibrate(tmp_path, capsys, trials, "--task", "three_segments")
    assert "'paper'" in message and "'three_segments'" in message


def test_the_calibrated_table_records_the_scene_it_was_measured_in(tmp_path):
    trials = write_trials(tmp_path / "trials.csv", one_round(),
                          physics_options={"env_kwargs": fidelity.scene_env_kwargs("Sawyer", True)})
    out = tmp_path / "t.json"
    assert calibrate.main(["--from-trials", str(trials), "--out", str(out), "--quiet"]) == 0
    source = TransitionTable.from_json(out).source
    assert "robot Sawyer" in source and "randomization on" in source


CORRUPT_TABLES = {
    "binary": b"\xff\xfe\x81\x00",
    "not a table": b"hello,world\n1,2\n",
    "garbage number": (",".join(robot_table.COLUMNS) + "\nPanda,default,paper,nominal,abc,,,,,,,\n").encode(),
    "short row": (",".join(robot_table.COLUMNS) + "\nPanda,paper\n").encode(),
    "no robot": (",".join(robot_table.COLUMNS) + "\n,default,paper,nominal,1,1,1,0,,,,\n").encode(),
}


@pytest.mark.parametrize("kind", CORRUPT_TABLES)
def test_robot_table_append_over_a_corrupt_csv_is_refused(tmp_path, capsys, kind):
    table = tmp_path / robot_table.TABLE_CSV
    table.write_bytes(CORRUPT_TABLES[kind])
    with pytest.raises(robot_table.TableFileError):
        robot_table.merge_rows(table, [])
    with pytest.raises(SystemExit) as caught:
        robot_table.main(["--append", "--out", str(tmp_path), "--robots", "Panda", "--tasks", "paper",
                          "--fidelity-trials", "0", "--episodes", "1", "--quiet"])
    error = capsys.readouterr().err.strip().splitlines()
    assert caught.value.code == 2 and len(error) == 1 and "--append" in error[0], error
    assert table.read_bytes() == CORRUPT_TABLES[kind]  # untouched, nothing ran


def test_robot_table_append_keeps_a_valid_table(tmp_path):
    table = tmp_path / robot_table.TABLE_CSV
    row = robot_table.table_row("Panda", "paper", {"trials": 72, "rounds": 1, "agreement": 1.0, "faults": 0}, None)
    trial_store.write_rows(table, [row], robot_table.COLUMNS)
    merged = robot_table.merge_rows(table, [])
    assert len(merged) == 1 and merged[0]["robot"] == "Panda" and float(merged[0]["fidelity_trials"]) == 72


@pytest.mark.cli
def test_a_second_fidelity_run_into_a_busy_folder_is_refused(tmp_path):
    import subprocess
    import sys

    from tableclean_suite.bench import outputs

    holder = subprocess.Popen(
        [sys.executable, "-c", "import time; from tableclean_suite.bench import outputs\n"
         f"with outputs.output_lock({str(tmp_path)!r}):\n    print('held', flush=True); time.sleep(60)"],
        stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(outputs.OutputBusyError, match="in use by another run"):
            fidelity.collect(1, 0, tmp_path / fidelity.TRIALS_CSV, log=None, model=MODEL)
        assert not (tmp_path / fidelity.TRIALS_CSV).exists()
    finally:
        holder.kill()
        holder.wait()
