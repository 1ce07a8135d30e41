"""``python -m benchmarks.fidelity``: ``tableclean-bench fidelity``."""

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    raise SystemExit(run_alias("fidelity", "python -m benchmarks.fidelity"))
