"""The spec-speed benchmark's pure parts (no timing assertions)."""

from __future__ import annotations

import pytest

from tableclean_suite.bench import spec_speed
from tableclean_suite.bench.scaling import DEFAULT_SEGMENTS

NUMBA_LOG = """
[cache] index saved to /x/kernel.train_batch-70.py311.nbi
[cache] data saved to /x/kernel.train_batch-70.py311.1.nbc
[cache] data loaded from /x/metrics._latest_episode_curves-1.nbc
[cache] data loaded from /x/kernel.epsilon_greedy-2.nbc
"""


def test_count_cache_events_counts_saves_and_loads():
    assert spec_speed.count_cache_events(NUMBA_LOG) == (1, 2)
    assert spec_speed.count_cache_events("") == (0, 0)


def test_rate_ratio_and_target():
    paper = spec_speed.Rate("paper", 24, 1000, 1.0)
    largest = spec_speed.Rate("big", 46080, 1000, 4.0)
    assert paper.per_second == 1000.0
    assert spec_speed.rate_ratio(largest, paper) == pytest.approx(0.25)
    assert spec_speed.within_target(0.5) and not spec_speed.within_target(0.49)


def test_largest_spec_is_the_studys_largest():
    spec = spec_speed.largest_study_spec()
    assert spec.segments == max(DEFAULT_SEGMENTS) and spec.n_states > 30_000


def test_measure_rates_counts_updates_per_spec():
    from tableclean_suite.task import get_task_spec

    rates = spec_speed.measure_rates([get_task_spec("paper"), get_task_spec("three_segments")], 2, 50, 1)
    assert [r.spec for r in rates] == ["paper", "three_segments"]
    assert [r.codes for r in rates] == [24, 96]
    assert all(r.updates == 100 and r.seconds > 0 for r in rates)


def test_summary_names_the_verdict():
    paper = spec_speed.Rate("paper", 24, 1000, 1.0)
    slow = spec_speed.Rate("big", 46080, 1000, 3.0)
    cold = [spec_speed.ColdStart(5.0, 1, 0, 0), spec_speed.ColdStart(2.0, 0, 3, 0)]
    text = "\n".join(spec_speed.summary_lines(paper, slow, cold))
    assert "NO" in text and "ratio largest/paper: 0.33" in text
    assert "compiled 1" in text and "loaded from disk cache 3" in text


def test_summary_labels_the_three_cold_start_processes_and_the_goal():
    paper = spec_speed.Rate("paper", 24, 1000, 1.0)
    (first, _), (warm, _), (off, _) = spec_speed.COLD_START_PROCESSES
    cold = [spec_speed.ColdStart(30.0, 39, 0, 0, first, 0), spec_speed.ColdStart(1.3, 0, 0, 0, warm, 17),
            spec_speed.ColdStart(9.0, 0, 5, 0, off, 0)]
    text = "\n".join(spec_speed.summary_lines(paper, paper, cold))
    assert "#1 first process (empty numba and result caches): 30.00 s" in text
    assert "#2 second process (warm numba and result caches): 1.30 s" in text and "cells resumed 17" in text
    assert "#3 second process, result caches off (numba cache only): 9.00 s" in text
    assert "within 3 s: yes" in text
    slow = [cold[0], spec_speed.ColdStart(3.5, 0, 0, 0, warm, 17), cold[2]]
    assert "within 3 s: NO" in "\n".join(spec_speed.summary_lines(paper, paper, slow))


def test_cold_start_processes_share_the_warm_out_but_not_the_uncached_one():
    outs = [out for _, out in spec_speed.COLD_START_PROCESSES]
    assert outs[0] == outs[1] != outs[2]


def test_bad_flag_exits_2(capsys):
    from tableclean_suite.bench import speed

    with pytest.raises(SystemExit) as stop:
        speed.main(["--runs", "-3"], alias="spec_speed")
    assert stop.value.code == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_cold_start_lines_are_empty_without_processes_and_name_the_warm_goal():
    (_, _), (warm, _), (_, _) = spec_speed.COLD_START_PROCESSES
    assert spec_speed.cold_start_lines([]) == []
    process = spec_speed.ColdStart(2.0, 0, 3, 0, warm, 17)
    assert spec_speed.warm_process([process]) is process and spec_speed.warm_within_target(process)
    assert not spec_speed.warm_within_target(spec_speed.ColdStart(2.0, 0, 3, 1, warm, 17))  # failed: not met
    assert spec_speed.cold_start_lines([process])[-1].endswith("within 3 s: yes")
