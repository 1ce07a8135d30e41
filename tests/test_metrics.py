"""Metric functions on tiny hand-made records with hand-computed answers."""

import dataclasses

import numpy as np
import pytest

import curve_oracle
from tableclean_suite import curves, metrics
from tableclean_suite.learners import TrainingResult
from tableclean_suite.task import Outcome

ROUTINE, IMPROPER, TERMINAL = int(Outcome.ROUTINE), int(Outcome.IMPROPER), int(Outcome.TERMINAL)


@pytest.fixture
def tiny():
    # run 0: [t0-1] terminal, no improper -> success; [t2-4] truncated with an improper action; t5 unfinished
    # run 1: [t0-2] terminal but with an improper action -> failure; [t3-5] terminal, clean -> success
    episode_end = np.array([[0, 1, 0, 0, 2, 0], [0, 0, 1, 0, 0, 1]], dtype=np.int8)
    outcomes = np.array(
        [[ROUTINE, TERMINAL, IMPROPER, ROUTINE, ROUTINE, ROUTINE], [IMPROPER, ROUTINE, TERMINAL, ROUTINE, ROUTINE, TERMINAL]],
        dtype=np.int8,
    )
    rewards = np.array([[-0.01, 1.0, -1.0, 0.01, 0.01, 0.5], [-1.0, 0.01, 1.0, 0.01, 0.01, 1.0]])
    zeros = np.zeros_like(episode_end)
    return TrainingResult(rewards, outcomes, zeros, zeros, episode_end, np.zeros((2, 24, 4)))


def test_episode_table_of_a_window_without_a_finished_episode():
    from tableclean_suite.learners import train

    table = train("q_learning", "r4", runs=2, iterations=3, max_itr=60, seed=0).episodes()
    assert len(table) == 0 and {"run", "episode", "success"} <= set(table.columns)


def test_episode_table(tiny):
    table = tiny.episodes()
    assert table["run"].tolist() == [0, 0, 1, 1]
    assert table["episode"].tolist() == [0, 1, 0, 1]
    assert table["length"].tolist() == [2, 3, 3, 3]
    np.testing.assert_allclose(table["return"], [0.99, -0.98, 0.01, 1.02])
    assert table["success"].tolist() == [True, False, False, True]
    assert table["reached_terminal"].tolist() == [True, False, True, True]
    assert table["improper_actions"].tolist() == [0, 1, 1, 0]


def test_success_curve(tiny):
    np.testing.assert_array_equal(curves.learning_curves(tiny)["success"], [0, 0.5, 0.5, 0.5, 0, 0.5])


def test_terminal_curve(tiny):
    np.testing.assert_array_equal(curves.learning_curves(tiny)["terminal"], [0, 0.5, 1, 1, 0.5, 0.5])


def test_average_reward_curve(tiny):
    a0, b0, a1, b1 = 0.99 / 2, -0.98 / 3, 0.01 / 3, 1.02 / 3
    expected = [np.nan, a0, (a0 + a1) / 2, (a0 + a1) / 2, (b0 + a1) / 2, (b0 + b1) / 2]
    np.testing.assert_allclose(curves.learning_curves(tiny)["average_reward"], expected)


def test_episodes_curve(tiny):
    np.testing.assert_array_equal(curves.learning_curves(tiny)["episodes"], [0, 0.5, 1, 1, 1.5, 2])


def test_plateau_and_iterations_to_max_success():
    curve = [0, 0.2, 0.4, 0.6, 0.8, 1.0, 1.0, 1.0]
    assert metrics.plateau(curve) == 1.0  # last 25 % = last 2 points
    assert metrics.iterations_to_max_success(curve) == 6  # first >= 0.95 at index 5 -> 6 iterations
    assert metrics.iterations_to_max_success(curve, threshold=0.5) == 4
    assert metrics.iterations_to_max_success([0.0] * 8) == 1  # a flat zero curve is at its plateau at once


def test_reward_convergence_from_early_minimum():
    curve = [0.5, -1.0, -0.5, 0.0, 0.5, 1.0, 1.0, 1.0]
    # minimum -1 at index 1; level = -1 + 0.95 * (1 - (-1)) = 0.9; first reached at index 5
    assert metrics.reward_convergence_iteration(curve) == 6
    # all-NaN early part (no episode finished before the plateau window): undefined
    assert metrics.reward_convergence_iteration([np.nan, np.nan, np.nan, 0.2]) is None


@pytest.mark.parametrize("bad", [0.0, 1.5, -0.1])
def test_bad_fractions_are_rejected(bad):
    with pytest.raises(ValueError, match="must be in"):
        metrics.plateau([1.0, 2.0], plateau_fraction=bad)
    with pytest.raises(ValueError, match="must be in"):
        metrics.iterations_to_max_success([1.0, 2.0], threshold=bad)


