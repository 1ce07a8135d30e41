"""``python -m benchmarks.coverage``: ``tableclean-bench coverage``."""

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    raise SystemExit(run_alias("coverage", "python -m benchmarks.coverage"))
