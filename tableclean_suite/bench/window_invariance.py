"""``tableclean-bench window-invariance``: do Table 3's iteration figures move with the window?

    tableclean-bench window-invariance                      # 4000 vs 12000 iterations
    tableclean-bench window-invariance --windows 2000 6000 --learners q_learning --runs 200

Runs ``tableclean-bench run`` (no sweeps, no figures; other flags are passed on) once per window
into ``OUT/w<iterations>/`` (a rerun resumes) and compares the main rows of the two ``table3.csv``:
a figure's change is ``|long - short| / short``.  Cells settled in both windows (`tableclean_suite.settling`)
should not move; those moving by more than ``--goal`` are listed, and the unsettled cells apart.
Writes ``OUT/window_invariance.csv`` (one row per cell and figure).  Exit code 0 after a
comparison, whatever it shows; 2 on bad flags.
"""
from __future__ import annotations

import contextlib
import math
import sys
from pathlib import Path

import pandas as pd

from tableclean_suite.bench import cli, outputs, run
from tableclean_suite.bench.tables import PRINT_WIDTH, main_rows

#: Windows compared by default (iterations): the paper's and three times as long.
DEFAULT_WINDOWS = (4000, 12000)
DEFAULT_THRESHOLD = 0.05
#: Run-command flags this command sets itself, and those that would write no Table 3.
OWN_RUN_FLAGS = ("--iterations", "--out", "--sweeps", "--no-sweeps", "--figures", "--no-figures")
NO_TABLE_FLAGS = ("--describe",)
RESULT_FILE = "window_invariance.csv"
PROG = "tableclean-bench window-invariance"
DEFAULT_OUT = "results/window_invariance"
#: Table 3's iteration figures compared (columns of ``table3.csv``).
FIGURES = ("learning_time_median", "reward_convergence_iterations", "reward_convergence_episodes",
           "max_success_iterations", "max_success_episodes")


def relative_change(short: float, long: float) -> float:
    """``|long - short| / |short|``; 0 if both are missing ("not reached"), inf if one is or short is 0."""
    missing = [value is None or pd.isna(value) for value in (short, long)]
    if all(missing) or (not any(missing) and short == long):  # equal, infinities (beyond both windows) included
        return 0.0
    if any(missing) or short == 0 or math.isinf(short):
        return math.inf
    return abs(float(long) - float(short)) / abs(float(short))


def figure_changes(short: pd.DataFrame, long: pd.DataFrame) -> pd.DataFrame:
    """One row per (learner, reward) cell of both main-row frames and figure of `FIGURES`: ``cell, figure,
    short, long, change, settled`` (settled in both); ValueError when they have no cell in common."""
    keys = ["learner", "reward"]
    both = short.merge(long, on=keys, suffixes=("_short", "_long"))
    if both.empty:
        raise ValueError("the two tables have no (learner, reward) cell in common")
    rows = []
    for _, cell in both.iterrows():
        settled = all(_true(cell[f"settled_{side}"]) for side in ("short", "long"))
        for figure in FIGURES:
            a, b = cell[f"{figure}_short"], cell[f"{figure}_long"]
            rows.append({"cell": f"{cell['learner']} {cell['reward']}", "figure": figure, "short": a, "long": b,
                         "change": relative_change(a, b), "settled": settled})
    return pd.DataFrame(rows)


def _true(value) -> bool:
    """A ``settled`` entry read back from CSV: True, "True" or 1; empty (not measured) is False."""
    return not pd.isna(value) and str(value).strip().lower() in ("true", "1", "1.0")


def build_parser(prog: str = PROG):
    """The command's own options; any other flag is the run command's (``--task``, ``--seed``, ...)."""
    parser = cli.command_parser(prog, __doc__.split("\n")[0],
                                epilog="Any other flag is passed to the run command for both windows "
                                       "(e.g. --task, --seed, --learners, --runs).")
    parser.add_argument("--windows", type=int, nargs=2, default=DEFAULT_WINDOWS, metavar=("SHORT", "LONG"),
                        help="the two training windows, iterations (SHORT < LONG). (default: %(default)s)")
    parser.add_argument("--goal", type=cli.number_type(float, lambda v: 0 < v < 1, "a fraction in (0, 1)"),
                        default=DEFAULT_THRESHOLD, metavar="FRACTION",
                        help="list the settled cells whose figures move by more than this fraction, in (0, 1). "
                             "(default: %(default)s)")
    cli.add_out_argument(parser, cli.DIRECTORY, DEFAULT_OUT, "output directory")
    return parser


