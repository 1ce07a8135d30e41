"""``python -m benchmarks.learner_speed``: ``tableclean-bench speed --sections learners``,
with the old command's flags (kept for the checkout)."""

import sys

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    sys.exit(run_alias("speed", "python -m benchmarks.learner_speed", alias="learner_speed"))
