"""The speed report says how far each time goal is from being met."""

import time

import pytest

from tableclean_suite.bench import goal_text, speed

pytestmark = pytest.mark.quick


def test_a_time_says_how_far_over_or_under_its_goal_it_is():
    assert goal_text.seconds_against_goal(5.32, 4.0) == "5.32 s (1.33x the 4 s goal, 1.32 s over)"
    assert goal_text.seconds_against_goal(3.0, 4.0) == "3.00 s (0.75x the 4 s goal, 1.00 s under)"


def test_a_lower_bound_goal_says_above_or_below():
    assert goal_text.against_goal("12.0x", 12.0, 10.0, "10x", False, "2.000") == "12.0x (1.20x the 10x goal, 2.000 above)"
    assert goal_text.against_goal("8.0x", 8.0, 10.0, "10x", False, "2.000") == "8.0x (0.80x the 10x goal, 2.000 below)"


def test_the_default_run_is_timed_several_times_and_the_median_kept(monkeypatch):
    from tableclean_suite.bench import run

    lengths = iter([0.0, 0.05, 0.0, 0.02])  # the warm-up, then three timed runs

    def fake_main(argv):
        assert "--fresh" in argv
        time.sleep(next(lengths))
        return 0

    monkeypatch.setattr(run, "main", fake_main)
    timing = speed.time_default_run(repeats=3)
    assert len(timing["walls"]) == 3
    assert timing["walls"][0] >= 0.05 and timing["walls"][2] >= 0.02
    assert timing["wall_s"] == timing["walls"][2]  # the middle one: 0.0 < 0.02 < 0.05


@pytest.mark.parametrize("code, error", [(130, KeyboardInterrupt), (2, RuntimeError)])
def test_the_default_run_timing_stops_when_a_run_did_not_finish(monkeypatch, code, error):
    from tableclean_suite.bench import run

    calls = []
    monkeypatch.setattr(run, "main", lambda argv: calls.append(argv) or code)
    with pytest.raises(error):
        speed.time_default_run(repeats=3)
    assert len(calls) == 1  # the warm-up's failure ends it: no timing of a cut-short run
