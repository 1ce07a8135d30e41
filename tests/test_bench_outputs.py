"""Output files: atomic, consistent after any interruption, and an unusable --out is refused up front."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tableclean_suite.bench import outputs

ROOT = Path(__file__).resolve().parents[1]
DATA_FILES = ("table3.csv", "table4.csv", "curves.csv")


def _writers(tag: str) -> dict:
    return {name: (lambda path, name=name: path.write_text(f"{name} of run {tag}\n")) for name in DATA_FILES}


def _consistent(out: Path) -> bool:
    """The invariant: either no config.json (no run claimed), or it and its data files agree."""
    return not (out / outputs.MANIFEST).exists() or outputs.check_outputs(out) == []


def test_publish_writes_data_files_then_a_manifest_with_their_digests(tmp_path):
    written = outputs.publish(tmp_path, _writers("A"), {"args": {"runs": 1}})
    assert [p.name for p in written] == [*DATA_FILES, outputs.MANIFEST]
    manifest = json.loads((tmp_path / outputs.MANIFEST).read_text())
    assert manifest["args"] == {"runs": 1} and len(manifest["run_id"]) == 32
    for name in DATA_FILES:
        assert manifest["files"][name]["sha256"] == outputs.sha256_file(tmp_path / name)
    assert outputs.check_outputs(tmp_path) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([*DATA_FILES, outputs.MANIFEST])  # no temporaries
    second = outputs.publish(tmp_path, _writers("B"), {})
    assert json.loads(second[-1].read_text())["run_id"] != manifest["run_id"]


def test_check_outputs_notices_a_file_of_another_run(tmp_path):
    outputs.publish(tmp_path, _writers("A"), {})
    (tmp_path / "table4.csv").write_text("table4.csv of run B\n")
    problems = outputs.check_outputs(tmp_path)
    assert len(problems) == 1 and "table4.csv" in problems[0]
    (tmp_path / outputs.MANIFEST).unlink()
    assert "did not finish" in outputs.check_outputs(tmp_path)[0]


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
    assert not (tmp_path / outputs.MANIFEST).exists()  # run A's manifest is gone, run B's never came
    assert _consistent(tmp_path)
    replaced = set(calls[:crash_at])
    for name in DATA_FILES:  # each data file is entirely run A's or entirely run B's
        assert (tmp_path / name).read_text() == f"{name} of run {'B' if name in replaced else 'A'}\n"
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


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


def test_unusable_out_exits_2_before_training(tmp_path):
    for what, out in _unusable_outs(tmp_path):
        result = cli("--runs", "5", "--iterations", "50", "--no-sweeps", "--no-figures", "--out", str(out))
        assert result.returncode == 2, what
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and "--out" in lines[0] and str(out.parent.name) in lines[0], (what, result.stderr)
        assert "Traceback" not in result.stderr and "cells" not in result.stdout, what


def test_cli_outputs_agree_with_their_manifest(tmp_path):
    out = tmp_path / "out"
    result = cli("--runs", "5", "--iterations", "80", "--rewards", "r4", "--learners", "q_learning", "--no-sweeps",
                 "--no-figures", "--no-progress", "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert outputs.check_outputs(out) == []
    manifest = json.loads((out / outputs.MANIFEST).read_text())
    assert sorted(manifest["files"]) == sorted((*DATA_FILES, "comparisons.csv"))
    assert manifest["args"]["runs"] == 5 and manifest["args"]["rewards"] == ["r4"]
