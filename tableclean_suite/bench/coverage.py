"""``tableclean-bench coverage``: how often each published interval holds the many-run value.

    tableclean-bench coverage                          # 100 replications of the 8 main cells
    tableclean-bench coverage --replications 100 --runs 200 --iterations 2000 --reference-runs 4000

For each main cell: one reference of ``--reference-runs`` runs (seed S) and K = ``--replications``
replications of ``--runs`` runs (seed S + 1 + k), each through the run command's path.  For every
published column ``X`` with ``X_low``/``X_high`` (``table3.csv``, ``comparisons.csv``), a replication
covers when ``X_low <= target <= X_high``, the target being the reference's ``X``; coverage =
covered / K with its Clopper-Pearson interval.  Writes ``OUT/coverage.csv`` (same arguments, same
bytes); the reference's cells are kept in ``OUT/cells/``.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from tableclean_suite.bench.tables import HIGH, LOW, PRINT_WIDTH
from tableclean_suite.intervals import DEFAULT_CONFIDENCE

#: Replications per cell by default (18 of 20 has a 95 % Clopper-Pearson interval of [68, 99] %).
DEFAULT_REPLICATIONS = 100
DEFAULT_REFERENCE_RUNS = 20_000
#: Bootstrap resamples of the reference, whose point values alone are used (2: scipy's fewest without a warning).
REFERENCE_SAMPLES = 2
RESULT_FILE = "coverage.csv"
PROG = "tableclean-bench coverage"
DEFAULT_OUT = "results/coverage"
#: Columns of ``coverage.csv``.
COLUMNS = ("table", "row", "statistic", "target", "nominal", "runs", "reference_runs", "replications", "covered",
           "undefined", "coverage", "coverage_low", "coverage_high", "coverage_confidence", "mean_width")
#: [RunConfig][tableclean_suite.bench.config.RunConfig] fields taken with the run command's flags, and their
#: argparse types (None: text).
RUN_FIELDS = {"learners": None, "rewards": None, "alpha": float, "gamma": float, "epsilon": float, "max_itr": int,
              "exploration": None, "q_init": float, "learner_options": None, "start": None, "ineffective": None,
              "threshold": float, "plateau_fraction": float, "support_fraction": float, "bootstrap_samples": int,
              "analysis": None, "analysis_episodes": int}


def replication_seed(seed: int, replication: int) -> int:
    """The seed of replication ``replication`` (0-based) of a study whose reference trains at ``seed``."""
    return int(seed) + 1 + int(replication)


def published_tables(config, model, store) -> dict:
    """The tables with intervals the run command publishes for ``config``'s main cells, trained or loaded
    through ``store``: ``"table3"`` by ``cell_id`` and (two or more cells) ``"comparisons"`` by
    ``"LEARNER-REWARD vs LEARNER-REWARD: SCORE"``."""
    from tableclean_suite.bench import experiments, statistics, tables

    grid = [m for m in experiments.config_grid(config) if m.experiment == "main"]
    grid_run = experiments.run_grid(grid, config, model, store)
    records, _ = experiments.cell_records(grid, grid_run.summaries, grid_run.statistics, config.settle_tolerance)
    published = {"table3": tables.table3(records, compare_with_paper=False).set_index("cell_id")}
    compared = statistics.comparisons(  # as the run command computes comparisons.csv
        grid_run.comparison_cells(m.cell for m in grid), config.confidence, config.bootstrap_samples, config.seed)
    if len(compared):
        published["comparisons"] = compared.set_axis([f"{row.learner_x}-{row.reward_x} vs {row.learner_y}-"
                                                      f"{row.reward_y}: {row.score}" for row in compared.itertuples()],
                                                     axis="index")
    return published


def _float(value) -> float:
    import pandas as pd

    return math.nan if value is None or value is pd.NA else float(value)


def coverage_frame(reference: dict, replications: list[dict], runs: int, reference_runs: int, nominal: float,
                   confidence: float = DEFAULT_CONFIDENCE):
    """One row (`COLUMNS`) per (table, row, statistic with an interval) of the ``reference`` tables (their point
    values are the targets) scored over the ``replications``' tables (at least one).  ``runs``,
    ``reference_runs`` and ``nominal`` (the intervals' confidence) are recorded; ``confidence`` (in (0, 1)) is
    the Clopper-Pearson interval's.  An undefined target leaves ``covered`` and ``coverage`` empty;
    ``mean_width`` is over the defined intervals (equal bounds, infinite included: width 0)."""
    import numpy as np
    import pandas as pd

    from tableclean_suite.intervals import clopper_pearson

    rows = []
    for table, frame in reference.items():
        statistics = [name for name in frame.columns if {name + LOW, name + HIGH} <= set(frame.columns)]
        for label, values in frame.iterrows():
            for name in statistics:
                target = _float(values[name])
                lows = np.array([_float(tables[table].at[label, name + LOW]) for tables in replications])
                highs = np.array([_float(tables[table].at[label, name + HIGH]) for tables in replications])
                defined = ~(np.isnan(lows) | np.isnan(highs))
                with np.errstate(invalid="ignore"):  # inf - inf: equal bounds, width 0
                    widths = np.where(highs[defined] == lows[defined], 0.0, highs[defined] - lows[defined])
                row = {"table": table, "row": label, "statistic": name, "target": target, "nominal": nominal,
                       "runs": runs, "reference_runs": reference_runs, "replications": len(replications),
                       "covered": pd.NA, "undefined": int((~defined).sum()), "coverage": math.nan,
                       "coverage_low": math.nan, "coverage_high": math.nan, "coverage_confidence": confidence,
                       "mean_width": float(np.mean(widths)) if defined.any() else math.nan}
                if not math.isnan(target):
                    covered = int((defined & (lows <= target) & (target <= highs)).sum())
                    row.update(covered=covered, coverage=covered / len(replications))
                    row["coverage_low"], row["coverage_high"] = clopper_pearson(covered, len(replications), confidence)
                rows.append(row)
    frame = pd.DataFrame(rows, columns=list(COLUMNS))
    frame["covered"] = frame["covered"].astype("Int64")
    return frame


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line: its own options and the run command's cell settings."""
    from tableclean_suite.bench import cli, run
    from tableclean_suite.bench.config import defaults, field_docs

    docs, default = field_docs(), defaults()
    parser = cli.command_parser(prog, "Measured coverage of every interval the run command publishes:\n"
                                      "K replications of each main cell against one many-run reference.",
                                epilog="The output holds measurements only. See docs/coverage.md.")
    own = parser.add_argument_group("coverage")
    own.add_argument("--replications", type=cli.positive_int, default=DEFAULT_REPLICATIONS, metavar="K",
                     help=f"replications of each cell (seeds S+1 .. S+K), an integer >= 1 "
                          f"(default {DEFAULT_REPLICATIONS})")
    own.add_argument("--reference-runs", type=cli.positive_int, default=DEFAULT_REFERENCE_RUNS, metavar="N",
                     help=f"runs of each cell's reference (seed S), whose point values are the targets; an integer "
                          f">= --runs (default {DEFAULT_REFERENCE_RUNS})")
    own.add_argument("--confidence", type=cli.number_type(float, lambda v: 0 < v < 1, "a number in (0, 1)"),
                     default=DEFAULT_CONFIDENCE, metavar="LEVEL",
                     help=f"confidence of the Clopper-Pearson interval on each coverage, in (0, 1) "
                          f"(default {DEFAULT_CONFIDENCE:g})")
    own.add_argument("--nominal", type=float, default=default["confidence"], metavar="LEVEL",
                     help=f"confidence of the intervals measured (the run command's --confidence), in (0, 1) "
                          f"(default {default['confidence']:g})")
    cells = parser.add_argument_group("cells (the run command's settings)")
    cli.add_runs_argument(cells, default["runs"], "runs per replication")
    cli.add_iterations_argument(cells, default["iterations"], "iterations per run")
    cli.add_seed_argument(cells, "the reference (S) and the replications (S+1+k)", default=default["seed"])
    cli.add_task_argument(cells, default=default["task"])
    for field, kind in RUN_FIELDS.items():
        shown = default[field]
        shown = " ".join(map(str, shown)) if isinstance(shown, tuple) else shown
        text = docs.get(field, "") + ("" if shown is None else f" (default: {shown})")
        options = {"nargs": "+", "metavar": field[:-1].upper()} if isinstance(default[field], tuple) else {}
        cells.add_argument(run.flag_of(field), dest=field, type=cli.name_list if options else kind,
                           default=argparse.SUPPRESS, help=text.replace("%", "%%"), **options)
    cli.add_out_argument(parser, cli.DIRECTORY, DEFAULT_OUT, "output directory")
    parser.add_argument("--no-progress", dest="progress", action="store_false",
                        help="no progress bar on stderr")
    return parser


def parse_args(argv=None, prog: str | None = None) -> argparse.Namespace:
    """Parse and check the command line (exit 2 on a bad value); adds ``config`` (the replications'
    [RunConfig][tableclean_suite.bench.config.RunConfig]) and ``prog``."""
    from tableclean_suite.bench import cli, run
    from tableclean_suite.bench.config import ConfigError, RunConfig

    parser, args = cli.parse_command(build_parser, argv, prog or PROG)
    args.prog = parser.prog
    if args.reference_runs < args.runs:
        parser.error(f"--reference-runs: {args.reference_runs} is fewer than --runs {args.runs}; "
                     f"allowed: an integer >= --runs")
    settings = {field: getattr(args, field) for field in RUN_FIELDS if hasattr(args, field)}
    for field in ("learners", "rewards"):
        if field in settings:
            settings[field] = [name for value in settings[field] for name in value]  # each value a comma list
    try:
        args.config = RunConfig(**settings, runs=args.runs, iterations=args.iterations, seed=args.seed,
                                task=args.task, confidence=args.nominal, sweeps=False, literature=False,
                                figures=False, progress=False, out=args.out, plugins=args.plugins)
    except ConfigError as error:
        flag = {"confidence": "--nominal"}.get(error.field, run.flag_of(error.field))
        parser.error(error.message_for(flag))
    cli.check_out(parser, args.out, "coverage", folders=("cells",))
    return args


def estimate(args, model) -> str:
    """The study's learner steps and estimated time, as printed; refuses a study too large
    ([check_grid_resources][tableclean_suite.bench.experiments.check_grid_resources])."""
    from tableclean_suite import resources
    from tableclean_suite.bench import experiments

    config, replications = args.config, args.replications
    cells = [m.cell for m in experiments.config_grid(config) if m.experiment == "main"]
    reference = replace(config, runs=args.reference_runs)
    seconds = sum(times * experiments.check_grid_resources(experiments.CellRun(cell, settings, model)
                                                           for cell in cells)
                  for times, settings in ((replications, config), (1, reference)))
    resources.require_time(seconds, f"{replications} replications and a reference of {len(cells)} cell(s)")
    steps = replications * len(cells) * config.runs * config.iterations
    reference_steps = len(cells) * args.reference_runs * config.iterations
    return (f"work: {replications} replications x {len(cells)} cells x {config.runs} runs x {config.iterations} "
            f"iterations = {steps:.3g} learner steps,\n"
            f"  plus the reference: {len(cells)} cells x {args.reference_runs} runs = {reference_steps:.3g}; "
            f"estimated {resources.format_seconds(seconds)} (training and asymptotes; bootstraps on top)")


def measure(args, model, out: Path):
    """Train the reference (cells kept in ``out/cells``) and the replications (not kept): their
    [coverage_frame][tableclean_suite.bench.coverage.coverage_frame]."""
    from tqdm.auto import tqdm

    from tableclean_suite.bench import experiments

    config = args.config
    reference_config = replace(config, runs=args.reference_runs, bootstrap_samples=REFERENCE_SAMPLES)
    print(f"reference: {args.reference_runs} runs per cell at seed {config.seed}", file=sys.stderr)
    started = time.perf_counter()
    reference = published_tables(reference_config, model, experiments.CellStore(out / "cells"))
    print(f"reference: {time.perf_counter() - started:.1f} s (trained, or loaded from {out / 'cells'})",
          file=sys.stderr)
    tables = []
    bar = tqdm(total=args.replications, desc="replications", unit="rep", disable=not args.progress, leave=False)
    with tempfile.TemporaryDirectory(prefix=".replications-", dir=out) as scratch:
        store = experiments.CellStore(scratch)  # run_grid saves each cell; a replication's are dropped after it
        for k in range(args.replications):
            started = time.perf_counter()
            tables.append(published_tables(replace(config, seed=replication_seed(config.seed, k)), model, store))
            for path in store.root.glob("*.npz"):
                path.unlink()
            if k == 0 and args.replications > 1:
                seconds = time.perf_counter() - started
                bar.write(f"replication 1 took {seconds:.1f} s: the other {args.replications - 1} about "
                          f"{(args.replications - 1) * seconds / 60:.1f} min", file=sys.stderr)
            bar.update(1)
    bar.close()
    return coverage_frame(reference, tables, config.runs, args.reference_runs, config.confidence, args.confidence)


def display_lines(frame) -> list[str]:
    """The printed table, one section per published table, at most ``PRINT_WIDTH`` characters wide
    (pandas wraps further columns into a block below)."""
    import pandas as pd

    lines = []
    for table, rows in frame.groupby("table", sort=False):
        one = rows["statistic"].nunique() == 1
        labels = ["row"] + ([] if one else ["statistic"])
        percent = 100 * rows[["coverage", "coverage_low", "coverage_high"]].to_numpy()
        shown = rows[labels].assign(
            target=rows["target"].map("{:.5g}".format),
            covered=rows["covered"].astype(str) + "/" + rows["replications"].astype(str),
            **{"coverage %": [f"{value:.1f}" for value in percent[:, 0]],
               "interval %": [f"[{low:.1f}, {high:.1f}]" for low, high in percent[:, 1:]],
               "mean width": rows["mean_width"].map("{:.4g}".format)})
        shown.loc[rows["covered"].isna(), ["covered", "coverage %", "interval %"]] = "-"
        for name in labels:  # left-aligned, header included
            shown[name] = shown[name].str.ljust(max(len(name), shown[name].str.len().max()))
        header = [name.ljust(len(shown[name].iloc[0])) if name in labels else name for name in shown.columns]
        lines.append(f"{table}.csv" + (f", {rows['statistic'].iloc[0]}:" if one else ":"))
        lines += shown.to_string(index=False, header=header, line_width=PRINT_WIDTH).splitlines()
    return lines


def main(argv=None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    from tableclean_suite.bench import cli, outputs
    from tableclean_suite.executors.blas import single_blas_thread

    args = parse_args(argv, prog)
    model = args.config.task_model()
    out = Path(args.out)
    text = estimate(args, model)
    model.require_learnable()  # after the resource guard (it builds the transitions), before any work
    print(text)
    started = time.perf_counter()
    try:
        with outputs.output_lock(out), single_blas_thread():
            frame = measure(args, model, out)
            outputs.publish(out, {RESULT_FILE: lambda path: frame.to_csv(path, index=False)},
                            {"args": outputs.arguments(args), "config": outputs.arguments(args.config)},
                            command="coverage")
    except KeyboardInterrupt:
        print(f"{args.prog}: interrupted; nothing written (the reference's cells are kept in {out / 'cells'})",
              file=sys.stderr)
        return cli.EXIT_INTERRUPTED
    config = args.config
    print(f"\nCoverage on task {config.task!r}: alpha {config.alpha:g}, gamma {config.gamma:g}, {config.runs} runs x "
          f"{config.iterations} iterations per replication,")
    print(f"  {config.bootstrap_samples} bootstrap replicates; target = the {args.reference_runs}-run "
          f"reference's value; nominal {100 * config.confidence:g} %;")
    print(f"  interval = {100 * args.confidence:g} % Clopper-Pearson interval of the coverage, in %.")
    for line in display_lines(frame):
        print(line)
    print(f"written: {out / RESULT_FILE} (in {time.perf_counter() - started:.1f} s)")
    return 0


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("coverage", "python -m tableclean_suite.bench.coverage"))
