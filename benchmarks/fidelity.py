"""``python -m benchmarks.fidelity``: ``tableclean-bench fidelity`` (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("fidelity", "python -m benchmarks.fidelity"))
