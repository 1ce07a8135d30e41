"""``python -m benchmarks.tune``: ``tableclean-bench tune``."""

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    raise SystemExit(run_alias("tune", "python -m benchmarks.tune"))
