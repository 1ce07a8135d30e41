"""The scaling study from parsed arguments (`command`'s namespace) to files: describe the families,
train every cell, report."""

from __future__ import annotations

import math
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pandas as pd

from tableclean_suite.bench.cli import say
from tableclean_suite.bench.scaling.family import (BASE_MAX_ITR, FIXED_PLAN_FAMILY, PRODUCT_FAMILY, counts_text,
                                                   describe_family, family_specs, fixed_plan_spec, paper_plan_steps)
from tableclean_suite.bench.scaling.report import (interval_text, json_safe, observed_order, ordering_answer,
                                                   ordering_report, print_cells, print_specs, write_figure)
from tableclean_suite.bench.scaling.statistics import (CONFIDENCE, MAX_CENSORED_SHARE_FOR_FIT, PAPER_ORDER,
                                                       fit_censored_power_law, local_slopes, log_standard_error)
from tableclean_suite.bench.scaling.study import cell_row, train_cell

#: How the printed fits describe the fixed-plan family's plans.
FIXED_PLAN_LENGTH_TEXT = "fixed at the paper's 8 steps"
#: Learner whose cells feed the figure and the growth-exponent fit (when it is trained).
FIT_LEARNER = "q_learning"


def _cells(rows: list[dict], learner: str, reward: str, gamma: float, family: str) -> list[dict]:
    """``learner``'s cells of ``reward`` at ``gamma`` in ``family``, by states reachable from the start."""
    return sorted((r for r in rows if r["learner"] == learner and r["reward"] == reward and r["gamma"] == gamma
                   and r["family"] == family), key=lambda r: r["reachable_from_start"])


def growth_fits(rows: list[dict], learner: str, rewards, gammas, family: str = PRODUCT_FAMILY) -> dict:
    """``{gamma text: {reward: fit}}``: the censored power-law fit
    ([`fit_censored_power_law`][tableclean_suite.bench.scaling.statistics.fit_censored_power_law]) of
    ``learner``'s median learning time against states reachable from the start, over ``family``'s specs
    (censored cells enter at their window; each point weighted by its own interval; no exponent when more
    than half the cells are censored), plus the fit's ``intercept`` (log units) for the figure."""
    return {f"{gamma:g}": {reward: _growth_fit(_cells(rows, learner, reward, gamma, family)) for reward in rewards}
            for gamma in gammas}


def _growth_fit(cells: list[dict]) -> dict:
    y = [r["window"] if r["censored"] else max(r["learning_time"], 1.0) for r in cells]
    se = [math.nan if r["censored"] else log_standard_error(max(r["learning_time"], 1.0),
                                                            max(r["learning_time_low"], 1.0),
                                                            r["learning_time_high"]) for r in cells]
    fit = fit_censored_power_law([r["reachable_from_start"] for r in cells], y, [r["censored"] for r in cells], se)
    reached = [(math.log(r["reachable_from_start"]), math.log(max(r["learning_time"], 1.0)))
               for r in cells if not r["censored"]]
    fit["intercept"] = (sum(b for _, b in reached) / len(reached)
                        - fit["exponent"] * sum(a for a, _ in reached) / len(reached)) if reached else math.nan
    return fit


def chain_of(row: dict) -> str:
    """The chain of specs a cell's local slopes run along: in the product family the specs of one
    object count M, growing with N (``"M=2"``); the fixed-plan family is one chain (``"N=3"``)."""
    return f"M={row['objects']}" if row["family"] == PRODUCT_FAMILY else f"N={row['segments']}"


def slope_table(rows: list[dict], replicates: dict, learner: str, rewards, gammas, family: str) -> dict:
    """``{gamma text: {reward: [slope dicts]}}``: the
    [`local_slopes`][tableclean_suite.bench.scaling.statistics.local_slopes] of ``learner``'s median
    learning time between consecutive sizes along each chain of ``family``
    ([`chain_of`][tableclean_suite.bench.scaling.pipeline.chain_of]: one factor grows at a time), each
    slope dict with its ``chain``; rewards without a chain of two sizes are left out."""
    table = {}
    for gamma in gammas:
        table[f"{gamma:g}"] = {}
        for reward in rewards:
            cells, listed = _cells(rows, learner, reward, gamma, family), []
            for chain in dict.fromkeys(chain_of(r) for r in cells):
                chosen = [r for r in cells if chain_of(r) == chain]
                draws = np.array([replicates[(r["spec"], gamma, learner, reward)] for r in chosen])
                listed += [{"chain": chain, **slope} for slope in local_slopes(
                    [r["reachable_from_start"] for r in chosen], [r["learning_time"] for r in chosen], draws)]
            if listed:
                table[f"{gamma:g}"][reward] = listed
    return table


