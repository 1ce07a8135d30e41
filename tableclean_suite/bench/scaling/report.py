"""The scaling study's report: printed tables and answers, CSV files, the figure and ``config.json``
(each writer writes the path it is given; the pipeline publishes them together)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from tableclean_suite.bench.scaling.family import FIXED_PLAN_FAMILY, PRODUCT_FAMILY, SpecInfo
from tableclean_suite.bench.scaling.statistics import PAPER_ORDER, order_verdict

#: Resolution of the PNG figure, dots per inch.
FIGURE_DPI = 120
#: The figure's iteration axis spans the data times / divided by this factor.
Y_MARGIN = 3.0
#: Marker shapes of the figure's families.
FAMILY_MARKERS = {PRODUCT_FAMILY: "o", FIXED_PLAN_FAMILY: "s"}


def json_safe(value):
    """``value`` with every non-finite float replaced by None (strict JSON)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {key: json_safe(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(item) for item in value]
    return value


def write_figure(path: Path, rows: list[dict], learner: str, fits: dict) -> None:
    """Two rows of panels, one column per gamma, for ``learner``.

    Top: median per-run learning time against states reachable from the start (log-log), one
    colour per reward pattern; filled markers = median reached (error bars: 95 % seeds-then-runs
    bootstrap interval), hollow markers at the window = censored (more than half the runs never
    learned); circles = the product family, squares = the fixed-plan family; dashed = the fitted
    power law where one is reported.  Bottom: the share of censored runs per cell.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import pandas as pd

    frame = pd.DataFrame(rows)
    frame = frame[frame["learner"] == learner].sort_values("reachable_from_start", kind="stable")
    gammas = sorted(set(frame["gamma"]))
    rewards = list(dict.fromkeys(frame["reward"]))
    colours = {reward: f"C{i}" for i, reward in enumerate(rewards)}
    figure, axes = plt.subplots(2, max(1, len(gammas)), figsize=(6.5 * max(1, len(gammas)), 9), squeeze=False)
    for column, gamma in enumerate(gammas):
        top, bottom = axes[0, column], axes[1, column]
        at_gamma = frame[frame["gamma"] == gamma]
        for reward in rewards:
            cells, colour = at_gamma[at_gamma["reward"] == reward], colours[reward]
            for family, marker in FAMILY_MARKERS.items():
                chosen = cells[cells["family"] == family]
                style = "-" if family == PRODUCT_FAMILY else ":"
                reached, censored = chosen[~chosen["censored"]], chosen[chosen["censored"]]
                if len(reached):
                    x, y = (reached[c].to_numpy(dtype=float) for c in ("reachable_from_start", "learning_time"))
                    low, high = (reached[c].to_numpy(dtype=float) for c in ("learning_time_low", "learning_time_high"))
                    high = np.where(np.isfinite(high), high, reached["window"].to_numpy())
                    error = np.clip(np.vstack([y - low, high - y]), 0, None)
                    top.errorbar(x, np.maximum(y, 1.0), yerr=error, marker=marker, linestyle=style, color=colour,
                                 capsize=2, markersize=5)
                if len(censored):
                    top.scatter(censored["reachable_from_start"].to_numpy(dtype=float), list(censored["window"]),
                                marker=marker, facecolors="none", edgecolors=colour, s=40)
                bottom.plot(list(chosen["reachable_from_start"]), list(chosen["censored_share"]), marker=marker,
                            color=colour, linestyle=style)
            fit = fits.get(f"{gamma:g}", {}).get(reward)
            product = cells[cells["family"] == PRODUCT_FAMILY]
            if fit and math.isfinite(fit["exponent"]) and math.isfinite(fit.get("intercept", math.nan)) \
                    and len(product):
                x = product["reachable_from_start"].to_numpy(dtype=float)
                top.plot(x, np.exp(fit["intercept"]) * x ** fit["exponent"], linestyle="--", color=colour, alpha=0.5)
        shown = [max(v, 1.0) for v in at_gamma.loc[~at_gamma["censored"], "learning_time"]] + list(at_gamma["window"])
        if shown:  # the fitted lines may not stretch the axis beyond the data (a steep fit would flatten it)
            top.set_ylim(min(shown) / Y_MARGIN, max(shown) * Y_MARGIN)
        top.plot([], [], color="black", marker="o", linestyle="-", label="product family (N x M)")
        top.plot([], [], color="black", marker="s", linestyle=":", label="fixed plan (8 steps)")
        top.scatter([], [], marker="o", facecolors="none", edgecolors="black", label="censored (at the window)")
        for reward in rewards:
            top.plot([], [], color=colours[reward], label=reward)
        top.set_xscale("log")
        top.set_yscale("log")
        top.set_xlabel("states reachable from the start")
        top.set_ylabel("median per-run learning time (iterations)")
        top.set_title(f"{learner}, gamma = {gamma:g}")
        top.legend(fontsize=7, loc="upper left")
        bottom.set_xscale("log")
        bottom.set_ylim(-0.05, 1.05)
        bottom.set_xlabel("states reachable from the start")
        bottom.set_ylabel("share of runs censored at the window")
    figure.tight_layout()
    try:
        figure.savefig(path, format="png", dpi=FIGURE_DPI)
    finally:
        plt.close(figure)


def interval_text(value, low, high, digits: int = 0) -> str:
    """``"value [low, high]"``; ``"censored"`` for an infinite or missing value; an infinite top reads
    ``>window``."""
    if value is None or not math.isfinite(value):
        return "censored"
    top = f"{high:.{digits}f}" if math.isfinite(high) else ">window"
    return f"{value:.{digits}f} [{low:.{digits}f}, {top}]"


def _print_table(columns: dict) -> None:
    """``{header: values}`` as a table at most `tables.PRINT_WIDTH` characters wide (pandas wraps
    further columns into a block below)."""
    import pandas as pd

    from tableclean_suite.bench.tables import PRINT_WIDTH

    print(pd.DataFrame(columns).to_string(index=False, line_width=PRINT_WIDTH))


def print_specs(infos: list[SpecInfo]) -> None:
    """The per-spec table: sizes, plan length, exact optimal success, window."""
    _print_table({"spec": [s.name for s in infos], "family": [s.family for s in infos],
                  "N": [s.segments for s in infos], "M": [s.objects for s in infos], "codes": [s.codes for s in infos],
                  "reachable": [s.reachable for s in infos], "from start": [s.reachable_from_start for s in infos],
                  "plan": [s.plan_length for s in infos],
                  "opt.success": [f"{s.optimal_success:.4f}" for s in infos], "window": [s.window for s in infos],
                  "max_itr": [s.max_itr for s in infos]})


def print_cells(rows: list[dict]) -> None:
    """The per-cell table: median learning time with its interval, the share censored, the window
    mean against the optimum and the share of runs that never reached the terminal state (its
    interval and each seed's own median are in ``scaling.csv``)."""
    _print_table({
        "spec": [r["spec"] for r in rows], "gamma": [f"{r['gamma']:g}" for r in rows],
        "learner": [r["learner"] for r in rows], "reward": [r["reward"] for r in rows],
        "median learning time": [interval_text(r["learning_time"], r["learning_time_low"], r["learning_time_high"])
                                 for r in rows],
        "censored": [f"{r['censored_share']:.2f}" for r in rows],
        "window mean / opt": [interval_text(r["success_window_mean"], r["success_window_mean_low"],
                                            r["success_window_mean_high"], 3) + f" / {r['optimal_success']:.3f}"
                              for r in rows],
        "never terminal": [f"{r['never_terminal_share']:.2f}" for r in rows]})


def ordering_report(replicates: dict, infos: list[SpecInfo], learner: str, rewards, gamma: float) -> dict:
    """Per spec, the [`order_verdict`][tableclean_suite.bench.scaling.statistics.order_verdict] of
    ``learner``'s median learning times at ``gamma`` against `PAPER_ORDER` (``replicates``:
    ``{(spec, gamma, learner, reward): (B,) medians}``).

    Returns ``{spec name: "holds" / "fails" / "tie" / None}`` (None: a pattern missing).
    """
    return {info.name: order_verdict({reward: replicates[(info.name, gamma, learner, reward)] for reward in rewards
                                      if (info.name, gamma, learner, reward) in replicates}) for info in infos}


def observed_order(rows: list[dict], spec: str, learner: str, gamma: float) -> str:
    """``learner``'s reward patterns on ``spec`` at ``gamma`` sorted by median learning time, e.g.
    ``"r2 (230) < r4 (310) < r1 (806) (censored: r3)"``; equal medians are joined by ``=``."""
    values = {r["reward"]: r["learning_time"] for r in rows
              if r["spec"] == spec and r["learner"] == learner and r["gamma"] == gamma}
    reached = sorted((v, name) for name, v in values.items() if math.isfinite(v))
    missing = sorted(name for name, v in values.items() if not math.isfinite(v))
    text = ""
    for k, (value, name) in enumerate(reached):
        if k:
            text += " = " if value == reached[k - 1][0] else " < "
        text += f"{name} ({value:g})"
    return text + (f" (censored: {', '.join(missing)})" if missing else "")


def ordering_answer(verdicts: dict) -> str:
    """One paragraph: whether r4 < r2 < r1 < r3 holds as the task grows, and how many comparisons
    it took (three consecutive pairs per spec, each decided by its 95 % bootstrap interval)."""
    order = " < ".join(PAPER_ORDER)
    shown = ", ".join(f"{name}: {v or 'undetermined'}" for name, v in verdicts.items())
    decided = [v for v in verdicts.values() if v is not None]
    counts = {kind: sum(v == kind for v in decided) for kind in ("holds", "tie", "fails")}
    comparisons = (len(PAPER_ORDER) - 1) * len(decided)
    if not decided:
        verdict = "cannot be decided (a pattern is missing)"
    else:
        verdict = (f"holds on {counts['holds']}, is a tie (some pair's interval includes equal times) on "
                   f"{counts['tie']} and fails on {counts['fails']} of {len(decided)} specs")
    return (f"Does {order} hold as the task grows? It {verdict} ({comparisons} pairwise comparisons, each at 95 %, "
            f"not corrected for multiplicity).\n  per spec: {shown}")
