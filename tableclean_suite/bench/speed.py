"""Speed of the batched learners against a plain per-step Python loop, as ratios.

    python -m benchmarks.speed [--runs 1000] [--iterations 3000] [--baseline-runs 20] [--skip-default-run]

Both sides run in this process on the same task.  Two baselines:
- ``plain loop``: a lean hand-written Python loop of Algorithm 1 over precomputed
  transition lists with ``random.random()`` (the fastest plain Python we could write),
- ``reference engine``: ``train(engine="reference")``, the library's own per-step loop
  (which also serves the physics backend and draws the same random numbers).
The compiled learners are timed after a warm-up call (numba compilation excluded).
It also times the whole default ``python -m benchmarks.run --fresh`` (all cells trained,
bootstraps, tables, CSVs, figures drawn: no result cache) in this process after a warm-up run:
CPU seconds and wall seconds; the per-update rate on the scaling study's largest spec against
the paper's (:mod:`.spec_speed`); and the cold start, measured in one go
(:func:`.spec_speed.time_cold_starts`): the README's command in three fresh processes sharing a
numba cache that starts empty — the first process (empty numba and result caches), a second
one on the same output directory (warm caches: the README's second run, goal <= 3 s) and a
second one on a new output directory (result caches off, numba's cache only).
"""

from __future__ import annotations

import argparse
import random
import sys
import time

from tableclean_suite.bench.cli import positive_int
from tableclean_suite.learners import train
from tableclean_suite.rewards import get_reward_pattern
from tableclean_suite.task import Outcome, TaskModel

LEARNERS = ("q_learning", "sarsa")


def plain_loop(learner: str, runs: int, iterations: int, alpha=0.3, gamma=0.3, epsilon=0.1, max_itr=500, seed=0):
    """Algorithm 1 as a straightforward Python loop (r2 rewards, no looping penalty). Returns updates done."""
    rng = random.Random(seed)
    model = TaskModel()
    n_actions = model.n_actions
    next_state, outcome = (a.tolist() for a in model.transition_arrays())
    values = get_reward_pattern("r2").outcome_values().tolist()
    start = model.start_state.index
    terminal_outcome = int(Outcome.TERMINAL)
    sarsa = learner == "sarsa"

    def choose(row):
        if rng.random() < epsilon:
            return rng.randrange(n_actions)
        return row.index(max(row))

    for _ in range(runs):
        q = [[0.0] * n_actions for _ in range(len(next_state))]
        state, length, action = start, 0, None
        for _ in range(iterations):
            if action is None:
                action = choose(q[state])
            nxt, out = next_state[state][action], outcome[state][action]
            reward = values[out]
            length += 1
            terminal = out == terminal_outcome
            next_action = None if terminal else choose(q[nxt])
            if terminal:
                target = reward
            elif sarsa:
                target = reward + gamma * q[nxt][next_action]
            else:
                target = reward + gamma * max(q[nxt])
            q[state][action] += alpha * (target - q[state][action])
            if terminal or length >= max_itr:
                state, length, action = start, 0, None
            else:
                state, action = nxt, (next_action if sarsa else None)
    return runs * iterations


def _rate(function) -> float:
    start = time.perf_counter()
    updates = function()
    return updates / (time.perf_counter() - start)


def measure(runs: int, iterations: int, baseline_runs: int) -> list[dict]:
    """Updates per second of each learner and of both baselines, and the ratios."""
    rows = []
    for learner in LEARNERS:
        train(learner, "r2", runs=2, iterations=10)  # warm-up: compile
        compiled = _rate(lambda: train(learner, "r2", runs=runs, iterations=iterations) and runs * iterations)
        plain = _rate(lambda: plain_loop(learner, baseline_runs, iterations))
        reference = _rate(
            lambda: train(learner, "r2", runs=baseline_runs, iterations=iterations, engine="reference")
            and baseline_runs * iterations
        )
        rows.append(
            {
                "learner": learner,
                "compiled_updates_per_s": compiled,
                "plain_loop_updates_per_s": plain,
                "reference_updates_per_s": reference,
                "ratio_vs_plain_loop": compiled / plain,
                "ratio_vs_reference": compiled / reference,
            }
        )
    return rows


def time_default_run() -> dict:
    """CPU and wall seconds of the default ``benchmarks.run``, after a warm-up run in this process."""
    import contextlib
    import io
    import tempfile

    from tableclean_suite.bench import run

    with tempfile.TemporaryDirectory() as out:
        argv = ["--out", out, "--fresh", "--no-progress"]
        with contextlib.redirect_stdout(io.StringIO()):
            run.main(argv)  # warm-up: numba compilation, matplotlib font cache
            cpu, wall = time.process_time(), time.perf_counter()
            run.main(argv)
            return {"cpu_s": time.process_time() - cpu, "wall_s": time.perf_counter() - wall}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.speed", description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=positive_int, default=1000, help="runs for the compiled learners (default 1000)")
    parser.add_argument("--iterations", type=positive_int, default=3000, help="iterations per run (default 3000)")
    parser.add_argument("--baseline-runs", type=positive_int, default=20, help="runs for the plain baselines (default 20)")
    parser.add_argument("--skip-default-run", action="store_true", help="do not time the default benchmarks.run")
    parser.add_argument("--skip-specs", action="store_true",
                        help="do not time the largest scaling spec against the paper's, nor the cold start")
    args = parser.parse_args(argv)
    import pandas as pd

    table = pd.DataFrame(measure(args.runs, args.iterations, args.baseline_runs))
    with pd.option_context("display.float_format", "{:,.1f}".format, "display.width", 160):
        print(table.to_string(index=False))
    print(f"\ngoal: >= 100x the plain loop; measured {table['ratio_vs_plain_loop'].min():.0f}x (worst learner)")
    if not args.skip_default_run:
        timing = time_default_run()
        print(
            f"default `python -m benchmarks.run --fresh` after warm-up: {timing['cpu_s']:.2f} s CPU, "
            f"{timing['wall_s']:.2f} s wall (goal <= 5 s)"
        )
    if not args.skip_specs:
        from tableclean_suite.bench import spec_speed
        from tableclean_suite.task import get_task_spec

        paper, largest = spec_speed.measure_rates([get_task_spec("paper"), spec_speed.largest_study_spec()],
                                                  spec_speed.DEFAULT_RUNS, spec_speed.DEFAULT_ITERATIONS,
                                                  spec_speed.DEFAULT_REPEATS)
        print()
        print("\n".join(spec_speed.summary_lines(paper, largest, spec_speed.time_cold_starts())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
