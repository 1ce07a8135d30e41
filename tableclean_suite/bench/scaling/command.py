"""The scaling study's command line: parse the flags, describe the family, train every cell, report."""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import asdict
from pathlib import Path

from tableclean_suite.bench import cli
from tableclean_suite.bench.cli import positive_float, positive_int
from tableclean_suite.bench.scaling.family import (BASE_MAX_ITR, DEFAULT_BASE_WINDOW, DEFAULT_OBJECT_COUNTS,
                                                   DEFAULT_SEGMENTS, DEFAULT_WINDOW_EXPONENT, describe_family,
                                                   family_specs, paper_plan_steps)
from tableclean_suite.bench.scaling.report import (config_dict, json_safe, observed_order, ordering_answer,
                                                   ordering_report, print_cells, print_specs, write_atomic_text,
                                                   write_csv, write_figure)
from tableclean_suite.bench.scaling.statistics import (CONFIDENCE, DEFAULT_RESAMPLES, MIN_PLATEAU,
                                                       PLATEAU_RISE_TOLERANCE, fit_growth_exponent, resample_counts)
from tableclean_suite.bench.scaling.study import cell_row, train_cell

#: The program name in messages unless the caller gives one.
PROG = "tableclean-bench scaling"
EXIT_USAGE = cli.EXIT_USAGE
DEFAULT_OUT = Path("results") / "scaling"

DEFAULT_LEARNERS = ("q_learning", "sarsa")
DEFAULT_REWARDS = ("r1", "r2", "r3", "r4")
#: Learner whose cells feed the figure and the growth-exponent fit (when it is trained).
FIT_LEARNER = "q_learning"
#: Runs per cell (independent learners), enough for 95 % bootstrap intervals.
DEFAULT_RUNS = 100
DEFAULT_SEED = 0


def _choice_list(allowed, what: str):
    def parse(text: str) -> tuple[str, ...]:
        chosen = tuple(dict.fromkeys(part.strip() for part in text.split(",") if part.strip()))
        bad = [name for name in chosen if name not in allowed]
        if bad or not chosen:
            raise argparse.ArgumentTypeError(f"unknown {what} {', '.join(bad) or text!r}; "
                                             f"allowed: {', '.join(allowed)} (comma separated)")
        return chosen
    return parse


#: Fewest segments a spec can have (a task needs a segment to move to) ...
MIN_SEGMENTS = 2
#: ... and fewest objects.
MIN_OBJECTS = 1


def _count_list(text: str, minimum: int, what: str) -> tuple[int, ...]:
    """``"2,3,5"`` -> ``(2, 3, 5)``: sorted, distinct integers >= ``minimum``, else an argparse error."""
    try:
        values = sorted({int(part) for part in text.split(",") if part.strip()})
    except ValueError:
        values = []
    if not values or values[0] < minimum:
        raise argparse.ArgumentTypeError(f"expected comma-separated {what} >= {minimum}, got {text!r}")
    return tuple(values)


def segment_list(text: str) -> tuple[int, ...]:
    """``"2,3,5"`` -> ``(2, 3, 5)``: sorted, distinct segment counts >= 2."""
    return _count_list(text, MIN_SEGMENTS, "segment counts")


def object_list(text: str) -> tuple[int, ...]:
    """``"1,3"`` -> ``(1, 3)``; ``"2"`` -> ``(2,)``: sorted, distinct object counts >= 1."""
    return _count_list(text, MIN_OBJECTS, "object counts")


