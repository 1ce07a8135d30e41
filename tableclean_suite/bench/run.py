"""``tableclean-bench run``: reproduce the paper's Tables 3-4 and Figures 3-7.

    tableclean-bench run                      # defaults reproduce the paper (~seconds)
    tableclean-bench run --describe           # the task model, Table 1 mapping, Table 2
    tableclean-bench run --runs 200 --rewards r2 r4 --no-sweeps --out results/quick

Trains the grid ([`experiments`][tableclean_suite.bench.experiments]: main, sweeps, literature),
prints Tables 3-4, the probabilities of improvement and the sweeps, and writes to ``--out``:
``table3.csv``, ``table4.csv`` (an interval column ``X`` followed by ``X_low``/``X_high``),
``comparisons.csv``, ``curves.csv``, the figures ``fig3..fig8*.png``, ``config.json`` (written
last: the configuration, a run id and each file's SHA-256) and ``cells/`` (a rerun loads them;
``--fresh`` retrains).  The settings are a `RunConfig` built from the command line here.
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import math
import platform
import sys
import time
from pathlib import Path

from tableclean_suite.bench import cli
from tableclean_suite.bench.cli import EXIT_INTERRUPTED, EXIT_USAGE
from tableclean_suite.bench.config import ConfigError, RunConfig, defaults, field_docs

#: Above this estimated size ``curves.csv`` keeps every k-th iteration (and says so in config.json).
CURVES_MAX_BYTES = 20_000_000
_CURVE_BYTES_PER_ROW = 60  # measured on the defaults: ~45-55 bytes per row
#: A cell failed to train (the executor names it).
EXIT_FAILED = 1
#: The program name in messages unless the caller gives one.
PROG = "tableclean-bench run"
#: The paper's spec name: its tables need no task label.
PAPER_TASK = "paper"
#: Resolution of the PNG figures, dots per inch.
FIGURE_DPI = 120

#: Command-line flag of each [`RunConfig`][tableclean_suite.bench.config.RunConfig] field not set by ``--field-name``.
FLAGS = {"sweeps": "--no-sweeps", "figures": "--no-figures", "progress": "--no-progress",
         "literature": "--no-literature"}


def flag_of(field: str) -> str:
    """The command-line flag that sets ``field`` of [`RunConfig`][tableclean_suite.bench.config.RunConfig]."""
    return FLAGS.get(field, "--" + field.replace("_", "-"))


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line; defaults and help texts come from [`RunConfig`][tableclean_suite.bench.config.RunConfig]."""
    from tableclean_suite.bench.config import backend_names
    from tableclean_suite.learners import exploration_names, learner_names
    from tableclean_suite.rewards import reward_pattern_names
    from tableclean_suite.task import task_spec_names

    docs, default = field_docs(), defaults()
    learners, rewards = ", ".join(learner_names()), ", ".join(reward_pattern_names())

    def helped(field: str, extra: str = "") -> str:
        text = docs.get(field, "") + (f" Allowed: {extra}." if extra else "")
        value = default[field]
        if value is not None and not isinstance(value, bool):
            text += f" (default: {' '.join(map(str, value)) if isinstance(value, tuple) else value})"
        return text.replace("%", "%%")

    parser = cli.command_parser(
        prog, "Reproduce the paper's Tables 3-4 and Figures 3-7 (task-level RL for table cleaning). "
              "List flags take space- or comma-separated values (--rewards r1 r2 or --rewards r1,r2).")

    def add(group, field: str, extra: str = "", **options):
        group.add_argument(flag_of(field), dest=field, default=argparse.SUPPRESS,
                           help=helped(field, extra), **options)

    def add_list(group, field: str, extra: str = "", kind=cli.name_list):
        add(group, field, extra, nargs="+", type=kind, metavar=field[:-1].upper() if field.endswith("s") else "VALUE")

    def add_switch(group, field: str, help_text: str):
        group.add_argument(flag_of(field), dest=field, action="store_const", const=not default[field],
                           default=argparse.SUPPRESS, help=help_text)

    grid = parser.add_argument_group("experiment grid")
    add_list(grid, "learners", learners)
    add_list(grid, "rewards", rewards)
    for field, kind in (("runs", int), ("iterations", int), ("alpha", float), ("gamma", float),
                        ("epsilon", float), ("max_itr", int)):
        add(grid, field, type=kind)
    cli.add_seed_argument(grid, "the runs, the bootstraps and the comparisons", default=argparse.SUPPRESS)
    learning = parser.add_argument_group("learner settings (every cell)")
    add(learning, "exploration", ", ".join(exploration_names()), metavar="NAME[:KEY=VALUE,...]")
    add(learning, "q_init", type=float)
    add(learning, "learner_options", metavar="JSON|KEY=VALUE,...")
    literature = parser.add_argument_group("Cruz et al.'s methods run here (Table 4)")
    add(literature, "literature_reward", rewards)
    add_switch(literature, "literature", "do not train them")
    sweeps = parser.add_argument_group("alpha/gamma sweeps (Figures 6-7)")
    add_list(sweeps, "alpha_sweep", kind=cli.number_list)
    add_list(sweeps, "gamma_sweep", kind=cli.number_list)
    add(sweeps, "sweep_reward", rewards)
    add(sweeps, "sweep_learner", learners)
    add_switch(sweeps, "sweeps", "skip the sweeps")
    task = parser.add_argument_group("task model and metrics")
    cli.add_task_argument(task, default=argparse.SUPPRESS,
                          help=helped("task", f"{', '.join(task_spec_names())}, or a path to a .json spec"))
    add(task, "start", metavar="MODE")
    add(task, "ineffective", metavar="MODE")
    for field in ("threshold", "plateau_fraction", "settle_tolerance", "support_fraction"):
        add(task, field, type=float)
    statistics = parser.add_argument_group("statistics")
    add(statistics, "bootstrap_samples", type=int)
    add(statistics, "confidence", type=float)
    add(statistics, "analysis", metavar="KIND")
    add(statistics, "analysis_episodes", type=int, metavar="N")
    backend = parser.add_argument_group("backend")
    add(backend, "backend", ", ".join(backend_names()), metavar="NAME")
    add(backend, "transitions", metavar="PATH")
    cli.add_executor_arguments(backend, "cells", suppress=True,
                               helps={field: helped(field) for field in ("workers", "executor", "ray_address")})
    output = parser.add_argument_group("output")
    cli.add_out_argument(output, cli.DIRECTORY, argparse.SUPPRESS, helped("out"))
    add_switch(output, "figures", "do not draw the PNG figures")
    output.add_argument("--fresh", dest="fresh", action="store_true", default=argparse.SUPPRESS,
                        help=docs.get("fresh", ""))
    add_switch(output, "progress", "no progress bar on stderr")
    output.add_argument("--describe", action="store_true",
                        help="print the task model analysis (states, Table 1 mapping, Table 2, learners) and exit")
    return parser


