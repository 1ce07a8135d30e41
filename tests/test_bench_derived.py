"""The derived-results cache (comparisons, figures): warm runs write the bytes cold runs write, and a
changed input, setting or code is never served from it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tableclean_suite.bench import derived, statistics

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


def derived_status(out: Path) -> dict:
    return json.loads((out / "config.json").read_text())["derived"]


def printed_tables(stdout: str) -> str:
    """The printed tables: stdout without the lines that say where numbers came from and how long it took."""
    return "\n".join(line for line in stdout.splitlines()
                     if not line.startswith(("cells:", "derived results", "done in", "  /", "written:")))


def file_bytes(out: Path) -> dict:
    return {name: (out / name).read_bytes() for name in OUTPUTS}


def test_warm_fresh_and_empty_caches_write_identical_files_and_tables(tmp_path):
    cold = cli(tmp_path / "a")
    assert derived_status(tmp_path / "a") == {"comparisons": "computed", "figures": dict.fromkeys(FIGURES, "drawn")}
    reference = file_bytes(tmp_path / "a")

    warm = cli(tmp_path / "a")  # same --out: every cell, the comparisons and every figure from the caches
    assert "resumed 0 cells" in cold.stdout and "resumed 6 cells" in warm.stdout and "trained 0" in warm.stdout
    assert derived_status(tmp_path / "a") == {"comparisons": "loaded", "figures": dict.fromkeys(FIGURES, "loaded")}
    assert file_bytes(tmp_path / "a") == reference
    assert printed_tables(warm.stdout) == printed_tables(cold.stdout)

    fresh = cli(tmp_path / "a", "--fresh")  # caches ignored: everything recomputed, the same bytes
    assert "resumed 0 cells" in fresh.stdout
    assert derived_status(tmp_path / "a") == {"comparisons": "computed", "figures": dict.fromkeys(FIGURES, "drawn")}
    assert file_bytes(tmp_path / "a") == reference
    assert printed_tables(fresh.stdout) == printed_tables(cold.stdout)


@pytest.mark.parametrize("change", [("--bootstrap-samples", "40"), ("--seed", "1")])
def test_a_changed_setting_is_not_served_from_the_caches(tmp_path, change):
    out = tmp_path / "out"
    cli(out)
    before = file_bytes(out)
    changed = cli(out, *change)
    assert "resumed 0 cells" in changed.stdout  # both settings are part of every cell's key
    assert derived_status(out) == {"comparisons": "computed", "figures": dict.fromkeys(FIGURES, "drawn")}
    after = file_bytes(out)
    assert after["comparisons.csv"] != before["comparisons.csv"]
    assert after["table3.csv"] != before["table3.csv"]
    assert any(after[name] != before[name] for name in FIGURES)  # the bands moved
    again = cli(out, *change)  # and the changed run is cached in turn
    assert derived_status(out)["comparisons"] == "loaded" and file_bytes(out) == after
    assert printed_tables(again.stdout) == printed_tables(changed.stdout)


def _cells(seed: int = 0, runs: int = 30) -> list[dict]:
    rng = np.random.default_rng(seed)
    cells = []
    for learner in ("q_learning", "sarsa"):
        for reward in ("r1", "r4"):
            first = rng.integers(1, 60, runs).astype(float)
            first[rng.random(runs) < 0.1] = np.nan
            cells.append({"learner": learner, "reward": reward,
                          "runs": {"success_asymptote": rng.random(runs), "first_success_iterations": first}})
    return cells


def test_comparisons_cache_hits_only_on_the_same_scores_settings_and_code(tmp_path, monkeypatch):
    store = derived.DerivedStore(tmp_path)
    cells = _cells()
    frame, cached = derived.comparisons(store, cells, 0.95, 60, 0)
    assert not cached
    expected = statistics.comparisons(cells, 0.95, 60, 0)
    pd.testing.assert_frame_equal(frame, expected)
    assert frame.to_csv(index=False) == expected.to_csv(index=False)
    again, cached = derived.comparisons(store, cells, 0.95, 60, 0)
    assert cached and again.to_csv(index=False) == expected.to_csv(index=False)
    for settings in ((0.9, 60, 0), (0.95, 61, 0), (0.95, 60, 1)):
        assert not derived.comparisons(store, cells, *settings)[1], settings
    nudged = _cells()
    nudged[2]["runs"]["success_asymptote"][5] = np.nextafter(nudged[2]["runs"]["success_asymptote"][5], 2.0)
    assert not derived.comparisons(store, nudged, 0.95, 60, 0)[1]  # one bit of one run's score
    swapped = [cells[1], cells[0], *cells[2:]]
    assert not derived.comparisons(store, swapped, 0.95, 60, 0)[1]  # order matters (X over Y)
    real = derived.source_digest
    monkeypatch.setattr(derived, "source_digest", lambda *names: real(*names) + "-edited")
    assert not derived.comparisons(store, cells, 0.95, 60, 0)[1]  # other statistics code
    monkeypatch.undo()
    assert not derived.DerivedStore(tmp_path, read=False).load("comparisons",
                                                               derived.comparisons_key(cells, 0.95, 60, 0))


def test_store_ignores_a_damaged_or_colliding_entry(tmp_path, capsys):
    store = derived.DerivedStore(tmp_path)
    key = {"what": "x", "n": 1}
    path = store.save("thing", key, b"payload")
    assert store.load("thing", key) == b"payload"
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporaries left
    data = path.read_bytes()
    path.write_bytes(data[:-1] + b"P")  # damaged payload
    assert store.load("thing", key) is None and "does not match" in capsys.readouterr().err
    other = {"what": "x", "n": 2}
    path.write_bytes(data.replace(derived._key_text(key).encode().replace(b'"', b'\\"'),
                                  derived._key_text(other).encode().replace(b'"', b'\\"')))
    assert store.load("thing", key) is None and "key differs" in capsys.readouterr().err
    store.save("thing", key, b"payload")
    assert store.load("thing", key) == b"payload"


def test_frame_digest_sees_values_dtypes_and_order():
    frame = pd.DataFrame({"name": ["a", "b"], "x": [0.0, 1.0], "n": [1, 2]})
    digest = derived.frame_digest(frame)
    assert derived.frame_digest(frame.copy()) == digest
    assert derived.frame_digest(frame.assign(x=[-0.0, 1.0])) != digest
    assert derived.frame_digest(frame.assign(n=[1.0, 2.0])) != digest
    assert derived.frame_digest(frame.assign(name=["a", "c"])) != digest
    assert derived.frame_digest(frame.iloc[::-1].reset_index(drop=True)) != digest
    assert derived.frame_digest(frame.assign(name=["a", None])) != digest


def test_figure_key_covers_matplotlib_settings_and_plotting_code(tmp_path):
    import matplotlib

    base = derived.matplotlib_config()
    key = derived.figure_key("fig3_success_rate_q_learning", "c" * 64, "t" * 64, 0.25, 120, base)
    assert key["code"] == derived.source_digest("tableclean_suite.bench.plots")
    assert key["versions"]["matplotlib"] == matplotlib.__version__
    with matplotlib.rc_context({"lines.linewidth": 3.0}):
        assert derived.matplotlib_config() != base
    assert derived.matplotlib_config() == base
    for other in (derived.figure_key("fig3_success_rate_q_learning", "c" * 64, "t" * 64, 0.25, 100, base),
                  derived.figure_key("fig3_success_rate_q_learning", "d" * 64, "t" * 64, 0.25, 120, base),
                  derived.figure_key("fig3_success_rate_q_learning", "c" * 64, None, 0.25, 120, base),
                  derived.figure_key("fig3_success_rate_q_learning", "c" * 64, "t" * 64, 0.5, 120, base),
                  derived.figure_key("fig4_average_reward_q_learning", "c" * 64, "t" * 64, 0.25, 120, base)):
        assert derived.key_hash(other) != derived.key_hash(key)


def test_figures_drawn_in_forked_processes_are_the_bytes_drawn_here(tmp_path):
    """start_figures' forked drawing (the default run's) writes the PNG bytes serial drawing does,
    stores them, and a second start loads them without drawing."""
    from tableclean_suite.bench import experiments, tables
    from tableclean_suite.bench.config import RunConfig
    from tableclean_suite.task import TaskModel

    cell = experiments.Cell("q_learning", "r1", 0.3, 0.3)
    config = RunConfig(runs=12, iterations=150, bootstrap_samples=20, seed=0)
    summary, stats, *_ = experiments.train_cell(cell, config, TaskModel())
    records, curves = experiments.cell_records([experiments.Membership("main", cell)], {cell: summary}, {cell: stats})
    table3 = tables.table3(records)
    frame = tables.curves_long(records, curves)
    serial = derived.figures(derived.DerivedStore(tmp_path / "serial"), frame, 0.25, table3, 60, processes=1)
    store = derived.DerivedStore(tmp_path / "forked")
    forked = derived.start_figures(store, frame, 0.25, table3, 60, processes=2).result()
    assert [f.name for f in forked] == [f.name for f in serial] == ["fig3_success_rate_q_learning.png",
                                                                    "fig4_average_reward_q_learning.png"]
    assert [f.png for f in forked] == [f.png for f in serial] and not any(f.cached for f in forked)
    again = derived.start_figures(store, frame, 0.25, table3, 60, processes=2).result()
    assert all(f.cached for f in again) and [f.png for f in again] == [f.png for f in serial]
