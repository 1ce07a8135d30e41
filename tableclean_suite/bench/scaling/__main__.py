"""``python -m tableclean_suite.bench.scaling``: ``tableclean-bench scaling``."""

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    raise SystemExit(run_alias("scaling", "python -m tableclean_suite.bench.scaling"))
