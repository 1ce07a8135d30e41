"""``python -m benchmarks.policy_analysis``: ``tableclean-bench policy-analysis`` (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("policy-analysis", "python -m benchmarks.policy_analysis"))
