"""The scaling study's command line: parse the flags, describe the family, train every cell, report."""

from __future__ import annotations

import argparse
from pathlib import Path

from tableclean_suite.bench import cli, outputs
from tableclean_suite.bench.cli import positive_float, positive_int
from tableclean_suite.bench.scaling.family import (DEFAULT_BASE_WINDOW, DEFAULT_FIXED_PLAN_OBJECTS, DEFAULT_GAMMAS,
                                                   DEFAULT_OBJECT_COUNTS, DEFAULT_SEGMENTS, DEFAULT_WINDOW_EXPONENT,
                                                   counts_text)
from tableclean_suite.bench.scaling.pipeline import run_study
from tableclean_suite.intervals import DEFAULT_REPS

#: The program name in messages unless the caller gives one.
PROG = "tableclean-bench scaling"
DEFAULT_OUT = Path("results") / "scaling"

DEFAULT_LEARNERS = ("q_learning", "sarsa")
#: The paper's four patterns and r4 with the looping rule for any N (both looping rules reported).
DEFAULT_REWARDS = ("r1", "r2", "r3", "r4", "r4_cycle")
#: Runs per seed and cell, and seeds per cell (--seed, --seed + 1, ...; at least MIN_SEEDS for a
#: between-seed spread).
DEFAULT_RUNS, DEFAULT_SEEDS, MIN_SEEDS = 20, 5, 2
DEFAULT_SEED = 0
#: Fewest segments and objects a spec can have.
MIN_SEGMENTS, MIN_OBJECTS = 2, 1


def _number_list(kind, allowed, what: str, ordered: bool = False, none: bool = False):
    """A list flag's type: ``"2,3,5"`` -> ``(2, 3, 5)``, distinct ``kind`` values for which ``allowed``
    holds, sorted (``ordered``: in the order given; ``none``: ``"none"`` -> ``()``), else an argparse
    error naming ``what``."""
    def parse(text: str) -> tuple:
        if none and text.strip().lower() == "none":
            return ()
        try:
            values = tuple(dict.fromkeys(kind(part) for part in text.split(",") if part.strip()))
        except ValueError:
            values = ()
        if not values or not all(allowed(v) for v in values):
            raise argparse.ArgumentTypeError(f"expected comma-separated {what}, got {text!r}")
        return values if ordered else tuple(sorted(values))

    parse.comma_list = True  # given twice: refused (cli.OneLineParser)
    return parse


segment_list = _number_list(int, lambda n: n >= MIN_SEGMENTS, f"segment counts >= {MIN_SEGMENTS}")
object_list = _number_list(int, lambda m: m >= MIN_OBJECTS, f"object counts >= {MIN_OBJECTS}")
fixed_plan_list = _number_list(int, lambda m: m >= MIN_OBJECTS, f"object counts >= {MIN_OBJECTS}", none=True)
gamma_list = _number_list(float, lambda g: 0.0 < g <= 1.0, "discounts in (0, 1]", ordered=True)


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line of the study."""
    from tableclean_suite.bench import scaling
    from tableclean_suite.learners import learner_names
    from tableclean_suite.rewards import reward_pattern_names

    parser = cli.command_parser(prog, scaling.__doc__.splitlines()[0])
    parser.add_argument("--learners", type=cli.choice_list(learner_names(), "learner"), default=DEFAULT_LEARNERS,
                        help=f"comma-separated learners; allowed: {', '.join(learner_names())} "
                             f"(default: {','.join(DEFAULT_LEARNERS)})")
    parser.add_argument("--rewards", type=cli.choice_list(reward_pattern_names(), "reward pattern"),
                        default=DEFAULT_REWARDS, help=f"comma-separated reward patterns; allowed: "
                        f"{', '.join(reward_pattern_names())} (default: {','.join(DEFAULT_REWARDS)})")
    parser.add_argument("--segments", type=segment_list, default=DEFAULT_SEGMENTS,
                        help=f"comma-separated segment counts N >= {MIN_SEGMENTS}; the family is "
                             f"segments x objects (default: {counts_text(DEFAULT_SEGMENTS)})")
    parser.add_argument("--objects", type=object_list, default=DEFAULT_OBJECT_COUNTS,
                        help=f"comma-separated object counts M >= {MIN_OBJECTS} "
                             f"(default: {counts_text(DEFAULT_OBJECT_COUNTS)})")
    parser.add_argument("--runs", type=positive_int, default=DEFAULT_RUNS,
                        help=f"runs per seed and cell (default: {DEFAULT_RUNS})")
    parser.add_argument("--seeds", type=cli.int_in(MIN_SEEDS, 10**6, "a seed count"), default=DEFAULT_SEEDS,
                        help=f"seeds per cell, --seed, --seed + 1, ... (>= {MIN_SEEDS}; default: {DEFAULT_SEEDS})")
    parser.add_argument("--base-window", type=positive_int, default=DEFAULT_BASE_WINDOW,
                        help=f"iterations for the paper's spec (default: {DEFAULT_BASE_WINDOW})")
    parser.add_argument("--window-exponent", type=positive_float, default=DEFAULT_WINDOW_EXPONENT,
                        help=f"window = base * (L / L0) ** exponent (default: {DEFAULT_WINDOW_EXPONENT})")
    parser.add_argument("--resamples", type=positive_int, default=DEFAULT_REPS,
                        help=f"seeds-then-runs bootstrap resamples (default: {DEFAULT_REPS})")
    parser.add_argument("--gammas", type=gamma_list, default=DEFAULT_GAMMAS,
                        help=f"comma-separated discounts in (0, 1], each an axis value of the study "
                             f"(default: {counts_text(DEFAULT_GAMMAS)})")
    parser.add_argument("--fixed-plan-objects", type=fixed_plan_list, default=DEFAULT_FIXED_PLAN_OBJECTS,
                        help=f"object counts M >= {MIN_OBJECTS} of the fixed-plan family (3 segments, 8-step plan, "
                             f"M - 1 objects parked), or 'none' (default: {counts_text(DEFAULT_FIXED_PLAN_OBJECTS)})")
    cli.add_seed_argument(parser, "the first training seed and the bootstrap", default=DEFAULT_SEED)
    cli.add_out_argument(parser, cli.DIRECTORY, str(DEFAULT_OUT), "output folder")
    return parser


def main(argv=None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    from tableclean_suite.bench.scaling.family import family_specs, fixed_plan_spec

    parser, args = cli.parse_command(build_parser, argv, prog or PROG)
    try:  # the sizes the task model refuses, before any work
        family_specs(args.segments, args.objects) + [fixed_plan_spec(m) for m in args.fixed_plan_objects]
    except ValueError as error:
        parser.error(f"--segments/--objects/--fixed-plan-objects: {error}")
    cli.check_out(parser, args.out, "scaling")
    with outputs.output_lock(args.out) as out:  # held throughout: OutputBusyError when another process holds it
        return run_study(args, out)
