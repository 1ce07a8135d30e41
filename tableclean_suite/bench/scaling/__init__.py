"""``tableclean-bench scaling``: does the reduced state space explain Q-learning's speed?

    python -m benchmarks.scaling                           # the default study (see docs/scaling.md)
    python -m benchmarks.scaling --segments 2,3 --objects 1 --fixed-plan-objects 1,3 --seeds 5 --runs 10 --out scaling-small

Trains every learner (``--learners``, default ``q_learning,sarsa``) x reward pattern (``--rewards``,
default r1-r4 and ``r4_cycle``, r4 with the looping rule for any N) x discount (``--gammas``,
default 0.3 and 0.9) on two families of task specs, each cell with ``--seeds`` seeds (default 5)
of ``--runs`` runs (default 20), and reports per cell the median per-run learning time with a 95 %
interval that includes the between-seed variance, the share of runs censored at the window, every
seed's own median, the success curve's window mean against the optimal policy's exact success
and the share of runs that never reached the terminal state.

The families (`family`)
    *Product*: every (N, M) of ``--segments`` x ``--objects`` (default 2-5 x 1-3: 12 specs, 20 to
    31 320 reachable states); the plan grows with the states (8 to 31 steps).  *Fixed plan*: 3
    segments, segments 1-2 unclean, object 1 on segment 1 and objects 2..M parked on the clean
    segment 3 (``--fixed-plan-objects``, default 1-5): the optimal plan stays 8 steps while the
    states reachable from the start grow from 40 to 5 410.

The window
    ``base_window * (L / L0) ** window_exponent`` iterations (default 12 000 x (L / 8)^3) with
    episodes truncated after ``500 * L / L0`` (L: the optimal plan length from the spec's start).

The response (`statistics`)
    Each run's learning time (``TrainingResult.learned_at``: the iteration from which its greedy
    policy follows a shortest plan from every start state through the window's end), censored at
    the window; the cell's Kaplan-Meier median over all its seeds' runs, its interval from
    resampling seeds and then runs within seeds.  Between consecutive sizes of a chain (N growing
    at fixed M in the product family, M growing in the fixed-plan family) the study reports local
    slopes d log(median) / d log(states) with intervals; a power law is fitted by censored maximum
    likelihood only where at most half the cells are censored.

Writes under ``--out`` (default ``results/scaling``), each atomically: ``scaling.csv`` (one row per
spec x gamma x learner x reward, ``_low``/``_high`` interval columns), ``scaling_specs.csv``,
``scaling_slopes.csv``, ``scaling.png`` (per gamma: median learning time against states reachable
from the start; the censored share) and ``config.json`` (last).

Modules
    `family` (specs, exact quantities, windows), `study` (training in run chunks and
    reduction to rows), `statistics` (learning time, seeds-then-runs bootstrap, local slopes, censored fit, reward order),
    `report` (tables, CSV, figure, ``config.json``), `pipeline` (the study from parsed
    arguments), `command` (the command line); ``python -m tableclean_suite.bench.scaling`` runs it.
"""

from tableclean_suite.bench.scaling.command import EXIT_USAGE, PROG, main
from tableclean_suite.bench.scaling.family import (DEFAULT_OBJECT_COUNTS, DEFAULT_SEGMENTS,
                                                   family_spec, largest_default_spec)

__all__ = ["DEFAULT_OBJECT_COUNTS", "DEFAULT_SEGMENTS", "EXIT_USAGE", "PROG", "family_spec",
           "largest_default_spec", "main"]
