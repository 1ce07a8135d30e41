"""``python -m benchmarks.speed``: ``tableclean-bench speed`` (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("speed", "python -m benchmarks.speed"))
