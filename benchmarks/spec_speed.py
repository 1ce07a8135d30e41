"""``python -m benchmarks.spec_speed``: entry point of :mod:`tableclean_suite.bench.spec_speed` (kept for the checkout)."""

import sys

from tableclean_suite.bench.spec_speed import main

if __name__ == "__main__":
    sys.exit(main())
