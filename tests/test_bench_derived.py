"""A run's outputs are the same bytes whether its cells are trained or loaded and its comparisons and
figures computed or loaded from the derived-results cache."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: Small but complete: both paper learners, two rewards, sweeps (all five figures), figures drawn.
ARGS = ("--rewards", "r1", "r4", "--runs", "24", "--iterations", "300", "--alpha-sweep", "0.1", "0.3",
        "--gamma-sweep", "0.3", "0.9", "--no-literature", "--bootstrap-samples", "50", "--no-progress")
FIGURES = ("fig3_success_rate_q_learning.png", "fig4_average_reward_q_learning.png", "fig5_average_reward_sarsa.png",
           "fig6_success_rate_sweeps.png", "fig7_average_reward_sweeps.png")
OUTPUTS = ("table3.csv", "table4.csv", "comparisons.csv", "curves.csv", *FIGURES)


def cli(out: Path, *extra: str) -> subprocess.CompletedProcess:
    result = subprocess.run([sys.executable, "-m", "benchmarks.run", *ARGS, "--out", str(out), *extra], cwd=ROOT,
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    return result


def printed_tables(stdout: str) -> str:
    """The printed tables: stdout without the lines that say where numbers came from and how long it took."""
    return "\n".join(line for line in stdout.splitlines()
                     if not line.startswith(("cells:", "  cell files:", "derived results", "done in", "  /", "written:")))


def file_bytes(out: Path) -> dict:
    return {name: (out / name).read_bytes() for name in OUTPUTS}


def test_warm_fresh_and_empty_caches_write_identical_files_and_tables(tmp_path):
    cold = cli(tmp_path / "a")
    reference = file_bytes(tmp_path / "a")
    warm = cli(tmp_path / "a")  # same --out: every cell loaded
    assert "resumed 0 cells" in cold.stdout and "resumed 6 cells" in warm.stdout and "trained 0" in warm.stdout
    assert "figures): computed in" in cold.stdout and "figures): loaded from" in warm.stdout
    assert file_bytes(tmp_path / "a") == reference
    assert printed_tables(warm.stdout) == printed_tables(cold.stdout)
    fresh = cli(tmp_path / "a", "--fresh")  # cells retrained: the same bytes
    assert "resumed 0 cells" in fresh.stdout and "figures): computed in" in fresh.stdout
    assert file_bytes(tmp_path / "a") == reference
    assert printed_tables(fresh.stdout) == printed_tables(cold.stdout)
    assert max(map(len, printed_tables(cold.stdout).splitlines())) <= 120


@pytest.mark.parametrize("change", [("--bootstrap-samples", "40"), ("--seed", "1")])
def test_a_changed_setting_is_not_served_from_the_caches(tmp_path, change):
    out = tmp_path / "out"
    cli(out)
    before = file_bytes(out)
    changed = cli(out, *change)
    assert "resumed 0 cells" in changed.stdout  # both settings are part of every cell's key
    assert "figures): computed in" in changed.stdout
    after = file_bytes(out)
    assert after["comparisons.csv"] != before["comparisons.csv"]
    assert after["table3.csv"] != before["table3.csv"]
