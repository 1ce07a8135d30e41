"""``python -m benchmarks.env_speed``: ``tableclean-bench speed --sections environment``,
with the old command's flags (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("speed", "python -m benchmarks.env_speed", alias="env_speed"))
