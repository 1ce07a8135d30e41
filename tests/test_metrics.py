"""Metric functions on tiny hand-made records with hand-computed answers."""

import numpy as np
import pytest

from tableclean_suite import metrics
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
    np.testing.assert_array_equal(metrics.success_curve(tiny), [0, 0.5, 0.5, 0.5, 0, 0.5])


def test_terminal_curve(tiny):
    np.testing.assert_array_equal(metrics.terminal_curve(tiny), [0, 0.5, 1, 1, 0.5, 0.5])


def test_average_reward_curve(tiny):
    a0, b0, a1, b1 = 0.99 / 2, -0.98 / 3, 0.01 / 3, 1.02 / 3
    expected = [np.nan, a0, (a0 + a1) / 2, (a0 + a1) / 2, (b0 + a1) / 2, (b0 + b1) / 2]
    np.testing.assert_allclose(metrics.average_reward_curve(tiny), expected)


def test_episodes_curve(tiny):
    np.testing.assert_array_equal(metrics.episodes_curve(tiny), [0, 0.5, 1, 1, 1.5, 2])


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


def test_episodes_at():
    assert metrics.episodes_at(np.array([0.0, 0.5, 1.0]), 2) == 0.5
    assert metrics.episodes_at(np.array([0.0]), None) is None


@pytest.mark.parametrize("bad", [0.0, 1.5, -0.1])
def test_bad_fractions_are_rejected(bad):
    with pytest.raises(ValueError, match="must be in"):
        metrics.plateau([1.0, 2.0], plateau_fraction=bad)
    with pytest.raises(ValueError, match="must be in"):
        metrics.iterations_to_max_success([1.0, 2.0], threshold=bad)


def test_summarize_keys(tiny):
    summary = metrics.summarize(tiny)
    for key in (
        "max_success_iterations", "max_success_episodes", "reward_convergence_iterations",
        "reward_convergence_episodes", "success_plateau", "max_average_reward",
    ):
        assert key in summary
    assert summary["success_plateau"] == pytest.approx(np.mean([0.0, 0.5]))  # last 2 of 6 iterations


def test_compiled_curves_equal_per_run_matrices_on_real_training():
    from tableclean_suite.learners import train

    result = train("sarsa", "r4", runs=64, iterations=1500, max_itr=60, seed=4)
    curves = metrics.learning_curves(result)
    np.testing.assert_array_equal(curves["success"], metrics.success_matrix(result).mean(axis=0))
    np.testing.assert_array_equal(curves["terminal"], metrics.terminal_matrix(result).mean(axis=0))
    np.testing.assert_array_equal(curves["episodes"], np.cumsum(result.episode_end != 0, axis=1).mean(axis=0))
    per_run = metrics.average_reward_matrix(result)
    started = ~np.all(np.isnan(per_run), axis=0)  # iterations at which some run has finished an episode
    assert np.all(np.isnan(curves["average_reward"][~started]))
    np.testing.assert_allclose(
        curves["average_reward"][started], np.nanmean(per_run[:, started], axis=0), rtol=1e-12, atol=1e-15
    )
