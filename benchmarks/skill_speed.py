"""``python -m benchmarks.skill_speed``: entry point of :mod:`tableclean_suite.bench.skill_speed` (kept for the checkout)."""

import sys

from tableclean_suite.bench.skill_speed import main

if __name__ == "__main__":
    sys.exit(main())
