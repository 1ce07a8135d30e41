"""The paper's published numbers, as data: Tables 3 and 4, quoted verbatim.

Source: "Accelerated Task Learning Using Q-learning with Reduced State Space and Reward with
Bootstrapping Effect", Section 3 (Results), Tables 3 and 4.  Where the paper's text disagrees with
its tables (r3 "2360 iterations", Affordance RL "around 55 episodes") the tables are quoted.
"""

from __future__ import annotations

import pandas as pd

#: How outputs cite the paper (config.json's ``paper`` field).
PAPER_REFERENCE = (
    "Accelerated Task Learning Using Q-learning with Reduced State Space and Reward with "
    "Bootstrapping Effect, Sec. 3, Tables 3-4, Figures 3-7"
)

#: The learner whose rows the paper's Table 3 describes (alpha = gamma = 0.3).
PAPER_LEARNER = "q_learning"

#: ``source`` of a quoted row in Table 4.
SOURCE_QUOTED = "quoted from the paper"

#: The paper's Table 3 (Q-learning, alpha = gamma = 0.3): iterations and episodes to average-reward
#: convergence and to maximum success, with the success rate each row reached (Sec. 3.1 text and
#: Table 4), as a fraction in [0, 1] so it compares with ``success_plateau``.
PAPER_TABLE3 = pd.DataFrame(
    {
        "reward": ["r1", "r2", "r3", "r4"],
        "paper_reward_convergence_iterations": [680, 290, 2350, 190],
        "paper_reward_convergence_episodes": [31, 21, 70, 15],
        "paper_max_success_iterations": [630, 240, 2350, 140],
        "paper_max_success_episodes": [25, 14, 70, 10],
        "paper_success_rate": [0.8394, 0.8473, 0.8108, 0.8477],
    }
)

#: Columns of the paper's Table 4 as quoted here: episodes to average-reward convergence,
#: maximum success rate in percent, episodes to maximum success ("-" in the paper is NaN).
PAPER_TABLE4_COLUMNS = (
    "methodology",
    "average_reward_convergence_episodes",
    "max_success_rate_percent",
    "max_success_episodes",
)

_NA = float("nan")

#: The paper's Table 4, verbatim, with ``source`` = `SOURCE_QUOTED` on every row.
PAPER_TABLE4 = pd.DataFrame(
    [
        ("Classic RL [8]", 1000, 35.0, 1000),
        ("Classic RL [7]", _NA, 4.0, 1000),
        ("Affordance RL [8]", 48, 99.9, _NA),
        ("Interactive RL (L=0.5) [8]", 40, _NA, _NA),
        ("This work with reward r1", 31, 83.94, 25),
        ("This work with reward r2", 21, 84.73, 14),
        ("This work with reward r3", 70, 81.08, 70),
        ("This work with reward r4", 15, 84.77, 10),
    ],
    columns=list(PAPER_TABLE4_COLUMNS),
).assign(source=SOURCE_QUOTED)