def _fit_text(fit: dict) -> str:
    if not math.isfinite(fit["exponent"]):
        reason = ("most cells censored" if fit["censored"] > MAX_CENSORED_SHARE_FOR_FIT * fit["points"]
                  else "too few reached cells")
        return f"no exponent ({reason}) over {fit['points']} specs ({fit['censored']} censored)"
    return (f"k = {fit['exponent']:.3f} [{fit['low']:.3f}, {fit['high']:.3f}] over {fit['points']} specs "
            f"({fit['censored']} censored)")


def _slopes_text(slopes: list[dict]) -> str:
    parts = []
    for chain in dict.fromkeys(s["chain"] for s in slopes):
        parts.append(f"{chain}: " + ", ".join(
            f"{s['from']}->{s['to']} " + interval_text(s["slope"], s["low"], s["high"], 2).replace(">window", "inf")
            for s in slopes if s["chain"] == chain))
    return "; ".join(parts)


def method_constants(args) -> dict:
    """The method's constants for ``config.json``."""
    from tableclean_suite.bench.scaling.family import ALPHA, EPSILON

    return {
        "alpha": ALPHA, "epsilon": EPSILON, "base_max_itr": BASE_MAX_ITR,
        "window_rule": "window = base_window * (L / L0) ** window_exponent, max_itr = base_max_itr * L / L0, "
                       "L = optimal plan length from the spec's start, L0 = the paper spec's",
        "response": "per-run learning time (TrainingResult.learned_at): the iteration from which the run's greedy "
                    "policy follows a shortest plan from every start state through the end of the window; runs "
                    "not there at the end are censored at the window; the cell's figure is the Kaplan-Meier "
                    "median over every seed's runs",
        "bootstrap": f"{args.resamples} resamples: {args.seeds} seeds drawn with replacement, then the runs within "
                     "each drawn seed with replacement; percentile intervals (between-seed variance included)",
        "confidence": CONFIDENCE,
        "fit": "maximum likelihood, log time = a + k log(states reachable from the start) + normal error of "
               "variance sigma^2 + s_i^2 (s_i from each point's interval), censored cells as P(> log window); "
               f"profile-likelihood interval of k; no exponent when more than {MAX_CENSORED_SHARE_FOR_FIT:.0%} "
               "of the cells are censored",
        "local_slopes": "d log(median) / d log(states) between consecutive sizes of a chain (product family: N "
                        "grows at fixed M; fixed-plan family: M grows at N = 3), percentile interval of the cells' "
                        "bootstrap medians",
        "order": f"{' < '.join(PAPER_ORDER)} per spec: each consecutive pair decided when 97.5 % of the paired "
                 "bootstrap medians agree, else a tie",
    }


