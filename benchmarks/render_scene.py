"""``python -m benchmarks.render_scene``: ``tableclean-bench render`` (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("render", "python -m benchmarks.render_scene"))
