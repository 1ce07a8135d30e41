"""``python -m benchmarks.window_invariance``: entry point of :mod:`tableclean_suite.bench.window_invariance`."""

import sys

from tableclean_suite.bench.window_invariance import main

if __name__ == "__main__":
    sys.exit(main())
