"""``python -m benchmarks.collect_demos``: entry point of :mod:`tableclean_suite.bench.collect_demos` (kept for the checkout)."""

import sys

from tableclean_suite.bench.collect_demos import main

if __name__ == "__main__":
    sys.exit(main())