def run_study(args, out: Path) -> int:
    """Describe the specs, train every cell, print and publish everything into the folder ``out``
    (``--out``, whose lock the caller holds); returns 0."""
    from tableclean_suite.bench import outputs

    started = time.perf_counter()
    paper_plan_length = paper_plan_steps()
    described = describe_family(family_specs(args.segments, args.objects), paper_plan_length, args.base_window,
                                args.window_exponent)
    described += describe_family([fixed_plan_spec(m) for m in args.fixed_plan_objects], paper_plan_length,
                                 args.base_window, args.window_exponent, FIXED_PLAN_FAMILY)
    infos = [info for info, _ in described]
    seeds = tuple(range(args.seed, args.seed + args.seeds))
    say(f"Scaling study: {len(infos)} specs (product family N = {counts_text(args.segments)} x "
          f"M = {counts_text(args.objects)}; fixed-plan family M = {counts_text(args.fixed_plan_objects) or 'none'})"
          f" x gamma {counts_text(args.gammas)} x {len(args.learners)} learners x {len(args.rewards)} rewards, "
          f"{args.seeds} seeds ({counts_text(seeds)}) x {args.runs} runs per cell.")
    say(f"Window rule: window = {args.base_window} * (L / {paper_plan_length}) ** {args.window_exponent:g}, "
          f"max_itr = {BASE_MAX_ITR} * L / {paper_plan_length} (L: optimal plan length from the spec's start).")
    say("Learning time: per run, the iteration from which its greedy policy follows a shortest plan from every "
          "start state to the window's end; Kaplan-Meier median over all seeds' runs, 'censored' = more than half "
          f"the runs not there by the window's end; {CONFIDENCE:.0%} intervals from {args.resamples} seeds-then-runs "
          "resamples.\n")
    print_specs(infos)
    rows, replicates = [], {}
    for info, model in described:
        for gamma in args.gammas:
            for learner in args.learners:
                for reward in args.rewards:
                    records = train_cell(model, info, learner, reward, args.runs, seeds, gamma)
                    rng = np.random.default_rng([args.seed, len(rows)])
                    row, medians = cell_row(info, learner, reward, gamma, records, args.resamples, rng)
                    rows.append(row)
                    replicates[(info.name, gamma, learner, reward)] = medians
        print(f"trained {info.name} ({len(rows)} cells, {time.perf_counter() - started:.0f} s)", file=sys.stderr,
              flush=True)
    fit_learner = FIT_LEARNER if FIT_LEARNER in args.learners else args.learners[0]
    families = [PRODUCT_FAMILY] + ([FIXED_PLAN_FAMILY] if args.fixed_plan_objects else [])
    fits = {family: growth_fits(rows, fit_learner, args.rewards, args.gammas, family) for family in families}
    slopes = {family: slope_table(rows, replicates, fit_learner, args.rewards, args.gammas, family)
              for family in families}
    product = [info for info in infos if info.family == PRODUCT_FAMILY]
    verdicts = {f"{gamma:g}": ordering_report(replicates, product, fit_learner, args.rewards, gamma)
                for gamma in args.gammas}
    print()
    print_cells(rows)
    for gamma in args.gammas:
        key = f"{gamma:g}"
        for family in families:
            say(f"\n{fit_learner}, gamma {gamma:g}, {family} family"
                  f"{' (plan length ' + FIXED_PLAN_LENGTH_TEXT + ')' if family == FIXED_PLAN_FAMILY else ''}: "
                  "local slopes d log(median) / d log(states) [95 % interval] between consecutive sizes of each "
                  "chain (one of N, M growing), and the censored power-law fit where at most half the cells are "
                  "censored:")
            for reward in args.rewards:
                say(f"  {reward}: {_slopes_text(slopes[family][key].get(reward, []))}")
                say(f"  {' ' * len(reward)}  fit: {_fit_text(fits[family][key][reward])}")
        say(ordering_answer(verdicts[key]))
        say(f"Observed order ({fit_learner}, gamma {gamma:g}, median learning time, fewest first):")
        for info in infos:
            order = observed_order(rows, info.name, fit_learner, gamma)
            say(f"  {info.name:<15}{info.reachable_from_start:>7}: {order}")
    slope_rows = [{"family": family, "gamma": float(gamma), "learner": fit_learner, "reward": reward, **slope}
                  for family in families for gamma, per in slopes[family].items()
                  for reward, listed in per.items() for slope in listed]
    seconds = time.perf_counter() - started
    specs = [asdict(s) for s in infos]
    config = {"study": "scaling", **outputs.arguments(args), **method_constants(args), "fit_learner": fit_learner,
              "growth_exponents": fits, "local_slopes": slopes, "paper_order": list(PAPER_ORDER),
              "order_holds": verdicts, "specs": specs, "seconds": seconds}
    outputs.publish(out, {
        "scaling.csv": lambda path: pd.DataFrame(rows).to_csv(path, index=False),
        "scaling_specs.csv": lambda path: pd.DataFrame(specs).to_csv(path, index=False),
        "scaling_slopes.csv": lambda path: pd.DataFrame(slope_rows).to_csv(path, index=False),
        "scaling.png": lambda path: write_figure(path, rows, fit_learner, fits[PRODUCT_FAMILY]),
    }, json_safe(config), command="scaling")
    say(f"\nWrote {out}/scaling.csv, scaling_specs.csv, scaling_slopes.csv, scaling.png, config.json in "
          f"{seconds:.1f} s wall.")
    return 0
