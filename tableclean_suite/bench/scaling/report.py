"""The scaling study's report: printed tables and answers, CSV files, the figure and ``config.json``.

Every file is written atomically (a temporary file in the same folder, then ``os.replace``).
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict
from pathlib import Path

import numpy as np

from tableclean_suite.bench.scaling.family import ALPHA, BASE_MAX_ITR, EPSILON, GAMMA, SpecInfo
from tableclean_suite.bench.scaling.statistics import (CONFIDENCE, MIN_PLATEAU, PAPER_ORDER, PLATEAU_FRACTION,
                                                       PLATEAU_RISE_TOLERANCE, THRESHOLD, order_holds)
from tableclean_suite.bench.scaling.study import GEOMETRIC_GRID_POINTS, LINEAR_GRID_POINTS

#: Resolution of the PNG figure, dots per inch.
FIGURE_DPI = 120
#: Marker shapes of the figure's points by object count M = 1, 2, 3, ... (cycled beyond).
OBJECT_MARKERS = ("o", "s", "^", "D", "v", "P", "X")


# ---------------------------------------------------------------------------
# Files
# ---------------------------------------------------------------------------
def json_safe(value):
    """``value`` with every non-finite float replaced by None (strict JSON)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {key: json_safe(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(item) for item in value]
    return value


def _temporary(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def write_atomic_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` via a temporary file and ``os.replace``."""
    temporary = _temporary(path)
    temporary.write_text(text)
    os.replace(temporary, path)


def write_csv(path: Path, rows: list[dict]) -> None:
    """Rows of equal keys as CSV, atomically."""
    import pandas as pd

    write_atomic_text(path, pd.DataFrame(rows).to_csv(index=False))


def object_marker(objects: int) -> str:
    """Matplotlib marker of the specs with ``objects`` M >= 1 (circle for M = 1, as before M varied)."""
    return OBJECT_MARKERS[(objects - 1) % len(OBJECT_MARKERS)]


def write_figure(path: Path, rows: list[dict], learner: str, fits: dict) -> None:
    """Log-log iterations to max success against reachable states, as PNG.

    One line per reward pattern (``learner``'s reached cells, joined in order of reachable
    states, with 95 % bootstrap error bars and the fitted power law dashed); the marker shape
    gives the spec's object count M (:func:`object_marker`), so a step along the line that adds
    an object reads apart from one that adds segments.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    figure, axes = plt.subplots(figsize=(7, 5))
    object_counts = sorted({r["objects"] for r in rows if r["learner"] == learner})
    for reward, fit in fits.items():
        cells = sorted((r for r in rows if r["learner"] == learner and r["reward"] == reward and r["reached"]),
                       key=lambda r: (r["reachable"], r["segments"], r["objects"]))
        if not cells:
            continue
        x = np.array([r["reachable"] for r in cells], dtype=float)
        y = np.array([r["max_success_iterations"] for r in cells])
        error = np.clip(np.array([[v - r["max_success_iterations_low"], r["max_success_iterations_high"] - v]
                                  for r, v in zip(cells, y)]).T, 0, None)  # (2, n): below, above
        objects = np.array([r["objects"] for r in cells])
        (line,) = axes.plot(x, y, linestyle="-", label=f"{reward} (exponent {fit['exponent']:.2f})")
        color = line.get_color()
        for m in object_counts:
            chosen = objects == m
            if chosen.any():
                axes.errorbar(x[chosen], y[chosen], yerr=error[:, chosen], marker=object_marker(m), linestyle="none",
                              color=color, capsize=3)
        if math.isfinite(fit["exponent"]):
            anchor = np.exp(np.mean(np.log(y)) - fit["exponent"] * np.mean(np.log(x)))
            axes.plot(x, anchor * x ** fit["exponent"], linestyle="--", color=color, alpha=0.6)
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_xlabel("reachable states")
    axes.set_ylabel("iterations to maximum success")
    axes.set_title(f"{learner}: iterations to max success (95 % bootstrap intervals)")
    reward_legend = axes.legend(loc="upper left")
    if len(object_counts) > 1:
        axes.add_artist(reward_legend)
        shapes = [Line2D([], [], marker=object_marker(m), linestyle="none", color="black",
                         label=f"M = {m} object{'s' if m > 1 else ''}") for m in object_counts]
        axes.legend(handles=shapes, loc="lower right")
    figure.tight_layout()
    temporary = _temporary(path)
    figure.savefig(temporary, format="png", dpi=FIGURE_DPI)
    plt.close(figure)
    os.replace(temporary, path)


def config_dict(args, infos: list[SpecInfo], fits: dict, verdicts: dict, seconds: float, fit_learner: str) -> dict:
    """The content of ``config.json``: the command line, every constant of the method, the fits,
    the reward-order verdicts, the specs and the wall time (``seconds``)."""
    return {
        "study": "scaling",
        "learners": list(args.learners), "rewards": list(args.rewards), "segments": list(args.segments),
        "objects": list(args.objects), "runs": args.runs, "base_window": args.base_window,
        "window_exponent": args.window_exponent, "base_max_itr": BASE_MAX_ITR,
        "window_rule": "window = base_window * (L / L0) ** window_exponent, max_itr = base_max_itr * L / L0, "
                       "L = optimal plan length from the default start, L0 = the paper spec's",
        "alpha": ALPHA, "gamma": GAMMA, "epsilon": EPSILON, "seed": args.seed,
        "threshold": THRESHOLD, "plateau_fraction": PLATEAU_FRACTION,
        "plateau_rise_tolerance": PLATEAU_RISE_TOLERANCE, "min_plateau": MIN_PLATEAU,
        "bootstrap": f"percentile bootstrap over run indices, {args.resamples} resamples, recomputing each figure "
                     f"from the resampled mean curve sampled at {LINEAR_GRID_POINTS} evenly and {GEOMETRIC_GRID_POINTS} "
                     f"geometrically spaced iterations (plateau: exact per-run plateau-window means)",
        "confidence": CONFIDENCE, "fit_learner": fit_learner, "growth_exponents": fits,
        "paper_order": list(PAPER_ORDER), "order_holds": verdicts,
        "specs": [asdict(s) for s in infos], "seconds": seconds,
    }


# ---------------------------------------------------------------------------
# Printing
# ---------------------------------------------------------------------------
def _interval_text(value, low, high, digits: int = 0) -> str:
    if not math.isfinite(value):
        return "not reached"
    return f"{value:.{digits}f} [{low:.{digits}f}, {high:.{digits}f}]"


def print_specs(infos: list[SpecInfo]) -> None:
    """The per-spec table: sizes, plan length, exact optimal success, window."""
    print(f"{'spec':<14}{'N':>3}{'M':>3}{'codes':>8}{'reachable':>10}{'plan':>6}{'opt.success':>12}"
          f"{'window':>9}{'max_itr':>8}")
    for s in infos:
        print(f"{s.name:<14}{s.segments:>3}{s.objects:>3}{s.codes:>8}{s.reachable:>10}{s.plan_length:>6}"
              f"{s.optimal_success:>12.4f}{s.window:>9}{s.max_itr:>8}")


def print_cells(rows: list[dict]) -> None:
    """The per-cell table: iterations and episodes to max success and the plateau, with intervals."""
    print(f"{'spec':<14}{'reach':>7} {'learner':<11}{'rw':<4}{'iterations to max success':>30}"
          f"{'episodes':>24}{'plateau':>24}")
    for r in rows:
        iterations = _interval_text(r["max_success_iterations"], r["max_success_iterations_low"],
                                    r["max_success_iterations_high"])
        episodes = _interval_text(r["max_success_episodes"], r["max_success_episodes_low"],
                                  r["max_success_episodes_high"], 1)
        top = _interval_text(r["success_plateau"], r["success_plateau_low"], r["success_plateau_high"], 3)
        note = "" if r["reached"] else f"  ({r['not_reached_reason']})"
        print(f"{r['spec']:<14}{r['reachable']:>7} {r['learner']:<11}{r['reward']:<4}{iterations:>30}"
              f"{episodes:>24}{top:>24}{note}")


def ordering_report(rows: list[dict], infos: list[SpecInfo], learner: str, rewards) -> dict:
    """Per spec, whether ``learner``'s iterations to max success follow :data:`PAPER_ORDER`.

    Returns ``{spec name: True / False / None}`` (None: a pattern missing or not reached).
    """
    verdicts = {}
    for info in infos:
        values = {r["reward"]: r["max_success_iterations"] for r in rows
                  if r["spec"] == info.name and r["learner"] == learner}
        verdicts[info.name] = order_holds(values) if set(PAPER_ORDER) <= set(rewards) else None
    return verdicts


def observed_order(rows: list[dict], spec: str, learner: str) -> str:
    """``learner``'s reward patterns on ``spec`` sorted by iterations to max success, e.g.
    ``"r2 < r4 < r3 (not reached: r1)"``."""
    values = {r["reward"]: r["max_success_iterations"] for r in rows if r["spec"] == spec and r["learner"] == learner}
    reached = sorted((v, name) for name, v in values.items() if math.isfinite(v))
    missing = sorted(name for name, v in values.items() if not math.isfinite(v))
    text = " < ".join(name for _, name in reached)
    return text + (f" (not reached: {', '.join(missing)})" if missing else "")


def ordering_answer(verdicts: dict) -> str:
    """One paragraph: whether r4 < r2 < r1 < r3 holds as the task grows."""
    order = " < ".join(PAPER_ORDER)
    shown = ", ".join(f"{name}: {'holds' if v else 'undetermined' if v is None else 'fails'}"
                      for name, v in verdicts.items())
    held = [name for name, v in verdicts.items() if v]
    decided = [v for v in verdicts.values() if v is not None]
    if not decided:
        verdict = "cannot be decided (a pattern is missing or did not reach its plateau)"
    elif all(decided):
        verdict = "holds for every spec where all four patterns reached their plateau"
    elif not held:
        verdict = "holds for no spec"
    else:
        largest_held = held[-1]
        verdict = f"holds only for {', '.join(held)} (largest: {largest_held}) and breaks as the task grows"
    return f"Does {order} hold as the task grows? It {verdict}.\n  per spec: {shown}"