def parse_args(argv=None, prog: str | None = None):
    """``(args, passthrough)``: this command's options and the flags passed on to the run command."""
    parser, args, passthrough = cli.parse_command(build_parser, argv, prog or PROG, known=True)
    args.prog = parser.prog
    short, long = args.windows
    if not 1 <= short < long:
        parser.error(f"--windows: need 1 <= SHORT < LONG, got {short} {long}")
    own = [flag for flag in passthrough if flag.split("=")[0] in OWN_RUN_FLAGS]
    if own:
        parser.error(f"{', '.join(own)}: set by this command (use --windows and --out)")
    no_table = [flag for flag in passthrough if flag.split("=")[0] in NO_TABLE_FLAGS]
    if no_table:
        parser.error(f"{', '.join(no_table)}: writes no Table 3 to compare (use the run command for it)")
    passthrough += ["--plugins", ",".join(args.plugins)] if args.plugins else []
    passthrough += ["--verbose"] if args.verbose else []
    cli.check_out(parser, args.out, "window-invariance")
    return args, passthrough


def run_window(iterations: int, out: Path, passthrough: list[str], prog: str = PROG) -> pd.DataFrame:
    """The main rows of Table 3 of the run command at ``iterations`` into ``out`` (its stdout in
    ``out/stdout.txt``); ``SystemExit`` with its exit code if it fails."""
    out.mkdir(parents=True, exist_ok=True)
    argv = [*passthrough, "--iterations", str(iterations), "--out", str(out), "--no-sweeps", "--no-figures",
            "--no-progress"]
    log = out / "stdout.txt"
    with open(log, "w", encoding="utf-8") as handle, contextlib.redirect_stdout(handle):
        code = run.main(argv, prog=prog)
    if code != 0:
        print(f"the run command at {iterations} iterations exited with {code}; its output: {log}", file=sys.stderr)
        raise SystemExit(code)
    return main_rows(pd.read_csv(out / "table3.csv"))


def cells_above(changes: pd.DataFrame, threshold: float) -> pd.Series:
    """Each settled cell of ``changes`` whose largest change exceeds ``threshold`` (a fraction): that change
    by cell, largest first."""
    settled = changes[changes["settled"]]
    largest = settled.groupby("cell", sort=False)["change"].max()
    return largest[largest > threshold].sort_values(ascending=False, kind="stable")


def summary_lines(changes: pd.DataFrame, threshold: float, windows) -> list[str]:
    """One line for the settled cells (largest change, cells moving by more than ``threshold``) and one for
    the others (each cell's largest change)."""
    short, long = windows
    settled = changes[changes["settled"]]
    lines = []
    if len(settled):
        worst = settled.loc[settled["change"].idxmax()]
        above = cells_above(changes, threshold)
        listed = ", ".join(f"{cell} ({_percent(value)})" for cell, value in above.items()) or "none"
        lines.append(f"settled cells ({settled['cell'].nunique()}): largest change {_percent(worst['change'])} "
                     f"({worst['cell']}, {worst['figure']}); cells with a figure moving by more than "
                     f"{_percent(threshold)}: {listed}")
    else:
        lines.append("no cell settled in both windows")
    unsettled = changes[~changes["settled"]]
    if len(unsettled):
        worst = unsettled.groupby("cell")["change"].max()
        listed = ", ".join(f"{cell} (up to {_percent(value)})" for cell, value in worst.items())
        lines.append(f"not settled in both windows ({len(worst)}; plateau still moving between {short} and {long} "
                     f"iterations, figures depend on the window): {listed}")
    return lines


def _percent(value: float) -> str:
    return "inf" if math.isinf(value) else f"{100 * value:.1f} %"


def main(argv=None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    args, passthrough = parse_args(argv, prog)
    out = Path(args.out)
    short, long = (run_window(w, out / f"w{w}", passthrough, args.prog) for w in args.windows)  # SystemExit: failed
    changes = figure_changes(short, long)
    outputs.publish(out, {RESULT_FILE: lambda path: changes.to_csv(path, index=False)},
                    {"args": outputs.arguments(args), "passthrough": passthrough}, command="window-invariance")
    shown = changes.assign(change=[_percent(v) for v in changes["change"]])
    print(f"Table 3's iteration figures at {args.windows[0]} and {args.windows[1]} iterations ({', '.join(FIGURES)}):")
    print(shown.to_string(index=False, na_rep="not reached", float_format=lambda v: f"{v:.1f}",
                          line_width=PRINT_WIDTH))
    for line in summary_lines(changes, args.goal, args.windows):
        print(line)
    print(f"written: {out / RESULT_FILE}")
    return 0


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("window-invariance", "python -m tableclean_suite.bench.window_invariance"))
