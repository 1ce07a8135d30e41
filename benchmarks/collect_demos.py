"""``python -m benchmarks.collect_demos``: ``tableclean-bench demos``."""

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    raise SystemExit(run_alias("demos", "python -m benchmarks.collect_demos"))
