"""Per-run learning time (``first_learned_at``, ``learned_at``) against a brute-force replay, and the tie rule.

The oracle here shares no code with the training loop: it reads each run's Q-table after every
iteration (``checkpoint=t``, the loop's own snapshot) and walks the greedy paths with the task
model's Python rules (``TaskModel.step``) and its breadth-first shortest plans.
"""

import numpy as np
import pytest

from tableclean_suite.learners import train
from tableclean_suite.task import TaskModel
from learner_oracle import oracle_train

LEARNED = ("first_learned_at", "learned_at")


def plan_length(model, state) -> int:
    plan = model.shortest_plan(state)
    return -1 if plan is None else len(plan)


def greedy_is_optimal(model, q, ties) -> bool:
    """Every start reaches the terminal state in its shortest-plan number of steps following the
    greedy action (ties: the first, or under random ties every tied one)."""
    lengths = {}

    def length(state):
        if state not in lengths:
            lengths[state] = plan_length(model, state)
        return lengths[state]

    frontier = [s.index for s in model.start_states()]
    seen = set(frontier)
    while frontier:
        code = frontier.pop()
        state = model.decode(code)
        if state.is_terminal:
            continue
        row = q[code]
        tied = [a for a in range(len(row)) if row[a] == row.max()]
        for action in tied if ties == "random" else tied[:1]:
            nxt = model.step(state, action)[0]
            if length(code) < 0 or length(nxt.index) != length(code) - 1:
                return False
            if nxt.index not in seen:
                seen.add(nxt.index)
                frontier.append(nxt.index)
    return True


def replayed_learning_times(learner, reward, iterations, ties="first", **kwargs):
    """``(first_learned_at, learned_at)`` per run from the Q-table after every iteration."""
    model = TaskModel(spec=kwargs.get("task", "paper"), start=kwargs.pop("start", None))
    kwargs["task"] = model
    final = train(learner, reward, iterations=iterations, ties=ties, **kwargs)
    runs = final.runs
    initial = np.zeros((runs, model.n_states, model.n_actions))
    tables = [initial] + [train(learner, reward, iterations=iterations, ties=ties, checkpoint=t, **kwargs)
                          .info["checkpoint_q"] for t in range(1, iterations + 1)]
    optimal = np.array([[greedy_is_optimal(model, q[r], ties) for q in tables] for r in range(runs)])
    first = np.array([int(np.argmax(row)) if row.any() else -1 for row in optimal])
    learned = np.array([-1 if not row[-1] else (0 if row.all() else int(np.flatnonzero(~row)[-1]) + 1)
                        for row in optimal])
    return final, first, learned


@pytest.mark.parametrize("learner,start,ties,options", [
    ("q_learning", None, "first", {}),
    ("double_q_learning", None, "random", {}),
    ("dyna_q", "uniform_unclean", "random", {}),
    ("q_lambda", None, "first", {"alpha": 0.5, "gamma": 0.5}),
])
def test_learning_times_equal_a_replay_of_every_iteration(learner, start, ties, options):
    final, first, learned = replayed_learning_times(learner, "r4", 250, ties=ties, runs=6, seed=4, start=start,
                                                    **options)
    np.testing.assert_array_equal(final.first_learned_at, first)
    np.testing.assert_array_equal(final.learned_at, learned)
    assert final.first_learned_at.dtype == np.int64 and final.learned_at.shape == (6,)
    assert (first > 0).any(), "no run learned: the comparison would only see -1"
    assert (learned[learned >= 0] >= first[learned >= 0]).all()


def test_a_budget_too_short_censors_every_run():
    # The paper's shortest plan from its start is 9 steps: no greedy policy can be right after 3 updates.
    result = train("q_learning", "r1", runs=20, iterations=3, seed=1)
    assert (result.learned_at == -1).all() and (result.first_learned_at == -1).all()