def test_summarize_returns_a_typed_frozen_summary(tiny):
    summary = metrics.summarize(tiny)
    assert isinstance(summary, metrics.Summary)
    assert metrics.SUMMARY_SCALARS == (
        "max_success_iterations", "max_success_episodes", "reward_convergence_iterations",
        "reward_convergence_episodes", "success_plateau", "max_average_reward", "average_reward_plateau",
        "terminal_plateau", "success_window_mean", "average_reward_window_mean", "held_success_iterations",
        "held_success_episodes", "greedy_success_plateau", "never_terminal_share",
    )
    assert metrics.ITERATION_SCALARS == ("max_success_iterations", "reward_convergence_iterations",
                                         "held_success_iterations")
    assert metrics.CURVE_NAMES == ("success", "average_reward", "terminal", "episodes")
    assert tuple(summary.scalars()) == metrics.SUMMARY_SCALARS and tuple(summary.curves()) == metrics.CURVE_NAMES
    assert summary.success_plateau == pytest.approx(np.mean([0.0, 0.5]))  # last 2 of 6 iterations
    np.testing.assert_array_equal(summary.success, curves.learning_curves(tiny)["success"])
    with pytest.raises(dataclasses.FrozenInstanceError):
        summary.success_plateau = 1.0
    with pytest.raises(ValueError):
        summary.success[0] = 1.0  # curves are read-only


def test_summary_rejects_curves_of_different_lengths():
    scalars = dict.fromkeys(metrics.SUMMARY_SCALARS, 0.5)
    with pytest.raises(ValueError, match="differ in length"):
        metrics.Summary(**scalars, success=np.zeros(3), average_reward=np.zeros(3), terminal=np.zeros(3),
                        episodes=np.zeros(4))


def _assert_same_summary(a, b):
    for name in metrics.SUMMARY_SCALARS:
        x, y = getattr(a, name), getattr(b, name)
        assert x == y or (x != x and y != y), name  # equal, or both NaN
    for name in metrics.CURVE_NAMES:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))  # bit-identical, NaN where NaN


def test_curve_sums_chunk_by_chunk_equal_one_pass():
    from tableclean_suite.learners import train

    runs, settings = 37, dict(iterations=700, max_itr=60, seed=5)
    whole = train("sarsa", "r1", runs=runs, **settings)
    sums = curves.CurveSums.zeros(700)
    for first in range(0, runs, 10):  # chunks of 10, 10, 10, 7 runs, trained separately
        sums.add(train("sarsa", "r1", runs=min(10, runs - first), first_run=first, **settings))
    assert sums.runs == runs
    _assert_same_summary(metrics.summarize(sums), metrics.summarize(whole))
    assert metrics.summarize(whole).max_success_iterations is not None  # the comparison is not vacuous
    with pytest.raises(ValueError, match="iterations"):
        sums.add(train("sarsa", "r1", runs=1, iterations=5))
    with pytest.raises(ValueError, match="no runs"):
        curves.CurveSums.zeros(3).curves()


def test_compiled_curves_equal_per_run_matrices_on_real_training():
    from tableclean_suite.learners import train

    result = train("sarsa", "r4", runs=64, iterations=1500, max_itr=60, seed=4)
    mean = curves.learning_curves(result)
    np.testing.assert_array_equal(mean["success"], curve_oracle.success_matrix(result).mean(axis=0))
    np.testing.assert_array_equal(mean["terminal"], curve_oracle.terminal_matrix(result).mean(axis=0))
    np.testing.assert_array_equal(mean["episodes"], np.cumsum(result.episode_end != 0, axis=1).mean(axis=0))
    per_run = curve_oracle.average_reward_matrix(result)
    started = ~np.all(np.isnan(per_run), axis=0)  # iterations at which some run has finished an episode
    assert np.all(np.isnan(mean["average_reward"][~started]))
    np.testing.assert_allclose(
        mean["average_reward"][started], np.nanmean(per_run[:, started], axis=0), rtol=1e-12, atol=1e-15
    )


def test_support_fraction_hides_points_resting_on_few_runs(tiny):
    # run 0 finishes its first episode at t1, run 1 at t2: with half the runs required t1 counts,
    # with all runs required only t2 on
    half = curves.CurveSums.zeros(6).add(tiny).curves(support_fraction=0.5)["average_reward"]
    full = curves.CurveSums.zeros(6).add(tiny).curves(support_fraction=1.0)["average_reward"]
    assert np.isnan(half[0]) and not np.isnan(half[1])
    assert np.isnan(full[:2]).all() and not np.isnan(full[2:]).any()
    np.testing.assert_array_equal(full[2:], half[2:])  # the rule removes points, never changes them
    with pytest.raises(ValueError, match="support_fraction"):
        curves.CurveSums.zeros(6).add(tiny).curves(support_fraction=1.5)


