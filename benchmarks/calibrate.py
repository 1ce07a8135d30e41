"""``python -m benchmarks.calibrate``: ``tableclean-bench calibrate`` (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("calibrate", "python -m benchmarks.calibrate"))
