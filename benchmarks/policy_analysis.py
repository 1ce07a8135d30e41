"""``python -m benchmarks.policy_analysis``: ``tableclean-bench policy-analysis``."""

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    raise SystemExit(run_alias("policy-analysis", "python -m benchmarks.policy_analysis"))
