"""``python -m benchmarks.env_speed``: entry point of :mod:`tableclean_suite.bench.env_speed` (kept for the checkout)."""

from tableclean_suite.bench.env_speed import main

if __name__ == "__main__":
    main()