def _counts_text(values) -> str:
    return ",".join(str(v) for v in values)


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line of the study."""
    from tableclean_suite.bench import scaling
    from tableclean_suite.learners import learner_names
    from tableclean_suite.rewards import reward_pattern_names

    parser = cli.command_parser(prog, scaling.__doc__.splitlines()[0])
    parser.add_argument("--learners", type=_choice_list(learner_names(), "learner"), default=DEFAULT_LEARNERS,
                        help=f"comma-separated learners; allowed: {', '.join(learner_names())} "
                             f"(default: {','.join(DEFAULT_LEARNERS)})")
    parser.add_argument("--rewards", type=_choice_list(reward_pattern_names(), "reward pattern"),
                        default=DEFAULT_REWARDS, help=f"comma-separated reward patterns; allowed: "
                        f"{', '.join(reward_pattern_names())} (default: {','.join(DEFAULT_REWARDS)})")
    parser.add_argument("--segments", type=segment_list, default=DEFAULT_SEGMENTS,
                        help=f"comma-separated segment counts N >= {MIN_SEGMENTS}; the family is "
                             f"segments x objects (default: {_counts_text(DEFAULT_SEGMENTS)})")
    parser.add_argument("--objects", type=object_list, default=DEFAULT_OBJECT_COUNTS,
                        help=f"comma-separated object counts M >= {MIN_OBJECTS} "
                             f"(default: {_counts_text(DEFAULT_OBJECT_COUNTS)})")
    parser.add_argument("--runs", type=positive_int, default=DEFAULT_RUNS,
                        help=f"runs per cell (default: {DEFAULT_RUNS})")
    parser.add_argument("--base-window", type=positive_int, default=DEFAULT_BASE_WINDOW,
                        help=f"iterations for the paper's spec (default: {DEFAULT_BASE_WINDOW})")
    parser.add_argument("--window-exponent", type=positive_float, default=DEFAULT_WINDOW_EXPONENT,
                        help=f"window = base * (L / L0) ** exponent (default: {DEFAULT_WINDOW_EXPONENT})")
    parser.add_argument("--resamples", type=positive_int, default=DEFAULT_RESAMPLES,
                        help=f"bootstrap resamples (default: {DEFAULT_RESAMPLES})")
    cli.add_seed_argument(parser, "the training runs and the bootstrap", default=DEFAULT_SEED)
    cli.add_out_argument(parser, cli.DIRECTORY, str(DEFAULT_OUT), "output folder")
    return parser


def run_study(args) -> int:
    """Describe the specs, train every cell, print and write everything; returns 0."""
    started = time.perf_counter()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    paper_plan_length = paper_plan_steps()
    specs = family_specs(args.segments, args.objects)
    described = describe_family(specs, paper_plan_length, args.base_window, args.window_exponent)
    infos = [info for info, _ in described]
    print(f"Scaling study: {len(infos)} specs (N = {_counts_text(args.segments)} segments x "
          f"M = {_counts_text(args.objects)} objects, by reachable states) x {len(args.learners)} learners x "
          f"{len(args.rewards)} rewards, {args.runs} runs per cell.")
    print(f"Window rule: window = {args.base_window} * (L / {paper_plan_length}) ** {args.window_exponent:g}, "
          f"max_itr = {BASE_MAX_ITR} * L / {paper_plan_length} (L: optimal plan length from the default start);")
    print(f"a cell 'not reached' has a plateau below {MIN_PLATEAU} or a success curve still rising by more than "
          f"{PLATEAU_RISE_TOLERANCE} over its plateau window.\n")
    print_specs(infos)
    counts = resample_counts(args.runs, args.resamples, args.seed)
    rows = []
    for info, model in described:
        for learner in args.learners:
            for reward in args.rewards:
                records = train_cell(model, info, learner, reward, args.runs, args.seed)
                rows.append(cell_row(info, learner, reward, records, counts))
    fit_learner = FIT_LEARNER if FIT_LEARNER in args.learners else args.learners[0]
    fits = {reward: fit_growth_exponent(
        [r["reachable"] for r in rows if r["learner"] == fit_learner and r["reward"] == reward],
        [r["max_success_iterations"] for r in rows if r["learner"] == fit_learner and r["reward"] == reward])
        for reward in args.rewards}
    verdicts = ordering_report(rows, infos, fit_learner, args.rewards)
    print()
    print_cells(rows)
    print(f"\nGrowth exponents ({fit_learner}; iterations to max success ~ reachable states ** k, "
          f"least squares on log-log, {CONFIDENCE:.0%} t interval):")
    for reward, fit in fits.items():
        print(f"  {reward}: k = {fit['exponent']:.3f} [{fit['low']:.3f}, {fit['high']:.3f}] "
              f"over {fit['points']} specs")
    print(ordering_answer(verdicts))
    print(f"Observed order ({fit_learner}, fewest iterations first):")
    for info in infos:
        print(f"  {info.name:<14}{info.reachable:>7}: {observed_order(rows, info.name, fit_learner)}")
    write_csv(out / "scaling.csv", rows)
    write_csv(out / "scaling_specs.csv", [asdict(s) for s in infos])
    write_figure(out / "scaling.png", rows, fit_learner, fits)
    seconds = time.perf_counter() - started
    write_atomic_text(out / "config.json", json.dumps(json_safe(
        config_dict(args, infos, fits, verdicts, seconds, fit_learner)), indent=2, allow_nan=False) + "\n")
    print(f"\nWrote {out}/scaling.csv, scaling_specs.csv, scaling.png, config.json in {seconds:.1f} s wall.")
    return 0


def main(argv=None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    _, args = cli.parse_command(build_parser, argv, prog or PROG)
    return run_study(args)
