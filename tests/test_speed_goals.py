"""The speed report says how far each time goal is from being met."""

import pytest

from tableclean_suite.bench import speed

pytestmark = pytest.mark.quick


def test_a_time_says_how_far_over_or_under_its_goal_it_is():
    assert speed.seconds_against_goal(5.32, 4.0) == "5.32 s (1.33x the 4 s goal, 1.32 s over)"
    assert speed.seconds_against_goal(3.0, 4.0) == "3.00 s (0.75x the 4 s goal, 1.00 s under)"
