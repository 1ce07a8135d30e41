"""``python -m benchmarks.window_invariance``: ``tableclean-bench window-invariance``."""

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    raise SystemExit(run_alias("window-invariance", "python -m benchmarks.window_invariance"))
