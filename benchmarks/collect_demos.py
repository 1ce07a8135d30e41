"""``python -m benchmarks.collect_demos``: ``tableclean-bench demos`` (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("demos", "python -m benchmarks.collect_demos"))
