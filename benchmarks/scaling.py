"""``python -m benchmarks.scaling``: entry point of :mod:`tableclean_suite.bench.scaling` (kept for the checkout)."""

import sys

from tableclean_suite.bench.scaling import main

if __name__ == "__main__":
    sys.exit(main())