def test_a_run_that_stays_learned_keeps_its_time_in_a_shorter_budget():
    kwargs = dict(runs=200, seed=2, alpha=0.5, epsilon=0.2)
    long, short = train("q_learning", "r1", iterations=1500, **kwargs), train("q_learning", "r1", iterations=900, **kwargs)
    kept = (long.learned_at >= 0) & (long.learned_at <= 900)
    assert kept.sum() > 20
    np.testing.assert_array_equal(short.learned_at[kept], long.learned_at[kept])
    seen = (long.first_learned_at >= 0) & (long.first_learned_at <= 900)
    np.testing.assert_array_equal(short.first_learned_at[seen], long.first_learned_at[seen])
    assert (long.learned_at == -1).any() or (long.learned_at > long.first_learned_at).any()


@pytest.mark.parametrize("ties", ["first", "random"])
def test_learning_times_do_not_depend_on_batching_or_engine(ties):
    kwargs = dict(iterations=500, seed=6, ties=ties)
    whole = train("sarsa", "r3", runs=300, **kwargs)
    tail = train("sarsa", "r3", runs=40, first_run=260, **kwargs)
    for name in LEARNED:
        np.testing.assert_array_equal(getattr(whole, name)[260:], getattr(tail, name))
    plain = oracle_train("sarsa", "r3", runs=4, first_run=260, **kwargs)
    for name in (*LEARNED, "actions", "q"):
        np.testing.assert_array_equal(getattr(tail, name)[:4], getattr(plain, name))


def test_random_ties_change_the_greedy_choice_only():
    kwargs = dict(runs=30, iterations=400, seed=3)
    first, random = train("q_learning", "r4", **kwargs), train("q_learning", "r4", ties="random", **kwargs)
    assert train("q_learning", "r4", ties="first", **kwargs).config["ties"] == "first"
    np.testing.assert_array_equal(train("q_learning", "r4", **kwargs).actions, first.actions)
    assert not np.array_equal(first.actions, random.actions)
    # With Q = 0 every action ties: the first greedy step is MOVE under "first", any action under "random".
    greedy = train("q_learning", "r4", runs=400, iterations=1, epsilon=0.0, ties="random", seed=1)
    assert set(np.unique(greedy.actions[:, 0])) == set(range(4))
    # Softmax has no greedy choice to break: the tie rule changes nothing.
    soft = dict(kwargs, exploration="softmax")
    np.testing.assert_array_equal(train("q_learning", "r4", ties="random", **soft).actions,
                                  train("q_learning", "r4", **soft).actions)


def test_unknown_tie_rule_is_refused():
    with pytest.raises(ValueError, match="unknown ties 'last'; allowed: first, random"):
        train(runs=1, iterations=1, ties="last")


def test_the_tie_rule_is_a_learner_option_too():
    kwargs = dict(runs=20, iterations=300, seed=8)
    by_argument = train("sarsa", "r4", ties="random", **kwargs)
    by_option = train("sarsa", "r4", learner_options={"ties": "random"}, **kwargs)
    for name in ("actions", "q", *LEARNED):
        np.testing.assert_array_equal(getattr(by_argument, name), getattr(by_option, name))
    assert by_option.config["learner_settings"]["ties"] == "random"
    assert "ties" not in train("sarsa", "r4", **kwargs).config["learner_settings"]
    with pytest.raises(ValueError, match="disagree"):
        train("sarsa", "r4", ties="first", learner_options={"ties": "random"}, **kwargs)


@pytest.mark.parametrize("learner", ["expected_sarsa", "double_q_learning", "q_lambda", "dyna_q",
                                     "affordance_q_learning", "learned_affordance_q_learning",
                                     "interactive_q_learning"])
def test_random_ties_compiled_equals_plain_loop(learner):
    kwargs = dict(runs=3, iterations=300, seed=9, ties="random", task=TaskModel(start="uniform_unclean"))
    compiled, plain = train(learner, "r4", **kwargs), oracle_train(learner, "r4", **kwargs)
    for name in ("rewards", "outcomes", "states", "actions", "episode_end", "q", *LEARNED):
        np.testing.assert_array_equal(getattr(compiled, name), getattr(plain, name), err_msg=name)
