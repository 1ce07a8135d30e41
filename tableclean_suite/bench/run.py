"""``python -m benchmarks.run``: reproduce the paper's Tables 3-4 and Figures 3-7.

    python -m benchmarks.run                      # defaults reproduce the paper (~seconds)
    python -m benchmarks.run --describe           # the task model, Table 1 mapping, Table 2
    python -m benchmarks.run --runs 200 --rewards r2,r4 --no-sweeps --out results/quick

Trains every learner x reward at (alpha, gamma) ("main"), plus the sweep learner x
sweep reward at each alpha of ``--alpha-sweep`` and each gamma of ``--gamma-sweep``,
prints Table 3 (ours beside the paper's), the sweep table and Table 4, and writes to
``--out``: ``table3.csv``, ``table4.csv``, ``curves.csv``, ``config.json``, the figures
``fig3..fig7*.png`` and ``cells/`` (one file per trained cell; a rerun with the same
settings loads them instead of retraining — ``--fresh`` retrains).

This is the only module of the harness that touches the filesystem.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import platform
import sys
import time
from pathlib import Path

#: Above this estimated size ``curves.csv`` keeps every k-th iteration (and says so in config.json).
CURVES_MAX_BYTES = 20_000_000
_CURVE_BYTES_PER_ROW = 60  # measured on the defaults: ~45-55 bytes per row
EXIT_USAGE = 2


def build_parser() -> argparse.ArgumentParser:
    from tableclean_suite.learners import BACKENDS

    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.run",
        description="Reproduce the paper's Tables 3-4 and Figures 3-7 (task-level RL for table cleaning).",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    grid = parser.add_argument_group("experiment grid")
    grid.add_argument("--learners", default="q_learning,sarsa", help="comma-separated registered learners")
    grid.add_argument("--rewards", default="r1,r2,r3,r4", help="comma-separated registered reward patterns")
    grid.add_argument("--runs", type=int, default=1000, help="independent runs per cell (averaged)")
    grid.add_argument("--iterations", type=int, default=4000, help="environment steps per run")
    grid.add_argument("--alpha", type=float, default=0.3, help="learning rate of the main cells, in (0, 1]")
    grid.add_argument("--gamma", type=float, default=0.3, help="discount of the main cells, in [0, 1]")
    grid.add_argument("--epsilon", type=float, default=0.1, help="epsilon-greedy exploration rate, in [0, 1]")
    grid.add_argument("--max-itr", type=int, default=500, help="iterations after which an episode is truncated")
    grid.add_argument("--seed", type=int, default=0, help="base seed (run i uses the key of (seed, i))")
    sweeps = parser.add_argument_group("alpha/gamma sweeps (Figures 6-7)")
    sweeps.add_argument("--alpha-sweep", default="0.3,0.5,0.7,0.9", help="alphas, at gamma = --gamma")
    sweeps.add_argument("--gamma-sweep", default="0.3,0.5,0.7,0.9", help="gammas, at alpha = --alpha")
    sweeps.add_argument("--sweep-reward", default="r4", help="reward pattern of the sweeps")
    sweeps.add_argument("--sweep-learner", default="q_learning", help="learner of the sweeps")
    sweeps.add_argument("--no-sweeps", action="store_true", help="skip the sweeps")
    task = parser.add_argument_group("task model and metrics")
    task.add_argument("--start", choices=("fixed", "uniform_unclean"), default="fixed",
                      help="episode start: Table 1 state 4, or uniform over the four both-unclean layouts")
    task.add_argument("--ineffective", choices=("ineffective", "improper"), default="ineffective",
                      help="how a pick with nothing to pick / a place with nothing held counts")
    task.add_argument("--threshold", type=float, default=0.95,
                      help="fraction of the plateau that counts as reached, in (0, 1]")
    task.add_argument("--plateau-fraction", type=float, default=0.25,
                      help="final fraction of the window averaged as the plateau, in (0, 1]")
    backend = parser.add_argument_group("backend")
    backend.add_argument("--backend", choices=BACKENDS, default="symbolic",
                         help="symbolic model, calibrated transition table, or skills in MuJoCo physics")
    backend.add_argument("--transitions", metavar="PATH", default=None,
                         help="transition table JSON (needed by --backend calibrated)")
    backend.add_argument("--workers", type=int, default=None,
                         help="processes (physics backend) or compiled threads (other backends)")
    output = parser.add_argument_group("output")
    output.add_argument("--out", default="results", help="output directory")
    output.add_argument("--no-figures", action="store_true", help="do not draw the PNG figures")
    output.add_argument("--fresh", action="store_true", help="retrain every cell, ignoring saved ones")
    output.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    output.add_argument("--describe", action="store_true",
                        help="print the task model analysis (states, Table 1 mapping, Table 2, learners) and exit")
    return parser


def _names(parser, flag: str, text: str, allowed: list[str]) -> list[str]:
    names = list(dict.fromkeys(n.strip() for n in text.split(",") if n.strip()))
    if not names:
        parser.error(f"{flag}: give at least one name; allowed: {', '.join(allowed)}")
    unknown = [n for n in names if n not in allowed]
    if unknown:
        parser.error(f"{flag}: unknown {', '.join(map(repr, unknown))}; allowed: {', '.join(allowed)}")
    return names


def _floats(parser, flag: str, text: str) -> list[float]:
    values = []
    for item in (t.strip() for t in text.split(",") if t.strip()):
        try:
            values.append(float(item))
        except ValueError:
            parser.error(f"{flag}: {item!r} is not a number")
    if not values:
        parser.error(f"{flag}: give at least one value")
    return list(dict.fromkeys(values))


def parse_args(argv=None) -> argparse.Namespace:
    """Parse and validate; any bad flag or value exits with code 2 and a one-line message."""
    from tableclean_suite.learners import learner_names, validate_hyperparameters
    from tableclean_suite.rewards import reward_pattern_names

    parser = build_parser()
    args = parser.parse_args(argv)
    learners, rewards = learner_names(), reward_pattern_names()
    args.learner_list = _names(parser, "--learners", args.learners, learners)
    args.reward_list = _names(parser, "--rewards", args.rewards, rewards)
    args.sweep_learner = _names(parser, "--sweep-learner", args.sweep_learner, learners)[0]
    args.sweep_reward = _names(parser, "--sweep-reward", args.sweep_reward, rewards)[0]
    args.alpha_values = _floats(parser, "--alpha-sweep", args.alpha_sweep)
    args.gamma_values = _floats(parser, "--gamma-sweep", args.gamma_sweep)
    hyper = dict(runs=args.runs, iterations=args.iterations, alpha=args.alpha, gamma=args.gamma,
                 epsilon=args.epsilon, max_itr=args.max_itr, seed=args.seed)
    try:
        validate_hyperparameters(**hyper)
    except ValueError as error:
        parser.error(f"--{str(error).replace('_', '-')}")
    for flag, key, values in (("--alpha-sweep", "alpha", args.alpha_values),
                              ("--gamma-sweep", "gamma", args.gamma_values)):
        for value in values:
            try:
                validate_hyperparameters(**{**hyper, key: value})
            except ValueError as error:
                parser.error(f"{flag}: {error}")
    for flag, value in (("--threshold", args.threshold), ("--plateau-fraction", args.plateau_fraction)):
        if not (math.isfinite(value) and 0.0 < value <= 1.0):
            parser.error(f"{flag} must be in (0, 1], got {value!r}")
    if args.workers is not None and args.workers < 1:
        parser.error(f"--workers must be >= 1, got {args.workers}")
    if args.backend == "calibrated" and args.transitions is None:
        parser.error("--backend calibrated needs --transitions PATH (a table from benchmarks.calibrate)")
    if args.backend != "calibrated" and args.transitions is not None:
        parser.error("--transitions is only used with --backend calibrated")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        parser.error(f"--out {args.out!r} exists and is not a directory")
    args.parser = parser
    return args


def _model(args):
    from tableclean_suite.task import TaskModel

    return TaskModel(ineffective=args.ineffective, start=args.start)


def _load_transitions(args, model):
    """The calibrated table, or exit 2 with a clear message if it cannot be read."""
    from tableclean_suite.learners import CorruptTableError, TransitionTable

    try:
        return TransitionTable.from_json(args.transitions, model)
    except (OSError, CorruptTableError, ValueError) as error:
        args.parser.error(f"--transitions {args.transitions!r}: {error}")


def _curves_stride(rows_per_iteration: int, iterations: int) -> int:
    estimate = rows_per_iteration * iterations * _CURVE_BYTES_PER_ROW
    return max(1, math.ceil(estimate / CURVES_MAX_BYTES))


def _config_json(args, settings, grid_run, stride: int, elapsed: float) -> dict:
    import numpy
    import pandas

    import tableclean_suite
    from tableclean_suite.bench import paper_data

    options = {k: v for k, v in vars(args).items() if k not in ("parser",)}
    return {
        "args": options,
        "argv": sys.argv[1:],
        "package": "tableclean_suite",
        "package_version": tableclean_suite.__version__,
        "timestamp": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "paper": paper_data.PAPER_REFERENCE,
        "transitions_sha256": settings.transitions_sha256,
        "cells": {"trained": grid_run.trained, "resumed": grid_run.resumed},
        "seconds": {"total": round(elapsed, 3), "training": round(grid_run.train_seconds, 3),
                    "metrics": round(grid_run.metrics_seconds, 3)},
        "curves_csv": {"metrics": ["success", "average_reward", "episodes"], "iteration_stride": stride},
        "versions": {"python": platform.python_version(), "numpy": numpy.__version__,
                     "pandas": pandas.__version__},
    }


def run(args) -> int:
    """Train/load the grid, print the tables, write files and figures; returns the exit code."""
    from tableclean_suite.bench import experiments, tables

    started = time.perf_counter()
    model = _model(args)
    transitions = _load_transitions(args, model) if args.backend == "calibrated" else None
    if args.workers is not None and args.backend != "physics":
        import numba

        numba.set_num_threads(min(args.workers, numba.config.NUMBA_NUM_THREADS))
    settings = experiments.Settings(
        runs=args.runs, iterations=args.iterations, epsilon=args.epsilon, max_itr=args.max_itr, seed=args.seed,
        start=args.start, ineffective=args.ineffective, backend=args.backend, transitions=args.transitions,
        transitions_sha256=experiments.file_sha256(args.transitions) if args.transitions else None,
        threshold=args.threshold, plateau_fraction=args.plateau_fraction, workers=args.workers,
    )
    grid = experiments.build_grid(
        args.learner_list, args.reward_list, args.alpha, args.gamma, args.sweep_learner, args.sweep_reward,
        args.alpha_values, args.gamma_values, sweeps=not args.no_sweeps,
    )
    out = Path(args.out)
    store = experiments.CellStore(out / "cells")
    try:
        grid_run = experiments.run_grid(grid, settings, model, store, transitions, fresh=args.fresh,
                                        progress=not args.no_progress)
    except experiments.CellFileError as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"\ninterrupted: finished cells are saved in {store.root}; rerun the same command to resume",
              file=sys.stderr)
        return 130
    cells = len(experiments.unique_cells(grid))
    print(f"cells: {cells} distinct ({len(grid)} table rows); resumed {grid_run.resumed} cells from {store.root}, "
          f"trained {grid_run.trained} (training {grid_run.train_seconds:.2f} s, "
          f"metrics {grid_run.metrics_seconds:.2f} s)")

    records, curves = experiments.cell_records(grid, grid_run.summaries)
    table3 = tables.table3(records)
    table4 = tables.table4(table3)
    stride = _curves_stride(len(records) * len(tables.CURVE_METRICS), args.iterations)
    curves_frame = tables.curves_long(records, curves, stride=stride)

    out.mkdir(parents=True, exist_ok=True)
    written = []
    table3.to_csv(out / "table3.csv", index=False)
    table4.to_csv(out / "table4.csv", index=False)
    curves_frame.to_csv(out / "curves.csv", index=False, float_format="%.6g")
    written += [out / "table3.csv", out / "table4.csv", out / "curves.csv"]
    if not args.no_figures:
        written += _write_figures(curves_frame, out, args.plateau_fraction)
    elapsed = time.perf_counter() - started
    (out / "config.json").write_text(json.dumps(_config_json(args, settings, grid_run, stride, elapsed), indent=2))
    written.append(out / "config.json")
    _print_tables(args, table3, table4)
    print("\nwritten:")
    for path in written:
        print(f"  {path}")
    print(f"  {store.root}/ ({cells} cell files)")
    if stride > 1:
        print(f"  (curves.csv keeps every {stride}th iteration to stay under {CURVES_MAX_BYTES // 1_000_000} MB)")
    print(f"done in {elapsed:.1f} s")
    return 0


def _print_tables(args, table3, table4) -> None:
    import pandas as pd

    from tableclean_suite.bench import tables

    with pd.option_context("display.width", 200, "display.max_columns", 50, "display.max_rows", 500):
        print(f"\nTable 3: learning speed per reward pattern (alpha = {args.alpha:g}, gamma = {args.gamma:g}, "
              f"epsilon = {args.epsilon:g}, {args.runs} runs x {args.iterations} iterations).")
        print("  'paper' = the paper's Table 3 (Q-learning only); success % = plateau of the success curve.")
        print(tables.display_table3(table3).to_string(na_rep="-"))
        sweeps = tables.display_sweeps(table3)
        if len(sweeps):
            print("\nSweeps (Figures 6-7; the paper gives no table for them):")
            print(sweeps.to_string(index=False, na_rep="-"))
        print("\nTable 4: comparison with the literature (* = quoted from the paper, not run here).")
        shown = tables.display_table4(table4)
        width = max(map(len, shown["methodology"]))
        print(shown.to_string(index=False, formatters={"methodology": f"{{:<{width}}}".format}))


def _write_figures(curves_frame, out: Path, plateau_fraction: float) -> list[Path]:
    import matplotlib.pyplot as plt

    from tableclean_suite.bench import plots

    paths = []
    for stem in plots.available_figures(curves_frame):
        _, builder = plots.PAPER_FIGURES[stem]
        fig, _ = builder(curves_frame, plateau_fraction)
        path = out / f"{stem}.png"
        fig.savefig(path, dpi=120, bbox_inches="tight")
        plt.close(fig)
        paths.append(path)
    return paths


def main(argv=None) -> int:
    args = parse_args(argv)
    try:
        if args.describe:
            from tableclean_suite.bench.describe import describe

            print(describe(_model(args), epsilon=args.epsilon, max_itr=args.max_itr))
            return 0
        return run(args)
    except BrokenPipeError:  # e.g. piped into `head`; the files are already written
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
