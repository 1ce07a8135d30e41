"""The figures select their rows by factorized codes: the same rows as comparing the text."""

import pandas as pd
import pytest

from tableclean_suite.bench import plots

pytestmark = pytest.mark.quick


def _frame(rewards):
    return pd.DataFrame({"learner": ["q_learning", "sarsa"] * len(rewards),
                         "reward": [r for r in rewards for _ in range(2)],
                         "experiment": ["main"] * (2 * len(rewards)),
                         "value": range(2 * len(rewards))}).astype({"learner": "string", "reward": "string"})


def test_selection_matches_comparing_the_text_and_follows_a_new_frame():
    frame = _frame(["r1", "r2", "r4"])
    picked = plots._select(frame, learner="sarsa", reward="r2")
    expected = frame[(frame["learner"] == "sarsa") & (frame["reward"] == "r2")]
    assert picked.equals(expected) and len(picked) == 1
    assert len(plots._select(frame, reward="r3")) == 0  # absent value: no rows
    other = _frame(["r3"])  # another frame (the codes of the last one must not be reused)
    assert plots._select(other, reward="r3")["value"].tolist() == [0, 1]
    assert plots._matches(other, "experiment", "main").all()
    assert not plots._matches(other, "experiment", "alpha_sweep").any()


def test_code_columns_factorizes_the_selected_columns_once_for_the_frame():
    frame = _frame(["r1", "r4"])
    plots.code_columns(frame)  # before forking the drawing processes
    coded, columns = plots._CODED
    assert coded is frame and set(columns) == {"learner", "reward", "experiment"}  # the frame has no "metric"
    assert plots._select(frame, reward="r4")["value"].tolist() == [2, 3]


def test_the_learning_time_figure_is_offered_only_with_the_kaplan_meier_curves():
    rows = [{"learner": "q_learning", "reward": "r4", "alpha": 0.3, "gamma": 0.3, "experiment": "main",
             "iteration": t, "metric": metric, "value": value, "low": value, "high": value}
            for t, value in ((1, 1.0), (2, 0.5), (3, 0.25)) for metric in ("success", "not_learned")]
    frame = pd.DataFrame(rows)
    assert "fig8_learning_time_q_learning" in plots.available_figures(frame)
    assert "fig8_learning_time_q_learning" not in plots.available_figures(frame[frame["metric"] == "success"])
    png = plots.render_png("fig8_learning_time_q_learning", frame, 0.25, None, 40)
    assert png.startswith(b"\x89PNG")
