"""The scaling study from parsed arguments to files: describe the families, train every cell, report.

:func:`run_study` takes the namespace :mod:`.command` parses (``learners, rewards, segments,
objects, fixed_plan_objects, gammas, runs, base_window, window_exponent, resamples, seed, out``).
"""

from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import asdict
from pathlib import Path

from tableclean_suite.bench.scaling.family import (BASE_MAX_ITR, FIXED_PLAN_FAMILY, PRODUCT_FAMILY, describe_family,
                                                   family_specs, fixed_plan_spec, paper_plan_steps)
from tableclean_suite.bench.scaling.report import (config_dict, json_safe, observed_order, ordering_answer,
                                                   ordering_report, print_cells, print_specs, write_atomic_text,
                                                   write_csv, write_figure)
from tableclean_suite.bench.scaling.statistics import (CONFIDENCE, GEOMETRIC_BLOCKS, LINEAR_BLOCKS, YARDSTICK_FRACTION,
                                                       fit_censored_power_law, log_standard_error, resample_counts)
from tableclean_suite.bench.scaling.study import cell_row, train_cell

#: How the printed fits describe the fixed-plan family's plans.
FIXED_PLAN_LENGTH_TEXT = "fixed at the paper's 8 steps"
#: Learner whose cells feed the figure and the growth-exponent fit (when it is trained).
FIT_LEARNER = "q_learning"


def _counts_text(values) -> str:
    return ",".join(str(v) for v in values)


def growth_fits(rows: list[dict], learner: str, rewards, gammas, family: str = PRODUCT_FAMILY) -> dict:
    """``{gamma text: {reward: fit}}``: :func:`.statistics.fit_censored_power_law` of ``learner``'s
    iterations to the yardstick against states reachable from the start, over ``family``'s specs
    (censored cells enter at their window; each point weighted by its own interval), plus the
    fit's ``intercept`` (log units) for the figure."""
    fits = {}
    for gamma in gammas:
        per_reward = {}
        for reward in rewards:
            cells = [r for r in rows if r["learner"] == learner and r["reward"] == reward and r["gamma"] == gamma
                     and r["family"] == family]
            y = [r["window"] if r["censored"] else r["yardstick_iterations"] for r in cells]
            se = [math.nan if r["censored"] else log_standard_error(r["yardstick_iterations"],
                                                                    r["yardstick_iterations_low"],
                                                                    r["yardstick_iterations_high"]) for r in cells]
            fit = fit_censored_power_law([r["reachable_from_start"] for r in cells], y,
                                         [r["censored"] for r in cells], se)
            reached = [(math.log(r["reachable_from_start"]), math.log(r["yardstick_iterations"]))
                       for r in cells if not r["censored"]]
            fit["intercept"] = (sum(b for _, b in reached) / len(reached)
                                - fit["exponent"] * sum(a for a, _ in reached) / len(reached)) if reached else math.nan
            per_reward[reward] = fit
        fits[f"{gamma:g}"] = per_reward
    return fits


def method_constants(args) -> dict:
    """The method's constants for ``config.json``."""
    from tableclean_suite.bench.scaling.family import ALPHA, EPSILON

    return {
        "alpha": ALPHA, "epsilon": EPSILON, "base_max_itr": BASE_MAX_ITR,
        "window_rule": "window = base_window * (L / L0) ** window_exponent, max_itr = base_max_itr * L / L0, "
                       "L = optimal plan length from the spec's start, L0 = the paper spec's",
        "yardstick": f"iterations until the mean success curve, read in blocks, reaches and stays to the window's "
                     f"end at or above {YARDSTICK_FRACTION} x the optimal policy's exact epsilon-greedy success; "
                     "censored when the last block is below",
        "yardstick_fraction": YARDSTICK_FRACTION,
        "blocks": f"union of {LINEAR_BLOCKS} evenly and {GEOMETRIC_BLOCKS} geometrically spaced block ends",
        "bootstrap": f"multinomial resamples of the runs ({args.resamples}), every figure recomputed by the "
                     "point's own function, percentile interval extended to the point",
        "confidence": CONFIDENCE,
        "fit": "maximum likelihood, log iterations = a + k log(states reachable from the start) + normal error of "
               "variance sigma^2 + s_i^2 (s_i from each point's interval), censored cells as P(> log window); "
               "profile-likelihood interval of k",
    }


def run_study(args) -> int:
    """Describe the specs, train every cell, print and write everything; returns 0.

    Holds ``--out``'s lock while it runs (:func:`~tableclean_suite.bench.outputs.output_lock`, as
    ``run`` does): a second study into the same folder raises
    :class:`~tableclean_suite.bench.outputs.OutputBusyError` (the command line: one line, exit 2)
    instead of interleaving its files with this one's.
    """
    from tableclean_suite.bench import outputs

    with outputs.output_lock(args.out) as out:
        return _study(args, Path(out))


