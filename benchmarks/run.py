"""``python -m benchmarks.run``: ``tableclean-bench run`` (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("run", "python -m benchmarks.run"))
