"""``python -m benchmarks.scaling``: ``tableclean-bench scaling`` (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("scaling", "python -m benchmarks.scaling"))
