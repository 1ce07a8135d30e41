"""``python -m benchmarks.speed``: entry point of :mod:`tableclean_suite.bench.speed` (kept for the checkout)."""

import sys

from tableclean_suite.bench.speed import main

if __name__ == "__main__":
    sys.exit(main())
