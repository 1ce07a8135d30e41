"""``python -m benchmarks.policy_analysis``: entry point of :mod:`tableclean_suite.bench.policy_analysis` (kept for the checkout)."""

import sys

from tableclean_suite.bench.policy_analysis import main

if __name__ == "__main__":
    sys.exit(main())
