"""``python -m benchmarks.object_table``: ``tableclean-bench objects`` (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("objects", "python -m benchmarks.object_table"))
