"""``python -m benchmarks.render_scene``: ``tableclean-bench render``."""

from tableclean_suite.bench.commands import run_alias

if __name__ == "__main__":
    raise SystemExit(run_alias("render", "python -m benchmarks.render_scene"))
