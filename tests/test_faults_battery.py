"""Fault battery through the command registry: each kind of operator fault ends with exit 2 and
one line on stderr naming the problem, no traceback, and nothing written that claims a result.

In process (``commands.main``), so the quick tier runs it; the cases that need other processes (locks held
by another run, kill -9, Ctrl-C, Ray) are in test_faults_waits.py, test_bench_outputs.py and
test_faults_trials.py.
"""

import json

import pytest

from tableclean_suite import resources
from tableclean_suite.bench import commands, fidelity, outputs, trial_store
from tableclean_suite.task import Action, TaskModel

QUICK = ["--runs", "4", "--iterations", "40", "--rewards", "r4", "--learners", "q_learning", "--no-sweeps",
         "--no-literature", "--no-figures", "--no-progress"]


def _refused(capsys, argv, *needles):
    code = commands.main(argv, prog="tableclean-bench")
    err = capsys.readouterr().err
    lines = [line for line in err.strip().splitlines() if line.strip() and "robosuite" not in line]
    assert code == 2, err
    assert len(lines) == 1 and "Traceback" not in err, err
    assert all(needle in lines[0] for needle in needles), lines[0]
    return lines[0]


def _spec(tmp_path, document) -> str:
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(document) if not isinstance(document, str) else document)
    return str(path)


# -- resources ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("case", ["22 segments", "14 segments x 2 objects", "maximum budget", "long budget"])
def test_resource_refusals(tmp_path, capsys, monkeypatch, case):
    monkeypatch.delenv(resources.OVERRIDE_ENV, raising=False)
    monkeypatch.setattr(resources, "available_bytes", lambda: 16 * 1024**3)
    from tableclean_suite.bench import digests  # the task's digest builds its table: refused before that

    monkeypatch.setattr(digests, "task_digest", lambda model: pytest.fail("the table was built before the refusal"))
    argv = {"22 segments": ["--task", _spec(tmp_path, {"name": "huge", "segments": 22})],
            # 12 x 2 now fits (simulated asymptotes, about 10 hours estimated, under the 24-hour guard); 14 x 2 does not
            "14 segments x 2 objects": ["--task", _spec(tmp_path, {"name": "big", "segments": 14, "objects": 2})],
            "maximum budget": ["--runs", "10000000", "--iterations", "100000000"],
            "long budget": ["--runs", "1000000", "--iterations", "10000000"]}[case]
    message = _refused(capsys, ["run", *argv, "--no-progress", "--out", str(tmp_path / "out")],
                       resources.OVERRIDE_ENV)
    assert "GiB" in message or "days" in message
    assert not (tmp_path / "out" / outputs.MANIFEST).exists()


def test_tune_refuses_a_budget_whose_records_cannot_fit(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv(resources.OVERRIDE_ENV, raising=False)
    monkeypatch.setattr(resources, "available_bytes", lambda: 16 * 1024**3)
    _refused(capsys, ["tune", "--runs", "100000", "--iterations", "1000000", "--trials", "1", "--out", str(tmp_path)],
             "records", resources.OVERRIDE_ENV)


# -- output folders ----------------------------------------------------------------------------------
@pytest.mark.parametrize("case", ["out is a file", "cells is a file", "foreign config.json", "table3.csv is a folder"])
def test_output_folder_refusals(tmp_path, capsys, case):
    out = tmp_path / "out"
    if case == "out is a file":
        out.write_text("")
    else:
        out.mkdir()
    if case == "cells is a file":
        (out / "cells").write_text("")
    if case == "foreign config.json":
        (out / outputs.MANIFEST).write_text('{"mine": true}')
    if case == "table3.csv is a folder":
        (out / "table3.csv").mkdir()
    _refused(capsys, ["run", *QUICK, "--out", str(out)])
    if case == "foreign config.json":
        assert (out / outputs.MANIFEST).read_text() == '{"mine": true}'
    elif out.is_dir():
        assert not (out / outputs.MANIFEST).exists()


# -- task specs --------------------------------------------------------------------------------------
@pytest.mark.parametrize("document", [
    {"name": "x", "segments": "3"},
    {"name": "x", "segments": "3", "start_state": {"clean": [False] * 3, "objects": [1], "arm": 1}},
    {"name": "x", "objects": [["box"]]},
    '{"name": "x", "objects": ' + "[" * 100000 + "]" * 100000 + "}",
    "not json",
])
def test_spec_file_refusals(tmp_path, capsys, document):
    _refused(capsys, ["run", *QUICK, "--task", _spec(tmp_path, document), "--out", str(tmp_path / "out")],
             "spec.json")


# -- tune ---------------------------------------------------------------------------------------------
TUNE = ["tune", "--runs", "4", "--iterations", "200", "--trials", "1", "--seed", "1"]


@pytest.mark.parametrize("storage", ["foo://x", "mysql://user@127.0.0.1:1/db"])
def test_tune_storage_refusals(tmp_path, capsys, storage):
    _refused(capsys, [*TUNE, "--out", str(tmp_path), "--storage", storage], "--storage", storage)


def test_tune_study_bound_to_its_configuration(tmp_path, capsys):
    assert commands.main([*TUNE, "--out", str(tmp_path), "--study-name", "s"], prog="tableclean-bench") == 0
    capsys.readouterr()
    _refused(capsys, [*TUNE, "--reward", "r2", "--out", str(tmp_path), "--study-name", "s"], "reward=", "'s'")


# -- stored trials --------------------------------------------------------------------------------------
def _trials(tmp_path, change=None, record=True):
    model = TaskModel()
    rows = []
    for state in (s for s in model.reachable_states() if not s.is_terminal):
        for action in Action:
            expected, outcome = model.step(state, action)
            rows.append({"round": 0, "seed": fidelity.round_seed(0, 0), "layout": "1-1", "reached_by": "plan",
                         "state": state.index, "action": action.name.lower(), "expected_state": expected.index,
                         "expected_outcome": outcome.name.lower(), "observed_state": expected.index,
                         "observed_outcome": outcome.name.lower(), "agree": 1, "success": 1, "improper": 0,
                         "steps": 1, "retries": 0, "wall_time": 0.1, "env_time": 0.1, "reason": "ok"})
    rows[0].update(change or {})
    path = tmp_path / "trials.csv"
    trial_store.write_rows(path, rows)
    if record:
        fidelity.configuration_path(path).write_text(json.dumps(fidelity.run_configuration(model, None)))
    return path


@pytest.mark.parametrize("case", ["observed state 99", "another spec", "binary file"])
def test_calibrate_refusals(tmp_path, capsys, case):
    trials = _trials(tmp_path, {"observed_state": 99} if case == "observed state 99" else None)
    extra = ["--task", "three_segments"] if case == "another spec" else []
    if case == "binary file":
        trials.write_bytes(b"\xff\xfe\x81garbage")
    out = tmp_path / "t.json"
    _refused(capsys, ["calibrate", "--from-trials", str(trials), "--out", str(out), "--quiet", *extra])
    assert not out.exists()


def test_fidelity_resume_without_its_configuration_is_refused(tmp_path, capsys):
    trials = _trials(tmp_path, record=False)
    trials.rename(tmp_path / fidelity.TRIALS_CSV)
    _refused(capsys, ["fidelity", "--trials", "1", "--out", str(tmp_path), "--quiet"], "unknown")
