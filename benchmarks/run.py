"""``python -m benchmarks.run``: entry point of :mod:`tableclean_suite.bench.run` (kept for the checkout)."""

import sys

from tableclean_suite.bench.run import main

if __name__ == "__main__":
    sys.exit(main())
