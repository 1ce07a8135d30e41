"""One publication per output folder: stale files go, unlisted files are reported, another
command's folder is refused, and the lock survives the deletion of any file."""

import fcntl
import json
import os
import subprocess
import sys

import pytest

from tableclean_suite.bench import outputs
from publication_check import check_outputs


def _writers(names, tag="A"):
    return {name: (lambda path, name=name: path.write_text(f"{name} {tag}\n")) for name in names}


def test_a_new_publication_removes_the_files_of_the_last_one_it_does_not_rewrite(tmp_path):
    outputs.publish(tmp_path, _writers(["table3.csv", "fig3.png", "fig4.png"]), {})
    outputs.publish(tmp_path, _writers(["table3.csv"], "B"), {})  # e.g. a rerun with --no-figures
    assert sorted(p.name for p in tmp_path.iterdir()) == ["config.json", "table3.csv"]
    assert check_outputs(tmp_path) == []


def test_files_of_an_interrupted_publication_are_removed_by_the_next(tmp_path, monkeypatch):
    outputs.publish(tmp_path, _writers(["table3.csv"]), {})
    real_replace = os.replace

    def crash_on_manifest(source, target):
        if str(target).endswith(outputs.MANIFEST):
            raise KeyboardInterrupt  # kill between the data files and the manifest
        real_replace(source, target)

    monkeypatch.setattr(outputs.os, "replace", crash_on_manifest)
    with pytest.raises(KeyboardInterrupt):
        outputs.publish(tmp_path, _writers(["table3.csv", "fig3.png"], "B"), {})
    monkeypatch.undo()
    assert not (tmp_path / outputs.MANIFEST).exists() and (tmp_path / "fig3.png").exists()
    outputs.publish(tmp_path, _writers(["table3.csv"], "C"), {})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["config.json", "table3.csv"]


def test_check_outputs_reports_a_file_the_manifest_does_not_list(tmp_path):
    outputs.publish(tmp_path, _writers(["table3.csv"]), {}, kept=("study.db",))
    (tmp_path / "study.db").write_text("kept")
    (tmp_path / "cells").mkdir()
    assert check_outputs(tmp_path) == []
    (tmp_path / "fig3.png").write_text("an older run's figure")
    problems = check_outputs(tmp_path)
    assert len(problems) == 1 and "fig3.png" in problems[0] and "not listed" in problems[0]


def test_a_folder_holding_another_commands_publication_is_refused_and_kept(tmp_path):
    outputs.publish(tmp_path, _writers(["table3.csv"]), {"args": {}}, command="run")
    before = (tmp_path / outputs.MANIFEST).read_text()
    assert json.loads(before)["command"] == "run"
    with pytest.raises(outputs.OutputError, match="tableclean-bench run"):
        outputs.publish(tmp_path, _writers(["scaling.csv"]), {}, command="scaling")
    assert "tableclean-bench run" in outputs.check_publishable(tmp_path, command="scaling")
    assert (tmp_path / outputs.MANIFEST).read_text() == before and not (tmp_path / "scaling.csv").exists()


def test_a_manifest_from_before_commands_were_recorded_is_a_run(tmp_path):
    outputs.publish(tmp_path, _writers(["table3.csv"]), {})
    document = json.loads((tmp_path / outputs.MANIFEST).read_text())
    del document["command"]
    (tmp_path / outputs.MANIFEST).write_text(json.dumps(document))
    assert outputs.check_publishable(tmp_path) is None
    assert "tableclean-bench run" in outputs.check_publishable(tmp_path, command="tune")


def test_the_lock_holds_when_every_file_of_the_folder_is_deleted(tmp_path):
    with outputs.output_lock(tmp_path):
        for path in tmp_path.iterdir():
            path.unlink()
        other = os.open(tmp_path, os.O_RDONLY)  # a second writer: its own open file description
        try:
            with pytest.raises(BlockingIOError):
                fcntl.flock(other, fcntl.LOCK_EX | fcntl.LOCK_NB)
        finally:
            os.close(other)
    other = os.open(tmp_path, os.O_RDONLY)
    fcntl.flock(other, fcntl.LOCK_EX | fcntl.LOCK_NB)  # released on leaving
    os.close(other)


def test_a_held_folder_refuses_publish_within_the_wait(tmp_path):
    other = os.open(tmp_path, os.O_RDONLY)
    fcntl.flock(other, fcntl.LOCK_EX)
    try:
        with pytest.raises(outputs.OutputBusyError, match="in use"):
            outputs.publish(tmp_path, _writers(["table3.csv"]), {}, wait=0.2)
    finally:
        os.close(other)


@pytest.mark.parametrize("out", ["x" * 300, "locked/sub"])
def test_an_unusable_out_is_one_line_not_a_traceback(tmp_path, out):
    (tmp_path / "locked").mkdir(mode=0o000)
    try:
        problem = outputs.check_writable(tmp_path / out)
        if os.geteuid() == 0 and out.startswith("locked"):
            pytest.skip("root reads any folder")
        assert problem and "\n" not in problem
        with pytest.raises(outputs.OutputError):
            outputs.publish(tmp_path / out, _writers(["a.csv"]), {})
    finally:
        (tmp_path / "locked").chmod(0o700)


@pytest.mark.cli
def test_scaling_into_a_runs_folder_is_refused_naming_the_run(tmp_path):
    outputs.publish(tmp_path, _writers(["table3.csv"]), {"args": {}}, command="run")
    result = subprocess.run([sys.executable, "-m", "tableclean_suite.bench", "scaling", "--segments", "2",
                             "--objects", "1", "--fixed-plan-objects", "none", "--out", str(tmp_path)],
                            capture_output=True, text=True, timeout=300)
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1 and "tableclean-bench run" in lines[0], result.stderr
    assert json.loads((tmp_path / outputs.MANIFEST).read_text())["command"] == "run"


def test_scalings_config_json_from_before_the_manifest_is_its_own_not_foreign(tmp_path):
    (tmp_path / outputs.MANIFEST).write_text(json.dumps({"study": "scaling", "seed": 0}))
    assert outputs.check_publishable(tmp_path, command="scaling") is None
    assert "tableclean-bench scaling" in outputs.check_publishable(tmp_path, command="run")
    outputs.publish(tmp_path, _writers(["scaling.csv"]), {}, command="scaling")
    assert check_outputs(tmp_path) == []


def test_coverage_publishes_its_table_and_refuses_a_runs_folder(tmp_path, capsys):
    from tableclean_suite.bench import commands

    tiny = ["--runs", "4", "--iterations", "40", "--max-itr", "20", "--learners", "q_learning", "--rewards", "r4",
            "--replications", "2", "--reference-runs", "8", "--bootstrap-samples", "50", "--no-progress"]
    assert commands.main(["coverage", *tiny, "--out", str(tmp_path / "cov")]) == 0
    manifest = json.loads((tmp_path / "cov" / outputs.MANIFEST).read_text())
    assert manifest["command"] == "coverage" and check_outputs(tmp_path / "cov") == []
    outputs.publish(tmp_path / "run", _writers(["table3.csv"]), {"args": {}}, command="run")
    capsys.readouterr()
    assert commands.main(["coverage", *tiny, "--out", str(tmp_path / "run")]) == 2
    assert "tableclean-bench run" in capsys.readouterr().err
