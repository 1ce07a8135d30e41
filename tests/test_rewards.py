"""Reward patterns: Table 2 values for every outcome, the looping penalty, the registry."""

import numpy as np
import pytest

from tableclean_suite.rewards import RewardPattern, get_reward_pattern, register_reward_pattern, reward_pattern_names
from tableclean_suite.task import Outcome
from learner_oracle import oracle_train

R, INEFF, REL, IRR, IMP, TERM = (
    Outcome.ROUTINE, Outcome.INEFFECTIVE, Outcome.RELEVANT_CLEAN, Outcome.IRRELEVANT_CLEAN, Outcome.IMPROPER,
    Outcome.TERMINAL,
)

# Table 2 of the paper, hand-copied: terminal, relevant, irrelevant, pick/place/move, improper
TABLE2 = {
    "r1": (1, -0.01, -0.01, -0.01, -1),
    "r2": (1, 1, -0.01, -0.01, -1),
    "r3": (1, 1, -0.01, 0.01, -1),
    "r4": (1, 1, -0.01, 0.01, -1),
}


@pytest.mark.parametrize("name", sorted(TABLE2))
def test_table2_values_for_every_outcome(name):
    terminal, relevant, irrelevant, routine, improper = TABLE2[name]
    pattern = get_reward_pattern(name)
    # a non-looping transition: 0 -> 1 with previous state 5
    assert pattern.reward(TERM, 0, 1, 5) == terminal
    assert pattern.reward(REL, 0, 1, 5) == relevant
    assert pattern.reward(IRR, 0, 0, 5) == irrelevant
    assert pattern.reward(R, 0, 1, 5) == routine
    assert pattern.reward(IMP, 0, 0, 5) == improper
    assert pattern.reward(INEFF, 0, 0, 5) == irrelevant  # ineffective counts as irrelevant cleaning (r4: also a loop)


def test_looping_penalty_only_in_r4():
    # move 0 -> 1 back to the state before the previous step (s_{t+1} = s_{t-1})
    assert get_reward_pattern("r3").reward(R, 1, 0, 0) == 0.01
    assert get_reward_pattern("r4").reward(R, 1, 0, 0) == -0.01
    assert get_reward_pattern("r4").reward(R, 1, 2, 0) == 0.01  # progress, no loop
    assert get_reward_pattern("r4").reward(R, 1, 2, -1) == 0.01  # first step of an episode
    assert get_reward_pattern("r4").reward(INEFF, 3, 3, 1) == -0.01  # staying put
    assert get_reward_pattern("r4").reward(IMP, 3, 3, 3) == -1  # improper is not a routine action


def test_looping_add_mode_and_terminal_add_mode():
    looping = RewardPattern("r4_add", 1, 1, -0.01, 0.01, -1, looping_penalty=-0.01, looping_mode="add")
    assert looping.reward(R, 1, 0, 0) == pytest.approx(0.0)
    bonus = RewardPattern("r2_bonus", 1, 1, -0.01, -0.01, -1, terminal_mode="add")
    assert bonus.reward(TERM, 0, 1) == 2.0


def test_outcome_values_array():
    assert get_reward_pattern("r2").outcome_values().tolist() == [-0.01, -0.01, 1.0, -0.01, -1.0, 1.0]


def test_user_pattern_registration_and_errors():
    mine = RewardPattern("test_sparse", 10, 0, 0, 0, -5)
    register_reward_pattern(mine)
    assert get_reward_pattern("test_sparse") is mine and "test_sparse" in reward_pattern_names()
    with pytest.raises(ValueError, match="already registered"):
        register_reward_pattern(mine)
    with pytest.raises(ValueError, match="unknown reward pattern 'r9'; allowed: r1, r2, r3, r4"):
        get_reward_pattern("r9")


@pytest.mark.parametrize(
    "kwargs,message",
    [
        ({"name": "R 5"}, "lower_snake"),
        ({"terminal": float("nan")}, "terminal must be finite"),
        ({"routine": "high"}, "routine must be a number"),
        ({"looping_mode": "sometimes"}, "unknown looping_mode 'sometimes'; allowed: replace, add"),
    ],
)
def test_invalid_patterns_are_rejected(kwargs, message):
    fields = dict(name="bad", terminal=1, relevant_clean=1, irrelevant_clean=0, routine=0, improper=-1)
    fields.update(kwargs)
    with pytest.raises(ValueError, match=message):
        RewardPattern(**fields)


