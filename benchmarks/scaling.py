"""``python -m benchmarks.scaling``: ``tableclean-bench scaling``."""

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    raise SystemExit(run_alias("scaling", "python -m benchmarks.scaling"))
