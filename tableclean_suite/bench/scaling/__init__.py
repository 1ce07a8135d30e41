"""``python -m benchmarks.scaling``: does the reduced state space explain Q-learning's speed?

    python -m benchmarks.scaling                           # the default study (~3 min wall on 2 shared cores)
    python -m benchmarks.scaling --segments 2,3 --objects 1,2 --runs 8 --base-window 400 --out /tmp/s

Trains every learner (``--learners``, default ``q_learning,sarsa``) x reward pattern
(``--rewards``, default ``r1..r4``) on a family of task specs that grows from the paper's
(2 segments, 1 object: 20 reachable states) to tens of thousands of reachable states, and
reports per spec the state codes, the reachable states (from every all-unclean layout, the
model's own count), the optimal plan length from the default start, the exact
epsilon-greedy success of an optimal policy, and per cell the iterations and episodes to
maximum success and the success plateau with 95 % bootstrap intervals.

The family
    Every ``(N, M)`` of ``--segments`` N (default 2,3,4,5) x ``--objects`` M (default 1,2,3):
    12 specs ``scale_n{N}_m{M}`` (the paper's for N = 2, M = 1), all M objects starting with
    the arm on segment 1 and every segment unclean.  The task grows along two axes: a segment
    doubles the clean/unclean layouts and adds an arm and an object position; an object
    multiplies the codes by N + 1 (on one of N segments or held) and lengthens the optimal plan
    (8, 12, 16 steps for M = 1, 2, 3 at N = 2; 17, 24, 31 at N = 5).  Reachable states run
    from 20 (N=2, M=1) to 31 320 (N=5, M=3; 34 560 codes).  Specs are trained, printed and written in order of reachable
    states (ties by N, then M), which interleaves the two axes (e.g. N=2, M=3 with 110 states
    sits between N=3, M=1 and N=4, M=1); "as the task grows" means down that order.

How the window was chosen
    The paper's spec trains ``--base-window`` iterations (default 12 000, 4x the paper's
    3000: with 6000, r1 and r4 were still rising at the end of several larger specs' windows)
    with the paper's ``max_itr`` 500.  A spec whose optimal plan from the default start has
    L steps (the paper's has L0 = 8) trains ``base_window * (L / L0) ** window_exponent``
    iterations (default exponent 3: N = 5, M = 3 with L = 31 gets ~698 000 iterations) and
    truncates episodes after ``500 * L / L0`` iterations (episodes of a longer task need
    proportionally more steps).  The window scales with the plan length,
    not the reachable states: a learner from a fixed start only has to learn the states near
    its plan, and a window linear in the states would spend the budget on the largest spec.
    The rule needs no change for M > 1: an object lengthens the plan, so it lengthens the
    window (the default family trains 2.29 million iterations per run over its 12 specs; at
    the time of writing every Q-learning cell reached its plateau, and the whole study took
    ~3 min wall on 2 cores shared with other work).
    Whether that was long enough is *measured*, not assumed: a cell counts as having reached
    its plateau only when the success curve is flat over the plateau window (the mean of its
    second half exceeds that of its first half by at most ``PLATEAU_RISE_TOLERANCE``) and
    the plateau is at least ``MIN_PLATEAU``; otherwise its iterations and episodes are NaN
    ("not reached") and the CSV says why.

Quantities (the definitions of :mod:`tableclean_suite.metrics`)
    Point estimates come from the full-resolution mean success curve over runs
    (``metrics.CurveSums`` fed chunk by chunk, then ``metrics.summarize``).  Intervals are a
    percentile bootstrap over run indices (``--resamples`` resamples of the runs with
    replacement; each resample recomputes the mean success curve, its plateau, the first
    iteration reaching ``threshold`` of that plateau and the mean episodes by then).  The
    plateau is resampled exactly (each run's full-resolution mean over the plateau window);
    the crossing uses each run's success and episode count sampled at ``LINEAR_GRID_POINTS``
    evenly and ``GEOMETRIC_GRID_POINTS`` geometrically spaced iterations, so an interval end
    is the grid point at or after the resample's crossing (``interval_resolution`` in the CSV:
    the grid spacing at the point estimate, under 1 % of it for windows up to 10**6).

Growth exponents
    Per reward pattern (for Q-learning), least squares of log(iterations to max success) on
    log(reachable states) over the specs where the plateau was reached; the 95 % interval is
    the slope +- t(0.975, n - 2) x its standard error.  "Maximum success" is 95 % of the
    cell's *own* plateau: a plateau far below the spec's optimal success (compare the
    ``success_plateau`` and ``optimal_success`` columns; e.g. Q-learning with r4 on M = 3)
    still counts, so the exponent measures the time to settle, not to learn the task well.

Writes under ``--out`` (default ``results/scaling``), each atomically (temporary file, then
``os.replace``): ``scaling.csv`` (one row per spec x learner x reward, ``_low``/``_high``
interval columns), ``scaling_specs.csv``, ``scaling.png`` (log-log iterations to max
success against reachable states, one line per reward pattern through the specs in order of
reachable states, marker shape = object count M) and ``config.json`` (last; ``objects`` is
the list of M, like ``segments``).

Modules
    :mod:`.family` (specs, exact quantities, windows), :mod:`.study` (training in run chunks
    and reduction to rows), :mod:`.statistics` (plateau verdicts, bootstrap intervals,
    growth exponents, reward order), :mod:`.report` (tables, CSV, figure, ``config.json``),
    :mod:`.command` (the command line); ``python -m tableclean_suite.bench.scaling`` runs it.
"""

from tableclean_suite.bench.scaling.command import EXIT_USAGE, PROG, main
from tableclean_suite.bench.scaling.family import (DEFAULT_OBJECT_COUNTS, DEFAULT_SEGMENTS,
                                                   family_spec, largest_default_spec)

__all__ = ["DEFAULT_OBJECT_COUNTS", "DEFAULT_SEGMENTS", "EXIT_USAGE", "PROG", "family_spec",
           "largest_default_spec", "main"]
