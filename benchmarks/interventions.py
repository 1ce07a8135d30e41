"""``python -m benchmarks.interventions``: ``tableclean-bench interventions``."""

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    raise SystemExit(run_alias("interventions", "python -m benchmarks.interventions"))