def test_given_plateaus_replace_the_window_mean():
    success = np.array([0.0, 0.5, 0.8, 0.9, 0.9, 1.0, 0.9, 0.9])
    # window mean (last 2) = 0.9 -> level 0.855 first reached at index 3; asymptote 1.0 -> 0.95 at index 5
    assert metrics.iterations_to_max_success(success) == 4
    assert metrics.iterations_to_max_success(success, top=1.0) == 6
    reward = np.array([0.1, -0.4, -0.2, 0.3, 0.5, 0.6, 0.9, 0.2])
    # asymptote 0.6: reached first at index 5, early minimum -0.4 at index 1 (before it);
    # level = -0.4 + 0.95 * (0.6 + 0.4) = 0.55 -> index 5
    assert metrics.early_minimum(reward, top=0.6) == 1
    assert metrics.reward_convergence_iteration(reward, top=0.6) == 6
    # the window does not enter: a later dip (index 7) is not the early minimum
    longer = np.r_[reward, [-5.0] * 20]
    assert metrics.reward_convergence_iteration(longer, top=0.6) == 6


def test_summarize_with_plateaus_and_support(tiny):
    plateaus = metrics.Plateaus(success=0.5, average_reward=0.1, terminal=1.0)
    summary = metrics.summarize(tiny, plateaus=plateaus, support_fraction=1.0)
    assert summary.success_plateau == 0.5 and summary.terminal_plateau == 1.0
    assert summary.success_window_mean == pytest.approx(0.25)
    assert summary.max_success_iterations == 2  # 0.5 >= 0.95 * 0.5 at t = 2
    assert np.isnan(summary.average_reward[:2]).all()
    # max average reward over supported points only: (a0 + a1) / 2, not a0 = 0.495 at t2 (one run)
    assert summary.max_average_reward == pytest.approx((0.99 / 2 + 0.01 / 3) / 2)


def test_curve_sums_keep_the_squares_of_the_average_rewards(tiny):
    sums = curves.CurveSums.zeros(6).add(tiny)
    per_run = curve_oracle.average_reward_matrix(tiny)
    np.testing.assert_allclose(sums.average_square, np.nansum(per_run ** 2, axis=0), rtol=1e-15)
    np.testing.assert_array_equal(sums.finished_runs, (~np.isnan(per_run)).sum(axis=0))


def test_curve_sums_do_not_depend_on_chunking():
    from tableclean_suite.learners import train

    settings = dict(iterations=400, max_itr=60, seed=3)
    whole = curves.CurveSums.zeros(400).add(train("q_learning", "r4", runs=11, **settings))
    chunked = curves.CurveSums.zeros(400)
    for first in (0, 5):
        chunked.add(train("q_learning", "r4", runs=min(5, 11 - first), first_run=first, **settings))
    chunked.add(train("q_learning", "r4", runs=1, first_run=10, **settings))
    for name in ("success", "average_sum", "average_square", "episodes"):
        assert getattr(whole, name).tobytes() == getattr(chunked, name).tobytes()


def test_reward_convergence_of_a_falling_curve_starts_from_its_early_maximum():
    # starts above its asymptote 0.2 and falls: early extreme = maximum 1.0 at index 1;
    # level = 1.0 + 0.95 * (0.2 - 1.0) = 0.24; first at or below it: index 4
    curve = [np.nan, 1.0, 0.8, 0.5, 0.22, 0.2, 0.21]
    assert metrics.early_minimum(curve, top=0.2) == 1
    assert metrics.reward_convergence_iteration(curve, top=0.2) == 5


def test_held_reaching_waits_until_the_curve_stays_above_its_level():
    #        t: 1    2    3    4    5    6    7    8
    curve = [0.0, 0.9, 0.5, 0.9, 0.9, 0.9, 0.4, 0.9]
    assert metrics.first_reaching(curve, 0.8) == 2  # hold 1 is the first touch
    assert metrics.first_reaching(curve, 0.8, hold=3) == 4  # 4, 5, 6 stay above; 2 falls back at 3
    assert metrics.first_reaching(curve, 0.8, start=4, hold=2) == 5  # from t = 5 on
    assert metrics.first_reaching(curve, 0.8, hold=4) is None  # no four in a row inside the window
    assert metrics.first_reaching(curve, 0.8, hold=9) is None  # longer than the window
    assert metrics.first_reaching([1.0] * 8, np.nan) is None  # a level that is not finite is never reached
    with pytest.raises(ValueError, match="hold must be an integer >= 1"):
        metrics.first_reaching(curve, 0.8, hold=0)


def test_summarize_reports_held_reaching_and_the_mechanism_plateaus(tiny):
    plateaus = metrics.Plateaus(success=0.5, average_reward=0.1, terminal=0.5, greedy_success=0.75,
                                never_terminal=0.25)
    summary = metrics.summarize(tiny, threshold=1.0, plateaus=plateaus, hold=1)
    assert summary.held_success_iterations == summary.max_success_iterations == 2  # hold 1 = first touch
    # success [0, .5, .5, .5, 0, .5]: at the level for t = 2, 3, 4 (three in a row), then below at t = 5
    assert metrics.summarize(tiny, threshold=1.0, plateaus=plateaus, hold=3).held_success_iterations == 2
    held = metrics.summarize(tiny, threshold=1.0, plateaus=plateaus, hold=4)
    assert held.held_success_iterations is None and held.held_success_episodes is None
    assert (summary.greedy_success_plateau, summary.never_terminal_share) == (0.75, 0.25)
    assert np.isnan(metrics.summarize(tiny).greedy_success_plateau)  # window means: not known
