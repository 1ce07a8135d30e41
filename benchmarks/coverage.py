"""``python -m benchmarks.coverage``: ``tableclean-bench coverage`` (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("coverage", "python -m benchmarks.coverage"))
