"""What the learners actually learned: measured plateaus against exact values, greedy success.

    tableclean-bench policy-analysis [--runs 1000] [--iterations 4000] [--long-iterations 20000] [--seed 0]

For every learner x reward pattern x start mode: the measured success plateau, the exact epsilon-greedy
success of the learned greedy policies (what the plateau should equal once they are stable) and their
success at epsilon = 0; and Q-learning with r3 at ``--long-iterations`` (r3's looping persists).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from tableclean_suite.bench import cli
from tableclean_suite.bench.tables import PRINT_WIDTH
from tableclean_suite import analysis, metrics
from tableclean_suite.learners import train
from tableclean_suite.task import StartMode, TaskModel

PROG = "tableclean-bench policy-analysis"
LEARNERS = ("q_learning", "sarsa")
REWARDS = ("r1", "r2", "r3", "r4")


def analyse(learner: str, reward: str, model: TaskModel, runs: int, iterations: int, seed: int, epsilon: float,
            max_itr: int) -> dict:
    """One row: measured plateau, exact epsilon-greedy and greedy success (%) of the learned policies."""
    result = train(learner, reward, runs=runs, iterations=iterations, seed=seed, task=model, epsilon=epsilon,
                   max_itr=max_itr)
    policies = analysis.greedy_policy(result.q)

    def exact(explore):
        return 100 * float(np.mean(analysis.exact_success_probability(policies, explore, max_itr, model=model)))

    return {"learner": learner, "reward": reward, "start": model.start.value, "iterations": iterations,
            "success_plateau_%": 100 * metrics.summarize(result).success_plateau,
            "exact_epsilon_greedy_%": exact(epsilon), "greedy_success_%": exact(0.0)}


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line."""
    parser = cli.command_parser(prog, __doc__.split("\n\n")[0])
    cli.add_runs_argument(parser, 1000, "runs per row")
    cli.add_iterations_argument(parser, 4000, "training iterations")
    parser.add_argument("--long-iterations", type=cli.positive_int, default=20000,
                        help="iterations of the long r3 row (default 20000)")
    cli.add_seed_argument(parser, "the training runs")
    return parser


def main(argv=None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    _, args = cli.parse_command(build_parser, argv, prog or PROG)
    import pandas as pd

    epsilon, max_itr = 0.1, 500
    rows = [analyse(learner, reward, TaskModel(start=start.value), args.runs, args.iterations, args.seed, epsilon,
                    max_itr) for start in StartMode for learner in LEARNERS for reward in REWARDS]
    rows.append(analyse("q_learning", "r3", TaskModel(), args.runs, args.long_iterations, args.seed, epsilon, max_itr))
    print(pd.DataFrame(rows).to_string(index=False, float_format="{:.2f}".format, line_width=PRINT_WIDTH))
    return 0


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("policy-analysis", "python -m tableclean_suite.bench.policy_analysis"))
