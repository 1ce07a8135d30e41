"""In-process tests of ``--describe``, which the other tests reach only through a new process."""

from tableclean_suite.bench import describe
from tableclean_suite.task import TaskModel


def test_describe_reports_the_paper_models_reachability_plan_and_table1_gaps():
    text = describe.describe(TaskModel())
    assert "20 states = 18 non-terminal + 2 terminal" in text
    assert "Shortest plan from Table 1 state 4 (code 0): 8 actions" in text
    assert "Table 1 rows never reachable: 14, 15, 16, 18" in text
    assert "r4" in text and "sarsa" in text and "q_learning" in text


def test_describe_of_another_spec_counts_its_states_without_the_papers_table1():
    model = TaskModel(spec="three_segments")
    text = describe.describe(model)
    assert f"{model.n_states} state codes (3 segments, 1 object" in text
    assert f"{len(model.reachable_states())} states = " in text
    assert "Table 1 rows never reachable" not in text
