"""Speed of every registered learner (and exploration) next to Q-learning, on the paper spec.

The ``learners`` section of ``tableclean-bench speed`` (:mod:`.speed`; ``python -m benchmarks.learner_speed``
is its alias):

All learners train the same runs x iterations of the ``paper`` spec in this process, after a
warm-up call each (numba compilation excluded); each time is the best of ``--repeat`` wall-clock
measurements of ``train()`` (the compiled loop over all cores, records included).  A *real*
update is one environment step and its TD update; Dyna-Q's *planning* updates (``planning_steps``
per real step) are counted separately.  ``time per real update vs Q-learning`` is the learner's
seconds per real step divided by Q-learning's (the issue's goal: <= 3 for all but Dyna-Q).
A second table times Q-learning under every registered exploration.
"""

from __future__ import annotations

import time

from tableclean_suite.learners import exploration_names, get_learner, learner_names, train

BASELINE = "q_learning"
#: The issue's bound on seconds per real update relative to Q-learning (Dyna-Q exempt).
SLOWDOWN_GOAL = 3.0
EXEMPT = ("dyna_q",)
TASK = "paper"
WARM_UP = dict(runs=2, iterations=10)
MILLION = 1e6


def time_training(learner: str, reward: str, runs: int, iterations: int, repeat: int, exploration: str | None = None):
    """Best wall-clock seconds of ``repeat`` ``train()`` calls (after one warm-up call)."""
    train(learner, reward, task=TASK, exploration=exploration, **WARM_UP)
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        train(learner, reward, runs=runs, iterations=iterations, task=TASK, exploration=exploration)
        best = min(best, time.perf_counter() - start)
    return best


def learner_rows(reward: str, runs: int, iterations: int, repeat: int) -> list[dict]:
    """One row per registered learner: real and planning updates per second, and the slowdown."""
    real = runs * iterations
    seconds = {name: time_training(name, reward, runs, iterations, repeat) for name in learner_names()}
    rows = []
    for name, elapsed in seconds.items():
        planning = real * get_learner(name).planning_steps
        rows.append({
            "learner": name,
            "seconds": elapsed,
            "real M updates/s": real / elapsed / MILLION,
            "planning M updates/s": planning / elapsed / MILLION,
            "time per real update vs Q-learning": elapsed / seconds[BASELINE],
            "time per update (real + planning) vs Q-learning": elapsed / (real + planning) * real / seconds[BASELINE],
        })
    return rows


def exploration_rows(reward: str, runs: int, iterations: int, repeat: int) -> list[dict]:
    """Q-learning under each registered exploration (default parameters): updates per second and slowdown."""
    real = runs * iterations
    seconds = {name: time_training(BASELINE, reward, runs, iterations, repeat, name) for name in exploration_names()}
    base = seconds[exploration_names()[0]]
    return [{"exploration": name, "seconds": elapsed, "M updates/s": real / elapsed / MILLION,
             "time per update vs epsilon_greedy": elapsed / base} for name, elapsed in seconds.items()]


def slowest(rows: list[dict]) -> tuple[str, float]:
    """``(learner, ratio)``: the learner slowest per real update relative to Q-learning (Dyna-Q exempt)."""
    checked = [row for row in rows if row["learner"] not in EXEMPT]
    worst = max(checked, key=lambda row: row["time per real update vs Q-learning"])
    return worst["learner"], worst["time per real update vs Q-learning"]