def _study(args, out: Path) -> int:
    """:func:`run_study`'s work, into the locked folder ``out``."""
    started = time.perf_counter()
    paper_plan_length = paper_plan_steps()
    described = describe_family(family_specs(args.segments, args.objects), paper_plan_length, args.base_window,
                                args.window_exponent)
    described += describe_family([fixed_plan_spec(m) for m in args.fixed_plan_objects], paper_plan_length,
                                 args.base_window, args.window_exponent, FIXED_PLAN_FAMILY)
    infos = [info for info, _ in described]
    print(f"Scaling study: {len(infos)} specs (product family N = {_counts_text(args.segments)} x "
          f"M = {_counts_text(args.objects)}; fixed-plan family M = {_counts_text(args.fixed_plan_objects) or 'none'})"
          f" x gamma {_counts_text(args.gammas)} x {len(args.learners)} learners x {len(args.rewards)} rewards, "
          f"{args.runs} runs per cell.")
    print(f"Window rule: window = {args.base_window} * (L / {paper_plan_length}) ** {args.window_exponent:g}, "
          f"max_itr = {BASE_MAX_ITR} * L / {paper_plan_length} (L: optimal plan length from the spec's start).")
    print(f"Yardstick: iterations until the mean success curve reaches and holds to the window's end "
          f"{YARDSTICK_FRACTION:.0%} of the optimal policy's exact success; 'censored' = not within the window.\n")
    print_specs(infos)
    counts = resample_counts(args.runs, args.resamples, args.seed)
    rows = []
    for info, model in described:
        for gamma in args.gammas:
            for learner in args.learners:
                for reward in args.rewards:
                    records = train_cell(model, info, learner, reward, args.runs, args.seed, gamma)
                    rows.append(cell_row(info, learner, reward, gamma, records, counts))
        print(f"trained {info.name} ({len(rows)} cells, {time.perf_counter() - started:.0f} s)", file=sys.stderr,
              flush=True)
    fit_learner = FIT_LEARNER if FIT_LEARNER in args.learners else args.learners[0]
    fits = growth_fits(rows, fit_learner, args.rewards, args.gammas)
    fixed_fits = growth_fits(rows, fit_learner, args.rewards, args.gammas, FIXED_PLAN_FAMILY)
    product = [info for info in infos if info.family == PRODUCT_FAMILY]
    verdicts = {f"{gamma:g}": ordering_report(rows, product, fit_learner, args.rewards, gamma) for gamma in args.gammas}
    print()
    print_cells(rows)
    for gamma in args.gammas:
        print(f"\nGrowth exponents ({fit_learner}, gamma {gamma:g}, product family; iterations to the yardstick ~ "
              f"states reachable from the start ** k; censored maximum likelihood, {CONFIDENCE:.0%} profile interval):")
        for reward, fit in fits[f"{gamma:g}"].items():
            print(f"  {reward}: k = {fit['exponent']:.3f} [{fit['low']:.3f}, {fit['high']:.3f}] over {fit['points']} "
                  f"specs ({fit['censored']} censored)")
        if args.fixed_plan_objects:
            print(f"  fixed-plan family (plan length {FIXED_PLAN_LENGTH_TEXT}):")
            for reward, fit in fixed_fits[f"{gamma:g}"].items():
                print(f"    {reward}: k = {fit['exponent']:.3f} [{fit['low']:.3f}, {fit['high']:.3f}] over "
                      f"{fit['points']} specs ({fit['censored']} censored)")
        print(ordering_answer(verdicts[f"{gamma:g}"]))
        print(f"Observed order ({fit_learner}, gamma {gamma:g}, fewest iterations first):")
        for info in infos:
            order = observed_order(rows, info.name, fit_learner, gamma)
            print(f"  {info.name:<15}{info.reachable_from_start:>7}: {order}")
    write_csv(out / "scaling.csv", rows)
    write_csv(out / "scaling_specs.csv", [asdict(s) for s in infos])
    write_figure(out / "scaling.png", rows, fit_learner, fits)
    seconds = time.perf_counter() - started
    write_atomic_text(out / "config.json", json.dumps(json_safe(
        config_dict(args, infos, {PRODUCT_FAMILY: fits, FIXED_PLAN_FAMILY: fixed_fits}, verdicts, seconds,
                    fit_learner, method_constants(args))), indent=2,
        allow_nan=False) + "\n")
    print(f"\nWrote {out}/scaling.csv, scaling_specs.csv, scaling.png, config.json in {seconds:.1f} s wall.")
    return 0
