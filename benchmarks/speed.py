"""``python -m benchmarks.speed``: ``tableclean-bench speed``."""

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    raise SystemExit(run_alias("speed", "python -m benchmarks.speed"))
