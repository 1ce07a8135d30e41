"""``python -m benchmarks.rollout``: ``tableclean-bench rollout`` (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("rollout", "python -m benchmarks.rollout"))
