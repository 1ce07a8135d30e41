"""``python -m benchmarks.window_invariance``: ``tableclean-bench window-invariance`` (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("window-invariance", "python -m benchmarks.window_invariance"))