def parse_args(argv=None, prog: str | None = None) -> argparse.Namespace:
    """Parse and validate the command line into a namespace with ``config`` (a
    [`RunConfig`][tableclean_suite.bench.config.RunConfig]), ``describe`` and ``parser``; a bad flag
    or value exits 2 with a message naming it and what is allowed."""
    parser, namespace = cli.parse_command(build_parser, argv, prog or PROG)  # plugins imported before names are checked
    parsed = vars(namespace)
    describe = parsed.pop("describe")
    for field in ("learners", "rewards", "alpha_sweep", "gamma_sweep"):  # each value a comma list
        if field in parsed:
            parsed[field] = [item for value in parsed[field] for item in value]
    try:
        config = RunConfig(**parsed)
    except ConfigError as error:
        parser.error(error.message_for(flag_of(error.field)))
    return argparse.Namespace(config=config, describe=describe, parser=parser)


def _manifest(config: RunConfig, model, transitions, grid_run, stride: int, elapsed: float) -> dict:
    """The contents of ``config.json`` ([`publish`][tableclean_suite.bench.outputs.publish] adds ``run_id``
    and ``files``)."""
    import numpy
    import pandas

    import tableclean_suite
    from tableclean_suite.bench import outputs, paper_data, tables

    return {
        "args": config.to_json(),
        "argv": sys.argv[1:],
        "package": "tableclean_suite",
        "package_version": tableclean_suite.__version__,
        "timestamp": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "paper": paper_data.PAPER_REFERENCE,
        "model": repr(model),
        "transitions_sha256": outputs.sha256_file(config.transitions) if transitions is not None else None,
        "cells": {"trained": grid_run.trained, "resumed": grid_run.resumed},
        "seconds": {"total": round(elapsed, 3), "training": round(grid_run.train_seconds, 3),
                    "metrics": round(grid_run.metrics_seconds, 3)},
        "curves_csv": {"metrics": list(tables.CURVE_METRICS), "iteration_stride": stride},
        "versions": {"python": platform.python_version(), "numpy": numpy.__version__,
                     "pandas": pandas.__version__},
    }


