"""``python -m benchmarks.rollout``: ``tableclean-bench rollout``."""

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    raise SystemExit(run_alias("rollout", "python -m benchmarks.rollout"))
