"""``python -m benchmarks.object_table``: ``tableclean-bench objects``."""

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    raise SystemExit(run_alias("objects", "python -m benchmarks.object_table"))
