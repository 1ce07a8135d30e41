"""``python -m benchmarks.robot_table``: ``tableclean-bench robots`` (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("robots", "python -m benchmarks.robot_table"))
