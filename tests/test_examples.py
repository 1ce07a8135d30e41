"""The shipped examples run from the checkout and extend the task without editing the package."""

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run_example(name: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / "examples" / name), *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=300)


def test_move_back_example_adds_an_action_and_reports_learning():
    result = run_example("move_back.py", "--runs", "40", "--iterations", "1500", "--json")
    assert result.returncode == 0, result.stderr
    rows = {(r["task"], r["learner"]): r for r in json.loads(result.stdout)}
    assert set(rows) == {(t, l) for t in ("three_segments", "three_segments_move_back") for l in ("q_learning", "sarsa")}
    plain, back = rows["three_segments", "q_learning"], rows["three_segments_move_back", "q_learning"]
    assert (plain["actions"], back["actions"]) == (4, 5)
    assert plain["reachable_states"] == back["reachable_states"] == 90
    assert (plain["plan_length"], back["plan_length"]) == (11, 10)
    assert back["optimal_success_exact"] > plain["optimal_success_exact"]  # a shorter plan risks fewer slips
    assert all(0.0 <= r["success_plateau"] <= 1.0 for r in rows.values())


def test_move_back_example_rejects_bad_flags():
    result = run_example("move_back.py", "--runs", "0")
    assert result.returncode == 2 and "--runs must be >= 1" in result.stderr and "Traceback" not in result.stderr
