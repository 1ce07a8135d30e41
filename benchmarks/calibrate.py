"""``python -m benchmarks.calibrate``: ``tableclean-bench calibrate``."""

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    raise SystemExit(run_alias("calibrate", "python -m benchmarks.calibrate"))
