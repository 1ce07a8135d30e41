"""The figures draw exactly the rows of their learner, metric and experiment: the rows comparing the
text would select, from whichever frame they are given."""

import numpy as np
import pandas as pd
import pytest

from tableclean_suite.bench import plots

pytestmark = pytest.mark.quick


def _frame(rewards, offset=0.0):
    """Two learners x ``rewards`` x two experiments, three iterations each; every row's value distinct."""
    rows = [{"learner": learner, "reward": reward, "experiment": experiment, "metric": "average_reward",
             "iteration": t, "value": offset + 100 * i + t}
            for i, (learner, reward, experiment) in enumerate(
                (learner, reward, experiment) for learner in ("q_learning", "sarsa") for reward in rewards
                for experiment in ("main", "alpha_sweep"))
            for t in (1, 2, 3)]
    return pd.DataFrame(rows).astype({"learner": "string", "reward": "string"})


def _drawn(frame, learner, experiment="main"):
    """``{reward: values}`` of the lines ``plot_rewards`` draws (no plateau lines)."""
    fig, ax = plots.plot_rewards(frame, learner, "average_reward", experiment=experiment, plateau_fraction=None)
    try:
        return {line.get_label(): np.asarray(line.get_ydata(), dtype=float) for line in ax.get_lines()}
    finally:
        plots.pyplot().close(fig)


def _expected(frame, learner, experiment="main"):
    rows = frame[(frame["learner"] == learner) & (frame["experiment"] == experiment)]
    return {reward: rows[rows["reward"] == reward].sort_values("iteration")["value"].to_numpy(dtype=float)
            for reward in dict.fromkeys(rows["reward"])}


def _same(a, b):
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)


def test_a_figure_draws_the_rows_comparing_the_text_selects_and_follows_a_new_frame():
    frame = _frame(["r1", "r2", "r4"])
    for learner in ("q_learning", "sarsa"):
        for experiment in ("main", "alpha_sweep"):
            drawn = _drawn(frame, learner, experiment)
            assert len(drawn) == 3 and _same(drawn, _expected(frame, learner, experiment))
    assert _drawn(frame, "expected_sarsa") == {}  # absent value: no rows, no lines
    other = _frame(["r3"], offset=0.5)  # another frame: what was read from the last one must not be reused
    assert _same(_drawn(other, "sarsa"), _expected(other, "sarsa"))


def test_the_learning_time_figure_is_offered_only_with_the_kaplan_meier_curves():
    rows = [{"learner": "q_learning", "reward": "r4", "alpha": 0.3, "gamma": 0.3, "experiment": "main",
             "iteration": t, "metric": metric, "value": value, "low": value, "high": value}
            for t, value in ((1, 1.0), (2, 0.5), (3, 0.25)) for metric in ("success", "not_learned")]
    frame = pd.DataFrame(rows)
    assert "fig8_learning_time_q_learning" in plots.available_figures(frame)
    assert "fig8_learning_time_q_learning" not in plots.available_figures(frame[frame["metric"] == "success"])
    png = plots.render_png("fig8_learning_time_q_learning", frame, 0.25, None, 40)
    assert png.startswith(b"\x89PNG")