def test_looping_memory_catches_a_ring_the_paper_rule_misses():
    from tableclean_suite.rewards import (EPISODE_LOOPING_MEMORY, PAPER_LOOPING_MEMORY, R4_CYCLE, SMALL_INCENTIVE,
                                          SMALL_PENALTY)

    r4, routine = get_reward_pattern("r4"), int(Outcome.ROUTINE)
    assert r4.looping_memory == PAPER_LOOPING_MEMORY and R4_CYCLE.looping_memory == EPISODE_LOOPING_MEMORY
    ring = [10, 11, 12]  # three MOVEs round three arm positions: 10 -> 11 -> 12 -> 10
    assert r4.reward(routine, 12, 10, previous_state=11) == SMALL_INCENTIVE  # s_{t+1} = s_{t-2}: not seen
    assert R4_CYCLE.reward(routine, 12, 10, 11, history=ring) == SMALL_PENALTY
    assert R4_CYCLE.reward(routine, 12, 13, 11, history=ring) == SMALL_INCENTIVE  # a new state: no loop
    assert R4_CYCLE.reward(int(Outcome.RELEVANT_CLEAN), 12, 10, 11, history=ring) == r4.relevant_clean
    three = RewardPattern("ring3", 1, 1, -0.01, 0.01, -1, looping_penalty=-0.5, looping_memory=3)
    assert three.reward(routine, 12, 10, 11, history=ring) == -0.5  # s_{t-2} is within 3 states
    assert three.reward(routine, 12, 10, 11, history=[10, 9, 11, 12]) == 0.01  # 4 states back: outside
    assert (r4.as_row()["looping_rule"], R4_CYCLE.as_row()["looping_rule"], three.as_row()["looping_rule"]) == (
        "s_t, s_t-1", "the episode", "last 3 states")
    assert get_reward_pattern("r3").as_row()["looping_rule"] is None
    with pytest.raises(ValueError, match="pass history="):
        R4_CYCLE.reward(routine, 12, 10, 11)
    with pytest.raises(ValueError, match="looping_memory must be an integer >= 2"):
        RewardPattern("bad_memory", 1, 1, -0.01, 0.01, -1, looping_penalty=-0.01, looping_memory=1)


@pytest.mark.parametrize("learner", ["q_learning", "sarsa"])
@pytest.mark.parametrize("memory", [0, 3])
def test_compiled_equals_plain_loop_with_a_longer_looping_memory(learner, memory):
    """The compiled kernel's looping memory and the reference loop's history give the same runs
    (three segments, so MOVE goes round a ring the paper's rule does not see)."""
    from tableclean_suite.learners import train
    from tableclean_suite.task import TaskModel, TaskSpec

    pattern = RewardPattern(f"ring_memory_{memory}", 1, 1, -0.01, 0.01, -1, looping_penalty=-0.01,
                            looping_memory=memory)
    model = TaskModel(spec=TaskSpec("ring_three", segments=3, objects=1))
    kwargs = dict(runs=3, iterations=600, seed=5, task=model)
    fast = train(learner, pattern, **kwargs)
    plain = oracle_train(learner, pattern, **kwargs)
    for name in ("rewards", "outcomes", "states", "actions", "episode_end", "q"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(plain, name), err_msg=name)
    paper_rule = train(learner, RewardPattern("ring_paper", 1, 1, -0.01, 0.01, -1, looping_penalty=-0.01), **kwargs)
    assert (fast.rewards == -0.01).sum() > (paper_rule.rewards == -0.01).sum()  # it penalises more loops


def test_the_paper_rule_is_memory_two_with_or_without_a_history():
    """r4 with (previous_state, state) and r4 with the episode's history give the same reward: one rule."""
    r4 = get_reward_pattern("r4")
    rng = np.random.default_rng(0)
    for _ in range(500):
        history = [int(s) for s in rng.integers(0, 6, size=rng.integers(1, 5))]
        previous = history[-2] if len(history) > 1 else -1
        outcome, next_state = int(rng.choice([R, INEFF, REL, IMP])), int(rng.integers(0, 6))
        by_states = r4.reward(outcome, history[-1], next_state, previous)
        assert by_states == r4.reward(outcome, history[-1], next_state, previous, history=history)
        looping = outcome in (R, INEFF) and next_state in (history[-1], previous)
        assert by_states == (r4.looping_penalty if looping else r4.outcome_values()[outcome])
