"""``python -m benchmarks.interventions``: ``tableclean-bench interventions`` (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("interventions", "python -m benchmarks.interventions"))