def run(args) -> int:
    """[`train_and_publish`][tableclean_suite.bench.run.train_and_publish] holding ``--out``'s lock
    (a second run into the same folder exits 2), with OpenBLAS on one thread."""
    import numpy  # noqa: F401  (loads the OpenBLAS whose threads single_blas_thread sets)

    from tableclean_suite.bench import outputs
    from tableclean_suite.executors.blas import single_blas_thread

    problem = outputs.check_publishable(args.config.out, folders=("cells",))
    if problem:
        print(f"{args.parser.prog}: error: --out {problem}", file=sys.stderr)
        return EXIT_USAGE
    with outputs.output_lock(args.config.out), single_blas_thread():
        return train_and_publish(args)


def train_and_publish(args) -> int:
    """Train/load the grid, print the tables, write files and figures; returns the exit code."""
    from tableclean_suite.bench import derived, experiments, outputs
    from tableclean_suite.executors import MissingRayError, TaskFailedError
    from tableclean_suite.learners import CorruptTableError

    started = time.perf_counter()
    config: RunConfig = args.config
    out = Path(config.out)
    model = config.task_model()
    try:
        transitions = config.transition_table(model)
    except (OSError, CorruptTableError, ValueError) as error:
        args.parser.error(f"--transitions {config.transitions!r}: {error}")
    executor = cell_executor(config)
    if executor is None and config.workers is not None and config.backend != "physics":
        import numba

        numba.set_num_threads(min(config.workers, numba.config.NUMBA_NUM_THREADS))
    grid = experiments.config_grid(config)
    store = experiments.CellStore(out / "cells")
    try:
        with executor if executor is not None else contextlib.nullcontext():
            grid_run = experiments.run_grid(grid, config, model, store, transitions, executor)
    except experiments.CellFileError as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except (MissingRayError, ConnectionError) as error:
        print(f"{args.parser.prog}: error: --executor {config.executor}: {error}", file=sys.stderr)
        return EXIT_USAGE
    except TaskFailedError as error:
        print(f"error: {error}; finished cells are saved in {store.root}", file=sys.stderr)
        return EXIT_FAILED
    except KeyboardInterrupt:
        print(f"\ninterrupted: finished cells are saved in {store.root}; rerun the same command to resume",
              file=sys.stderr)
        return EXIT_INTERRUPTED
    from tableclean_suite.bench import statistics, tables

    cells = len(experiments.unique_cells(grid))
    print(f"cells: {cells} distinct ({len(grid)} table rows); resumed {grid_run.resumed} cells, trained "
          f"{grid_run.trained} (training {grid_run.train_seconds:.2f} s, metrics {grid_run.metrics_seconds:.2f} s)\n"
          f"  cell files: {store.root}")

    records, curves = experiments.cell_records(grid, grid_run.summaries, grid_run.statistics,
                                             config.settle_tolerance, grid_run.plans)
    paper_task = tables.is_paper_task(model)
    table3 = tables.table3(records, compare_with_paper=paper_task)
    table4 = tables.table4(table3, paper_task=paper_task)
    rows = len(records) * len(tables.CURVE_METRICS) * config.iterations
    stride = max(1, math.ceil(rows * _CURVE_BYTES_PER_ROW / CURVES_MAX_BYTES))
    survival = all(statistics.NOT_LEARNED in curve_set for curve_set in curves)  # the runs recorded learning times
    figure_frame = tables.curves_long(records, curves, (*tables.CURVE_METRICS, statistics.NOT_LEARNED)
                                      if survival and config.figures else tables.CURVE_METRICS, stride)
    curves_frame = figure_frame[figure_frame["metric"].isin(tables.CURVE_METRICS)]
    results = derived.derive(  # from cells/derived/ when it holds them, else computed and stored there
        store.root / "derived", grid_run.comparison_cells(m.cell for m in grid if m.experiment == "main"),
        config.confidence, config.bootstrap_samples, config.seed, figure_frame if config.figures else None, table3,
        plateau_fraction=config.plateau_fraction, dpi=FIGURE_DPI, read=not config.fresh)
    comparisons, figures = results.comparisons, results.figures
    print(results.summary())

    writers = {
        "table3.csv": lambda path: table3.to_csv(path, index=False),
        "table4.csv": lambda path: table4.to_csv(path, index=False),
        "comparisons.csv": lambda path: comparisons.to_csv(path, index=False),
        "curves.csv": lambda path: path.write_text(tables.csv_text(curves_frame), encoding="utf-8", newline=""),
    }
    writers.update({name: (lambda path, png=png: path.write_bytes(png)) for name, png in figures.items()})
    elapsed = time.perf_counter() - started
    manifest = _manifest(config, model, transitions, grid_run, stride, elapsed)
    try:
        written = outputs.publish(out, writers, manifest)
    except KeyboardInterrupt:
        print(f"\ninterrupted while writing {out}: it has no {outputs.MANIFEST}, so it describes no run; "
              "rerun the same command (cells are saved) to write it", file=sys.stderr)
        return EXIT_INTERRUPTED
    _print_tables(config, table3, table4, model.spec.name, paper_task, comparisons)
    print("\nwritten:")
    for path in written:
        print(f"  {path}")
    print(f"  {store.root}/ ({cells} cell files)")
    if stride > 1:
        print(f"  (curves.csv keeps every {stride}th iteration to stay under {CURVES_MAX_BYTES // 1_000_000} MB)")
    print(f"done in {time.perf_counter() - started:.1f} s")
    return 0


