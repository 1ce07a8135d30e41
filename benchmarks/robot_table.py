"""``python -m benchmarks.robot_table``: ``tableclean-bench robots``."""

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    raise SystemExit(run_alias("robots", "python -m benchmarks.robot_table"))
