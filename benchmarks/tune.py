"""``python -m benchmarks.tune``: entry point of :mod:`tableclean_suite.bench.tune` (kept for the checkout)."""

import sys

from tableclean_suite.bench.tune import main

if __name__ == "__main__":
    sys.exit(main())