def cell_executor(config: RunConfig):
    """The executor that trains the run's cells: a [`RayExecutor`][tableclean_suite.executors.ray_executor.RayExecutor]
    for ``--executor ray``, a [`LocalExecutor`][tableclean_suite.executors.local.LocalExecutor] of
    ``--workers`` processes when that is above 1 and the backend is not physics, else None (this process)."""
    from tableclean_suite.executors import make_executor

    if config.executor == "local" and (config.workers in (None, 1) or config.backend == "physics"):
        return None
    return make_executor(config.executor, workers=config.workers, address=config.ray_address)


def _print_tables(config: RunConfig, table3, table4, task_name: str, paper_task: bool, comparisons=None) -> None:
    """Print Tables 3-4, the comparisons and sweeps, each at most `tables.PRINT_WIDTH`
    characters wide; ``task_name``: the spec's name (not its file's)."""
    import pandas as pd

    from tableclean_suite.bench import tables
    from tableclean_suite.bench.statistics import EQUIVALENCE_MARGINS

    level = f"{100 * config.confidence:g}%"
    with pd.option_context("display.width", tables.PRINT_WIDTH, "display.max_columns", 50, "display.max_rows", 500):
        on_task = "" if task_name == PAPER_TASK else f" on task {task_name!r}"
        print(f"\nTable 3: learning speed per reward pattern{on_task} (alpha = {config.alpha:g}, gamma = "
              f"{config.gamma:g}, epsilon = {config.epsilon:g},\n  {config.runs} runs x {config.iterations} "
              f"iterations, {config.backend} backend).  Every column is in table3.csv.")
        print("\nTable 3a: per-run learning time (iterations).")
        print(f"  learning time = per run, the first iteration from which its greedy policy is optimal (a shortest "
              f"plan from every start\n  state) and stays so to the end of the budget ({config.iterations} "
              f"iterations); runs not optimal at the end are censored at the\n  budget (Kaplan-Meier).  "
              f"median/quartiles [{level} "
              f"CI] = where the pointwise {level} log-log band of the survival\n  curve crosses 1/2 (inf: beyond the "
              f"budget); RMST = mean of min(time, budget) [percentile bootstrap over runs,\n  "
              f"{config.bootstrap_samples} resamples, widened for runs a sample may lack]; censored % "
              "[Clopper-Pearson].  Each interval targets\n  the value over unlimited runs.")
        print(tables.display_learning_time(table3).to_string())
        print(f"\nTable 3b: plateaus = {tables.plateaus_kind(table3)} asymptotes of each run's final behaviour (greedy "
              f"policy under the exploration),\n  mean over runs [{level} percentile bootstrap over runs, widened for "
              "runs a sample may lack; Clopper-Pearson\n  where each run is 0 or 1]; greedy success = the final "
              "greedy policies (epsilon = 0); never terminal = runs that\n  never reached the terminal state; "
              f"drift = mean change of a run's success asymptote over the window's last quarter;\n  settled = drift <= "
              f"{100 * config.settle_tolerance:g} pp.")
        if paper_task:
            print("  'paper' = the paper's Table 3 (Q-learning only).")
        print(tables.display_plateaus(table3).to_string())
        print(f"\nTable 3c: the paper's definitions, read off the mean curves over runs: iterations (itr) and "
              f"episodes (eps) to\n  average-reward convergence (conv.) and to the first touch of "
              f"{100 * config.threshold:g}% of the success plateau (touch), the maximum\n  average reward (max avg r); "
              "the paper's values in parentheses.  No intervals: such a reading is biased and its\n  target moves "
              "with the number of runs.  avg r plateau: per-run asymptotes, mean over runs."
              + ("" if paper_task else f"  Task {task_name!r} is not the paper's: no paper values."))
        print(tables.display_paper_definitions(table3).to_string())
        if comparisons is not None and len(comparisons):
            margins = ", ".join(f"{score} {margin:g}" for score, margin in EQUIVALENCE_MARGINS.items())
            print(f"\nProbability of improvement (a run of X beats a run of Y by more than the margin; pairs within "
                  f"it\ncount half; 0.5 = no difference; censored learning times count as the budget;\n  margins: "
                  f"{margins}).\n  {len(comparisons)} comparisons, each with its own {level} stratified bootstrap "
                  "interval over runs (not adjusted for multiplicity):")
            print(tables.display_comparisons(comparisons).to_string(index=False))
        sweeps = tables.display_sweeps(table3)
        if len(sweeps):
            print("\nSweeps (Figures 6-7; the paper gives no table for them; median = per-run learning time, first "
                  "touch = the paper's):")
            print(sweeps.to_string(index=False))
        quoted = ("the paper's Table 4 verbatim" if paper_task else
                  f"the literature's rows of the paper's Table 4 (its own '{tables.PAPER_OWN_ROWS}' rows are on the "
                  "paper's task, so not beside this one)")
        print(f"\nTable 4: comparison with the literature{on_task}. 'run here' = trained by this run on this task "
              f"(reward,\n  alpha, gamma, epsilon as above; [..] = {level} intervals; episodes are the paper's "
              f"mean-curve readings);\n  'quoted' = {quoted} ([7], [8]: measured on other tasks).")
        shown = tables.display_table4(table4)
        width = max(map(len, shown["method"]))
        print(shown.to_string(index=False, formatters={"method": f"{{:<{width}}}".format}))


def main(argv=None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``, ``prog`` in messages); returns the exit code."""
    args = parse_args(argv, prog)
    try:
        if args.describe:
            from tableclean_suite.bench.describe import describe

            print(describe(args.config.task_model(), epsilon=args.config.epsilon, max_itr=args.config.max_itr))
            return 0
        return run(args)
    except BrokenPipeError:  # e.g. piped into `head`; the files are already written
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("run", "python -m tableclean_suite.bench.run"))
