"""``tableclean-bench scaling``: does the reduced state space explain Q-learning's speed?

    python -m benchmarks.scaling                           # the default study (see docs/scaling.md)
    python -m benchmarks.scaling --segments 2,3 --objects 1 --fixed-plan-objects 1,3 --runs 20 --out /tmp/s

Trains every learner (``--learners``, default ``q_learning,sarsa``) x reward pattern (``--rewards``,
default r1-r4 and ``r4_cycle``, r4 with the looping rule for any N) x discount (``--gammas``,
default 0.3 and 0.9) on two families of task specs, and reports per cell the iterations to a
*fixed* yardstick with 95 % bootstrap intervals, whether the cell was censored, the success
curve's window mean against the optimal policy's exact success, and the share of runs that never
reached the terminal state.

The families (:mod:`.family`)
    *Product*: every (N, M) of ``--segments`` x ``--objects`` (default 2-5 x 1-3: 12 specs, 20 to
    31 320 reachable states); the plan grows with the states (8 to 31 steps).  *Fixed plan*: 3
    segments, segments 1-2 unclean, object 1 on segment 1 and objects 2..M parked on the clean
    segment 3 (``--fixed-plan-objects``, default 1-5): the optimal plan stays 8 steps while the
    states reachable from the start grow from 40 to 5 410.

The window
    ``base_window * (L / L0) ** window_exponent`` iterations (default 12 000 x (L / 8)^3) with
    episodes truncated after ``500 * L / L0`` (L: the optimal plan length from the spec's start).
    The window no longer decides what counts as reached: the yardstick is fixed per spec.

The yardstick (:mod:`.statistics`)
    Iterations until the mean success curve (read in blocks: 2 % of the window late, finer early)
    reaches, and stays at or above until the window's end, 90 % of the optimal policy's exact
    epsilon-greedy success on that spec; censored when its last block is below.  Growth exponents
    are fitted per gamma and reward pattern by censored maximum likelihood, each point weighted by
    its own interval, with profile-likelihood intervals.

Writes under ``--out`` (default ``results/scaling``), each atomically: ``scaling.csv`` (one row per
spec x gamma x learner x reward, ``_low``/``_high`` interval columns), ``scaling_specs.csv``,
``scaling.png`` (per gamma: yardstick iterations against states reachable from the start, reached
and censored cells apart; window mean over the optimum) and ``config.json`` (last).

Modules
    :mod:`.family` (specs, exact quantities, windows), :mod:`.study` (training in run chunks and
    reduction to rows), :mod:`.statistics` (yardstick, bootstrap, censored fit, reward order),
    :mod:`.report` (tables, CSV, figure, ``config.json``), :mod:`.pipeline` (the study from parsed
    arguments), :mod:`.command` (the command line); ``python -m tableclean_suite.bench.scaling`` runs it.
"""

from tableclean_suite.bench.scaling.command import EXIT_USAGE, PROG, main
from tableclean_suite.bench.scaling.family import (DEFAULT_OBJECT_COUNTS, DEFAULT_SEGMENTS,
                                                   family_spec, largest_default_spec)

__all__ = ["DEFAULT_OBJECT_COUNTS", "DEFAULT_SEGMENTS", "EXIT_USAGE", "PROG", "family_spec",
           "largest_default_spec", "main"]
