"""``python -m benchmarks.tune``: ``tableclean-bench tune`` (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("tune", "python -m benchmarks.tune"))
