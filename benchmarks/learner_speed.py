"""``python -m benchmarks.learner_speed``: entry point of :mod:`tableclean_suite.bench.learner_speed` (kept for the checkout)."""

import sys

from tableclean_suite.bench.learner_speed import main

if __name__ == "__main__":
    sys.exit(main())
