"""``python -m benchmarks.run``: ``tableclean-bench run``."""

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    raise SystemExit(run_alias("run", "python -m benchmarks.run"))
