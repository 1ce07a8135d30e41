"""``tableclean-bench scaling``: does the reduced state space explain Q-learning's speed?

    python -m benchmarks.scaling                           # the default study (see docs/scaling.md)
    python -m benchmarks.scaling --segments 2,3 --objects 1 --fixed-plan-objects 1,3 --seeds 5 --runs 10 \\
        --out scaling-small

Trains learners x reward patterns x discounts on two families of task specs (`family`) and reports
each cell's median per-run learning time with its interval, local slopes and a censored power-law
fit (`statistics`; docs/scaling.md states the method).  Publishes ``scaling.csv``,
``scaling_specs.csv``, ``scaling_slopes.csv``, ``scaling.png`` and ``config.json`` under ``--out``.
"""

from tableclean_suite.bench.scaling.command import PROG, main

__all__ = ["PROG", "main"]
