"""Output files: atomic, consistent after any interruption, and an unusable --out is refused up front."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tableclean_suite.bench import outputs
from publication_check import check_outputs

ROOT = Path(__file__).resolve().parents[1]
DATA_FILES = ("table3.csv", "table4.csv", "curves.csv")


def _writers(tag: str) -> dict:
    return {name: (lambda path, name=name: path.write_text(f"{name} of run {tag}\n")) for name in DATA_FILES}


def _consistent(out: Path) -> bool:
    """The invariant: either no config.json (no run claimed), or it and its data files agree."""
    return not (out / outputs.MANIFEST).exists() or check_outputs(out) == []


def test_publish_writes_data_files_then_a_manifest_with_their_digests(tmp_path):
    written = outputs.publish(tmp_path, _writers("A"), {"args": {"runs": 1}})
    assert [p.name for p in written] == [*DATA_FILES, outputs.MANIFEST]
    manifest = json.loads((tmp_path / outputs.MANIFEST).read_text())
    assert manifest["args"] == {"runs": 1} and len(manifest["run_id"]) == 32
    for name in DATA_FILES:
        assert manifest["files"][name]["sha256"] == outputs.sha256_file(tmp_path / name)
    assert check_outputs(tmp_path) == []
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == sorted([*DATA_FILES, outputs.MANIFEST])  # no temporaries
    second = outputs.publish(tmp_path, _writers("B"), {})
    assert json.loads(second[-1].read_text())["run_id"] != manifest["run_id"]


def test_check_outputs_notices_a_file_of_another_run(tmp_path):
    outputs.publish(tmp_path, _writers("A"), {})
    (tmp_path / "table4.csv").write_text("table4.csv of run B\n")
    problems = check_outputs(tmp_path)
    assert len(problems) == 1 and "table4.csv" in problems[0]
    (tmp_path / outputs.MANIFEST).unlink()
    assert "did not finish" in check_outputs(tmp_path)[0]


@pytest.mark.parametrize("crash_at", range(len(DATA_FILES) + 1))
def test_a_crash_between_two_replaces_leaves_no_false_claim(tmp_path, monkeypatch, crash_at):
    outputs.publish(tmp_path, _writers("A"), {})
    real_replace, calls = os.replace, []

    def crashing_replace(source, target):
        calls.append(Path(target).name)
        if len(calls) > crash_at:
            raise KeyboardInterrupt("simulated crash")
        real_replace(source, target)

    monkeypatch.setattr(outputs.os, "replace", crashing_replace)
    with pytest.raises(KeyboardInterrupt):
        outputs.publish(tmp_path, _writers("B"), {})
    monkeypatch.undo()
    assert _consistent(tmp_path)  # run A's manifest is intact or gone; run B's never came
    replaced = set(calls[:crash_at])
    for name in DATA_FILES:  # each data file is entirely run A's or entirely run B's
        assert (tmp_path / name).read_text() == f"{name} of run {'B' if name in replaced else 'A'}\n"
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


def _publication(out: Path) -> dict:
    return {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}


@pytest.mark.parametrize("errno_name", ["ENOSPC", "EROFS", "EACCES"])
@pytest.mark.parametrize("failing", range(len(DATA_FILES)))
def test_a_file_system_error_while_writing_keeps_the_last_publication(tmp_path, errno_name, failing):
    import errno

    outputs.publish(tmp_path, _writers("A"), {})
    before = _publication(tmp_path)
    writers = _writers("B")
    name = DATA_FILES[failing]

    def full_disk(path):
        path.write_text("partial")
        code = getattr(errno, errno_name)
        raise OSError(code, os.strerror(code))

    writers[name] = full_disk
    with pytest.raises(outputs.OutputError) as caught:
        outputs.publish(tmp_path, writers, {})
    message = str(caught.value)
    assert name in message and os.strerror(getattr(errno, errno_name)) in message and "\n" not in message
    assert _publication(tmp_path) == before and check_outputs(tmp_path) == []


def test_a_folder_where_a_data_file_goes_is_one_error_and_keeps_the_publication(tmp_path):
    outputs.publish(tmp_path, {"table3.csv": lambda p: p.write_text("A")}, {})
    before = _publication(tmp_path)
    (tmp_path / "table4.csv").mkdir()
    with pytest.raises(outputs.OutputError, match="table4.csv"):
        outputs.publish(tmp_path, _writers("B"), {})
    assert _publication(tmp_path) == before and (tmp_path / "table4.csv").is_dir()


@pytest.mark.parametrize("foreign", ['{"name": "my project"}', "not json at all", ""])
def test_publish_never_deletes_a_config_json_it_did_not_write(tmp_path, foreign):
    (tmp_path / outputs.MANIFEST).write_text(foreign)
    with pytest.raises(outputs.OutputError, match="not written by tableclean_suite"):
        outputs.publish(tmp_path, _writers("A"), {})
    assert (tmp_path / outputs.MANIFEST).read_text() == foreign
    assert not (tmp_path / "table3.csv").exists()


@pytest.mark.parametrize("out", ["", "   ", None])
def test_an_empty_out_is_refused_not_the_current_directory(tmp_path, monkeypatch, out):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(outputs.OutputError, match="empty"):
        outputs.publish(out, _writers("A"), {})
    assert "empty" in outputs.check_writable(out)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.cli
def test_a_second_writer_is_refused_while_the_folder_is_locked(tmp_path):
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, time; from tableclean_suite.bench import outputs\n"
         f"with outputs.output_lock({str(tmp_path)!r}):\n    print('held', flush=True); time.sleep(60)"],
        stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(outputs.OutputBusyError, match="in use by another run"):
            outputs.publish(tmp_path, _writers("A"), {}, wait=0.2)
        assert not (tmp_path / "table3.csv").exists()
    finally:
        holder.kill()
        holder.wait()
    outputs.publish(tmp_path, _writers("A"), {}, wait=5)  # the lock dies with its holder
    assert check_outputs(tmp_path) == []


def test_the_lock_is_reentrant_within_a_process(tmp_path):
    with outputs.output_lock(tmp_path):
        outputs.publish(tmp_path, _writers("A"), {}, wait=0)
    assert check_outputs(tmp_path) == []


def test_a_failing_writer_keeps_the_old_file(tmp_path):
    target = outputs.atomic_write_text(tmp_path / "x.csv", "old\n")

    def half_written(path):
        path.write_text("partial")
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        outputs.atomic_write(target, half_written)
    assert target.read_text() == "old\n" and [p.name for p in tmp_path.iterdir()] == ["x.csv"]


def test_check_writable(tmp_path, monkeypatch):
    assert outputs.check_writable(tmp_path / "new" / "dir") is None and (tmp_path / "new" / "dir").is_dir()
    afile = tmp_path / "afile"
    afile.write_text("")
    assert "is a file" in outputs.check_writable(afile)
    assert "is under" in outputs.check_writable(afile / "sub")

    def refuse(self, data):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(Path, "write_bytes", refuse)  # a read-only directory, even for root
    assert "not writable (Permission denied)" in outputs.check_writable(tmp_path / "ro")


def cli(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "benchmarks.run", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=300)


def _unusable_outs(tmp_path):
    afile = tmp_path / "afile"
    afile.write_text("")
    outs = [("a file", afile), ("a path under a file", afile / "sub" / "dir")]
    if os.geteuid() != 0:  # root writes into read-only directories; the monkeypatched test above covers it
        readonly = tmp_path / "readonly"
        readonly.mkdir()
        readonly.chmod(0o500)
        outs.append(("a read-only directory", readonly / "out"))
    return outs


@pytest.mark.cli
def test_unusable_out_exits_2_before_training(tmp_path):
    for what, out in _unusable_outs(tmp_path):
        result = cli("--runs", "5", "--iterations", "50", "--no-sweeps", "--no-figures", "--out", str(out))
        assert result.returncode == 2, what
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and "--out" in lines[0] and str(out.parent.name) in lines[0], (what, result.stderr)
        assert "Traceback" not in result.stderr and "cells" not in result.stdout, what


@pytest.mark.cli
def test_cli_outputs_agree_with_their_manifest(tmp_path):
    out = tmp_path / "out"
    result = cli("--runs", "5", "--iterations", "80", "--rewards", "r4", "--learners", "q_learning", "--no-sweeps",
                 "--no-figures", "--no-progress", "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert check_outputs(out) == []
    manifest = json.loads((out / outputs.MANIFEST).read_text())
    assert sorted(manifest["files"]) == sorted((*DATA_FILES, "comparisons.csv"))
    assert manifest["args"]["runs"] == 5 and manifest["args"]["rewards"] == ["r4"]


def test_a_cell_store_that_cannot_write_raises_one_output_error(tmp_path):
    from tableclean_suite.bench import experiments

    (tmp_path / "cells").write_text("")
    store = experiments.CellStore(tmp_path / "cells")
    with pytest.raises(outputs.OutputError, match="cannot create the cell folder"):
        store.save(experiments.Cell("q_learning", "r4", 0.3, 0.3), {"x": 1}, None, None)


QUICK_RUN = ("--runs", "5", "--iterations", "50", "--rewards", "r4", "--learners", "q_learning", "--no-sweeps",
             "--no-literature", "--no-figures", "--no-progress")


def _one_line_exit_2(result, *needles):
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr
    assert all(needle in lines[-1] for needle in needles), result.stderr


@pytest.mark.cli
def test_run_refuses_a_foreign_config_json_before_training_and_keeps_it(tmp_path):
    (tmp_path / outputs.MANIFEST).write_text('{"my": "project"}')
    result = cli(*QUICK_RUN, "--out", str(tmp_path))
    _one_line_exit_2(result, "not written by tableclean_suite")
    assert (tmp_path / outputs.MANIFEST).read_text() == '{"my": "project"}' and "cells" not in result.stdout


@pytest.mark.cli
def test_run_refuses_a_file_where_its_cell_folder_goes(tmp_path):
    (tmp_path / "cells").write_text("")
    _one_line_exit_2(cli(*QUICK_RUN, "--out", str(tmp_path)), "cells", "is a file")


@pytest.mark.cli
def test_a_second_run_into_a_busy_out_exits_2_and_the_first_publishes_alone(tmp_path):
    first = subprocess.Popen([sys.executable, "-m", "benchmarks.run", *QUICK_RUN[:-1], "--runs", "5000",
                              "--iterations", "3000", "--seed", "1", "--out", str(tmp_path)], cwd=ROOT,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = 60
        import time

        while not (tmp_path / "cells").exists() and deadline > 0:
            time.sleep(0.2)
            deadline -= 0.2
        second = cli(*QUICK_RUN, "--seed", "2", "--out", str(tmp_path))
    finally:
        out, err = first.communicate(timeout=300)
    assert first.returncode == 0, err
    _one_line_exit_2(second, "in use by another run")
    assert check_outputs(tmp_path) == []
    assert json.loads((tmp_path / outputs.MANIFEST).read_text())["args"]["seed"] == 1
