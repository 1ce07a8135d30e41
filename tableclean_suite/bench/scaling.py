"""``python -m benchmarks.scaling``: does the reduced state space explain Q-learning's speed?

    python -m benchmarks.scaling                           # the default study (~1-2 min on 2 cores)
    python -m benchmarks.scaling --segments 2,3 --runs 8 --base-window 400 --out /tmp/s

Trains every learner (``--learners``, default ``q_learning,sarsa``) x reward pattern
(``--rewards``, default ``r1..r4``) on a family of task specs that grows from the paper's
(2 segments, 1 object: 20 reachable states) to tens of thousands of reachable states, and
reports per spec the state codes, the reachable states (from every all-unclean layout, the
model's own count), the optimal plan length from the default start, the exact
epsilon-greedy success of an optimal policy, and per cell the iterations and episodes to
maximum success and the success plateau with 95 % bootstrap intervals.

The family
    ``--segments`` N (default 2..9) with ``--objects`` M (default 1) objects.  The M = 1
    family reaches 46 062 reachable states at N = 9.  (Specs with M >= 2 cannot be trained at
    the time of writing: ``TaskModel.transition_arrays`` steps every code, including the
    unreachable ones holding two objects, and the model raises ``ActionEffectError`` there.)

How the window was chosen
    The paper's spec trains ``--base-window`` iterations (default 12 000, 4x the paper's
    3000: with 6000, r1 and r4 were still rising at the end of several larger specs' windows)
    with the paper's ``max_itr`` 500.  A
    spec whose optimal plan from the default start has L steps (the paper's has L0 = 8) trains
    ``base_window * (L / L0) ** window_exponent`` iterations (default exponent 3: N = 9 gets
    ~572 000 iterations) and truncates episodes after ``500 * L / L0`` iterations (episodes of
    a longer task need proportionally more steps).  The window scales with the plan length,
    not the reachable states: a learner from a fixed start only has to learn the states near
    its plan, and a window linear in the states would spend the budget on the largest spec.
    Whether that was long enough is *measured*, not assumed: a cell counts as having reached
    its plateau only when the success curve is flat over the plateau window (the mean of its
    second half exceeds that of its first half by at most ``PLATEAU_RISE_TOLERANCE``) and
    the plateau is at least ``MIN_PLATEAU``; otherwise its iterations and episodes are NaN
    ("not reached") and the CSV says why.

Quantities (the definitions of :mod:`tableclean_suite.metrics`)
    Point estimates come from the full-resolution mean success curve over runs
    (``metrics.CurveSums`` fed chunk by chunk, then ``metrics.summarize``).  Intervals are a
    percentile bootstrap over run indices (``BOOTSTRAP_RESAMPLES`` resamples of the runs with
    replacement; each resample recomputes the mean success curve, its plateau, the first
    iteration reaching ``threshold`` of that plateau and the mean episodes by then).  The
    plateau is resampled exactly (each run's full-resolution mean over the plateau window);
    the crossing uses each run's success and episode count sampled at ``LINEAR_GRID_POINTS``
    evenly and ``GEOMETRIC_GRID_POINTS`` geometrically spaced iterations, so an interval end
    is the grid point at or after the resample's crossing (``interval_resolution`` in the CSV:
    the grid spacing at the point estimate, under 1 % of it for windows up to 10**6).

Growth exponents
    Per reward pattern (for Q-learning), least squares of log(iterations to max success) on
    log(reachable states) over the specs where the plateau was reached; the 95 % interval is
    the slope +- t(0.975, n - 2) x its standard error.

Writes under ``--out`` (default ``results/scaling``), each atomically (temporary file, then
``os.replace``): ``scaling.csv`` (one row per spec x learner x reward, ``_low``/``_high``
interval columns), ``scaling_specs.csv``, ``scaling.png`` (log-log iterations to max
success against reachable states, one line per reward) and ``config.json`` (last).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numba
import numpy as np

from tableclean_suite.bench.cli import positive_int

#: Program name of the checkout's entry point.
PROG = "python -m benchmarks.scaling"
EXIT_USAGE = 2
DEFAULT_OUT = Path("results") / "scaling"

#: The default family: segments N = 2..9 with one object (20 .. 46 062 reachable states).
DEFAULT_SEGMENTS = tuple(range(2, 10))
DEFAULT_OBJECTS = 1
DEFAULT_LEARNERS = ("q_learning", "sarsa")
DEFAULT_REWARDS = ("r1", "r2", "r3", "r4")
#: Learner whose cells feed the figure and the growth-exponent fit (when it is trained).
FIT_LEARNER = "q_learning"
#: The ordering the paper reports for Q-learning's iterations to maximum success.
PAPER_ORDER = ("r4", "r2", "r1", "r3")

#: Runs per cell (independent learners), enough for 95 % bootstrap intervals.
DEFAULT_RUNS = 100
#: Iterations for the paper's spec (4x the paper's 3000: r1 and r4 approach their plateaus slowly on larger specs).
DEFAULT_BASE_WINDOW = 12000
#: Window growth with the optimal plan length: window = base * (L / L0) ** exponent.
DEFAULT_WINDOW_EXPONENT = 3.0
#: The paper's episode truncation, for the paper's spec; scaled linearly with L / L0.
BASE_MAX_ITR = 500
#: The paper's hyperparameters.
ALPHA, GAMMA, EPSILON = 0.3, 0.3, 0.1
DEFAULT_SEED = 0

#: Fraction of the plateau that counts as "maximum success" (metrics' default).
THRESHOLD = 0.95
#: Final fraction of the window averaged as the plateau (metrics' default).
PLATEAU_FRACTION = 0.25
#: A plateau window whose second half beats its first half by more than this (success fraction)
#: is still rising: the cell did not reach its plateau within the window.
PLATEAU_RISE_TOLERANCE = 0.02
#: Below this plateau (success fraction) "95 % of the plateau" is reached at once and means nothing.
MIN_PLATEAU = 0.01

#: Per-run curves are kept at the union of this many evenly spaced iterations ...
LINEAR_GRID_POINTS = 500
#: ... and this many geometrically spaced ones (relative resolution window ** (1 / points) - 1,
#: under 1 % for windows up to 10**6 iterations), for the bootstrap.
GEOMETRIC_GRID_POINTS = 1500
DEFAULT_RESAMPLES = 1000
CONFIDENCE = 0.95
#: Records of one training chunk stay below this many bytes (runs per chunk follow from it).
CHUNK_BYTES = 64 * 2**20
_REWARD_BYTES = 8  # float64 reward per iteration
_INT_RECORDS = 4  # outcomes, states, actions, episode_end
_Q_BYTES = 8  # float64 Q-table entry
#: Resolution of the PNG figure, dots per inch.
FIGURE_DPI = 120


# ---------------------------------------------------------------------------
# Specs and their exact quantities
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class SpecInfo:
    """One spec of the family and what the study needs of it.

    Attributes:
        name: spec name (``scale_n{N}_m{M}``; ``paper`` for N = 2, M = 1).
        segments, objects: N >= 2 and M >= 1.
        codes: state codes, ``2**N * (N + 1)**M * N``.
        reachable: states reachable from every all-unclean layout (terminal ones included).
        plan_length: optimal plan length (steps) from the default start.
        optimal_success: exact epsilon-greedy success probability of an optimal policy, in [0, 1].
        window: iterations per run (>= 1).
        max_itr: episode truncation (iterations, >= 1).
    """

    name: str
    segments: int
    objects: int
    codes: int
    reachable: int
    plan_length: int
    optimal_success: float
    window: int
    max_itr: int


def family_spec(segments: int, objects: int):
    """The family's spec with N ``segments`` and M ``objects`` boxes (the paper's for N=2, M=1)."""
    from tableclean_suite.task import TaskSpec, get_task_spec

    paper = get_task_spec("paper")
    if (segments, objects) == (paper.segments, paper.n_objects):
        return paper
    return TaskSpec(f"scale_n{segments}_m{objects}", segments=segments, objects=objects,
                    description=f"scaling study: {segments} segments, {objects} object(s)")


def distances_to_terminal(next_state: np.ndarray, terminal: np.ndarray) -> np.ndarray:
    """Shortest number of steps from every code to a terminal code, by value iteration.

    Args:
        next_state: ``(S, A)`` successor codes (``TaskModel.transition_arrays``).
        terminal: ``(S,)`` bool, terminal codes.

    Returns:
        ``(S,)`` int64 distances (0 at terminal codes), -1 where no terminal is reachable.
    """
    unknown = np.iinfo(np.int64).max
    distance = np.where(terminal, 0, unknown)
    while True:
        best = distance[next_state].min(axis=1)
        candidate = np.where(terminal | (best == unknown), distance, np.minimum(distance, best + 1))
        if np.array_equal(candidate, distance):
            break
        distance = candidate
    return np.where(distance == unknown, -1, distance)


def optimal_policy(next_state: np.ndarray, distance: np.ndarray) -> np.ndarray:
    """A greedy policy that follows a shortest plan from every state.

    In each state with a finite distance d > 0 it takes the first action, in the spec's order,
    whose successor is at distance d - 1; elsewhere (terminal or hopeless codes) action 0.

    Args:
        next_state: ``(S, A)`` successor codes.
        distance: ``(S,)`` distances of :func:`distances_to_terminal`.

    Returns:
        ``(S,)`` int64 action indices.
    """
    closer = (distance[next_state] == (distance - 1)[:, None]) & (distance[:, None] > 0)
    return np.where(closer.any(axis=1), np.argmax(closer, axis=1), 0).astype(np.int64)


def terminal_codes(model) -> np.ndarray:
    """``(S,)`` bool: whether each code of ``model`` is terminal (every segment clean)."""
    return np.array([model.decode(code).is_terminal for code in range(model.n_states)], dtype=bool)


def plan_window(plan_length: int, paper_plan_length: int, base_window: int, exponent: float) -> tuple[int, int]:
    """``(window, max_itr)`` in iterations for a spec whose optimal plan has ``plan_length`` steps.

    ``window = base_window * (L / L0) ** exponent`` and ``max_itr = BASE_MAX_ITR * L / L0``,
    both rounded up (L0 = ``paper_plan_length``).
    """
    ratio = plan_length / paper_plan_length
    return math.ceil(base_window * ratio ** exponent), math.ceil(BASE_MAX_ITR * ratio)


def paper_plan_steps() -> int:
    """L0: the paper spec's optimal plan length from its default start (the model's own BFS)."""
    from tableclean_suite.task import TaskModel

    model = TaskModel(spec="paper")
    return len(model.shortest_plan(model.start_state))


def json_safe(value):
    """``value`` with every non-finite float replaced by None (strict JSON)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {key: json_safe(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(item) for item in value]
    return value


def describe_spec(spec, paper_plan_length: int, base_window: int, exponent: float):
    """``(SpecInfo, TaskModel)`` of ``spec``: sizes, optimal plan and its exact success, window."""
    from tableclean_suite.analysis import exact_success_probability
    from tableclean_suite.task import TaskModel

    model = TaskModel(spec=spec)
    next_state, _ = model.transition_arrays()
    distance = distances_to_terminal(next_state, terminal_codes(model))
    plan_length = int(distance[model.start_state.index])
    window, max_itr = plan_window(plan_length, paper_plan_length, base_window, exponent)
    policy = optimal_policy(next_state, distance)
    success = float(exact_success_probability(policy, EPSILON, max_itr, model=model))
    info = SpecInfo(spec.name, spec.segments, spec.n_objects, model.n_states, len(model.reachable_states()),
                    plan_length, success, window, max_itr)
    return info, model


# ---------------------------------------------------------------------------
# Training, reduced chunk by chunk
# ---------------------------------------------------------------------------
@numba.njit(cache=True)
def _grid_curves(outcomes, episode_end, grid, tail_start, improper_code, terminal_code, success_out, episodes_out,
                 tail_out):
    """Per run, at each grid iteration (0-based indices ``grid``, increasing): whether the latest
    finished episode succeeded (``success_out (R, G)``, 0/1) and episodes finished so far
    (``episodes_out (R, G)``); and ``tail_out (R,)``: how many iterations t >= ``tail_start``
    had a successful latest episode."""
    n_runs, n_iterations = outcomes.shape
    for r in range(n_runs):
        improper = 0
        finished = 0
        latest = 0
        g = 0
        tail = 0
        for t in range(n_iterations):
            if outcomes[r, t] == improper_code:
                improper += 1
            if episode_end[r, t] != 0:
                finished += 1
                latest = 1 if (episode_end[r, t] == terminal_code and improper == 0) else 0
                improper = 0
            if t >= tail_start:
                tail += latest
            while g < grid.shape[0] and grid[g] == t:
                success_out[r, g] = latest
                episodes_out[r, g] = finished
                g += 1
        tail_out[r] = tail


def grid_indices(window: int, linear: int = LINEAR_GRID_POINTS,
                 geometric: int = GEOMETRIC_GRID_POINTS) -> np.ndarray:
    """``(G,)`` int64 0-based iteration indices in [0, window - 1], increasing, ending at ``window - 1``:
    ``linear`` evenly spaced counts and ``geometric`` geometrically spaced ones from 1 to ``window``
    (G <= linear + geometric)."""
    even = np.ceil(np.arange(1, linear + 1) * window / linear)
    spread = np.ceil(np.geomspace(1, window, geometric))
    return np.unique(np.clip(np.r_[even, spread], 1, window).astype(np.int64) - 1)


def plateau_start(window: int, plateau_fraction: float = PLATEAU_FRACTION) -> int:
    """0-based first iteration of the plateau window (the last ``plateau_fraction`` of ``window``)."""
    return window - max(1, math.ceil(window * plateau_fraction))


def grid_gap(grid: np.ndarray, iteration: float) -> float:
    """Spacing (iterations) of the grid points around the 1-based ``iteration`` count; NaN if not finite."""
    if not math.isfinite(iteration):
        return math.nan
    at = int(np.clip(np.searchsorted(grid, iteration - 1), 1, len(grid) - 1))
    return float(grid[at] - grid[at - 1])


@dataclass
class CellRecords:
    """What one trained cell keeps.

    Attributes:
        summary: ``metrics.summarize`` of the full-resolution mean curves (all runs).
        grid: ``(G,)`` 0-based iteration indices of the per-run samples.
        success: ``(R, G)`` uint8, 1 where the run's latest finished episode succeeded.
        episodes: ``(R, G)`` int32, episodes the run finished by then.
        run_plateau: ``(R,)`` float64, each run's success averaged over the plateau window (full resolution).
        updates: learner updates performed (runs x window).
        seconds: wall time of training and reduction.
    """

    summary: object
    grid: np.ndarray
    success: np.ndarray
    episodes: np.ndarray
    run_plateau: np.ndarray
    updates: int
    seconds: float


def runs_per_chunk(window: int, n_states: int, n_actions: int, itemsize: int, runs: int) -> int:
    """Runs per training chunk so one chunk's records and Q-tables stay below ``CHUNK_BYTES``."""
    per_run = window * (_REWARD_BYTES + _INT_RECORDS * itemsize) + n_states * n_actions * _Q_BYTES
    return max(1, min(runs, CHUNK_BYTES // per_run))


def train_cell(model, info: SpecInfo, learner: str, reward: str, runs: int, seed: int) -> CellRecords:
    """Train ``runs`` runs of one cell in chunks, keeping only the curve sums and grid samples."""
    from tableclean_suite import metrics
    from tableclean_suite.learners import train
    from tableclean_suite.learners.kernel import EPISODE_TERMINAL
    from tableclean_suite.task import Outcome

    started = time.perf_counter()
    grid = grid_indices(info.window)
    success = np.zeros((runs, len(grid)), dtype=np.uint8)
    episodes = np.zeros((runs, len(grid)), dtype=np.int32)
    tail = np.zeros(runs, dtype=np.int64)
    tail_start = plateau_start(info.window)
    sums = metrics.CurveSums.zeros(info.window)
    chunk = runs_per_chunk(info.window, model.n_states, model.n_actions, np.dtype(model.record_dtype).itemsize, runs)
    for first in range(0, runs, chunk):
        count = min(chunk, runs - first)
        result = train(learner=learner, reward=reward, runs=count, iterations=info.window, alpha=ALPHA,
                       gamma=GAMMA, epsilon=EPSILON, max_itr=info.max_itr, seed=seed, task=model, first_run=first)
        sums.add(result)
        _grid_curves(result.outcomes, result.episode_end, grid, tail_start, int(Outcome.IMPROPER), EPISODE_TERMINAL,
                     success[first:first + count], episodes[first:first + count], tail[first:first + count])
        del result
    summary = metrics.summarize(sums, THRESHOLD, PLATEAU_FRACTION)
    run_plateau = tail / (info.window - tail_start)
    return CellRecords(summary, grid, success, episodes, run_plateau, runs * info.window,
                       time.perf_counter() - started)


# ---------------------------------------------------------------------------
# Statistics
# ---------------------------------------------------------------------------
def plateau_rise(curve: np.ndarray, plateau_fraction: float = PLATEAU_FRACTION) -> float:
    """Mean of the plateau window's second half minus its first half (success fraction units)."""
    window = max(2, math.ceil(len(curve) * plateau_fraction))
    tail = np.asarray(curve, dtype=float)[-window:]
    half = len(tail) // 2
    return float(np.nanmean(tail[half:]) - np.nanmean(tail[:half]))


def plateau_verdict(curve: np.ndarray) -> tuple[bool, str]:
    """``(reached, reason)``: whether the success ``curve`` (``(T,)``) settled on a usable plateau."""
    from tableclean_suite import metrics

    top = metrics.plateau(curve, PLATEAU_FRACTION)
    rise = plateau_rise(curve)
    if not math.isfinite(top) or top < MIN_PLATEAU:
        return False, f"plateau {top:.3f} < {MIN_PLATEAU}"
    if rise > PLATEAU_RISE_TOLERANCE:
        return False, f"still rising by {rise:.3f} over the plateau window"
    return True, ""


def resample_counts(runs: int, resamples: int, seed: int) -> np.ndarray:
    """``(B, R)`` int: how often each run index is drawn in each bootstrap resample."""
    rng = np.random.default_rng(seed)
    return rng.multinomial(runs, np.full(runs, 1.0 / runs), size=resamples)


def bootstrap_cell(records: CellRecords, counts: np.ndarray) -> dict:
    """Percentile intervals (``CONFIDENCE``) over run resamples of the cell's three figures.

    Args:
        records: the cell's grid samples, ``(R, G)``.
        counts: ``(B, R)`` resample counts of :func:`resample_counts`.

    Returns:
        ``{"iterations": (low, high), "episodes": (low, high), "plateau": (low, high)}``; the
        iteration ends are 1-based counts on the grid.
    """
    runs = records.success.shape[0]
    weights = counts.astype(np.float64) / runs
    success = weights @ records.success.astype(np.float64)  # (B, G)
    episodes = weights @ records.episodes.astype(np.float64)
    top = weights @ records.run_plateau  # (B,), exact: each run's full-resolution plateau-window mean
    hit = success >= THRESHOLD * top[:, None]
    first = np.where(hit.any(axis=1), np.argmax(hit, axis=1), len(records.grid) - 1)
    iterations = records.grid[first] + 1.0
    reached_episodes = episodes[np.arange(len(first)), first]
    tails = (100 * (1 - CONFIDENCE) / 2, 100 * (1 + CONFIDENCE) / 2)
    return {name: tuple(float(v) for v in np.percentile(values, tails))
            for name, values in (("iterations", iterations), ("episodes", reached_episodes), ("plateau", top))}


def fit_growth_exponent(x, y, confidence: float = CONFIDENCE) -> dict:
    """Least squares of ``log y`` on ``log x``: ``y ~ c * x ** exponent``.

    Args:
        x, y: positive sizes and values; pairs with a non-finite or non-positive member are skipped.
        confidence: level of the slope's interval, in (0, 1).

    Returns:
        ``{"exponent", "low", "high", "points"}``: the slope, its t interval (NaN with fewer
        than 3 points) and the number of points used (exponent NaN with fewer than 2).
    """
    from scipy import stats

    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    usable = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    points = int(usable.sum())
    if points < 2 or np.ptp(np.log(x[usable])) == 0:
        return {"exponent": math.nan, "low": math.nan, "high": math.nan, "points": points}
    fit = stats.linregress(np.log(x[usable]), np.log(y[usable]))
    if points < 3:
        return {"exponent": float(fit.slope), "low": math.nan, "high": math.nan, "points": points}
    half = stats.t.ppf((1 + confidence) / 2, points - 2) * fit.stderr
    return {"exponent": float(fit.slope), "low": float(fit.slope - half), "high": float(fit.slope + half),
            "points": points}


def order_holds(values: dict, order=PAPER_ORDER) -> bool | None:
    """Whether ``values[order[0]] < values[order[1]] < ...``; None if one is missing or NaN."""
    chosen = [values.get(name, math.nan) for name in order]
    if any(v is None or not math.isfinite(v) for v in chosen):
        return None
    return all(a < b for a, b in zip(chosen, chosen[1:]))


# ---------------------------------------------------------------------------
# Rows, files, figure
# ---------------------------------------------------------------------------
def cell_row(info: SpecInfo, learner: str, reward: str, records: CellRecords, counts: np.ndarray) -> dict:
    """One ``scaling.csv`` row: the cell's figures (NaN when not reached) and their intervals."""
    summary = records.summary
    reached, reason = plateau_verdict(summary.success)
    interval = bootstrap_cell(records, counts)
    nan2 = (math.nan, math.nan)
    it_low, it_high = interval["iterations"] if reached else nan2
    ep_low, ep_high = interval["episodes"] if reached else nan2
    iterations = summary.max_success_iterations if reached and summary.max_success_iterations is not None else None
    episodes = summary.max_success_episodes if iterations is not None else None
    return {
        "spec": info.name, "segments": info.segments, "objects": info.objects, "reachable": info.reachable,
        "learner": learner, "reward": reward, "runs": records.success.shape[0], "window": info.window,
        "max_itr": info.max_itr,
        "max_success_iterations": math.nan if iterations is None else float(iterations),
        "max_success_iterations_low": it_low, "max_success_iterations_high": it_high,
        "max_success_episodes": math.nan if episodes is None else float(episodes),
        "max_success_episodes_low": ep_low, "max_success_episodes_high": ep_high,
        "success_plateau": summary.success_plateau,
        "success_plateau_low": interval["plateau"][0], "success_plateau_high": interval["plateau"][1],
        "optimal_success": info.optimal_success,
        "plateau_rise": plateau_rise(summary.success),
        "reached": reached, "not_reached_reason": reason,
        "interval_resolution": grid_gap(records.grid, math.nan if iterations is None else float(iterations)),
        "seconds": records.seconds,
    }


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


def write_figure(path: Path, rows: list[dict], learner: str, fits: dict) -> None:
    """Log-log iterations to max success against reachable states, one line per reward, as PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(7, 5))
    for reward, fit in fits.items():
        cells = [r for r in rows if r["learner"] == learner and r["reward"] == reward and r["reached"]]
        if not cells:
            continue
        x = np.array([r["reachable"] for r in cells], dtype=float)
        y = np.array([r["max_success_iterations"] for r in cells])
        error = np.array([[v - r["max_success_iterations_low"], r["max_success_iterations_high"] - v]
                          for r, v in zip(cells, y)]).T
        line = axes.errorbar(x, y, yerr=np.clip(error, 0, None), marker="o", capsize=3,
                             label=f"{reward} (exponent {fit['exponent']:.2f})")
        if math.isfinite(fit["exponent"]):
            anchor = np.exp(np.mean(np.log(y)) - fit["exponent"] * np.mean(np.log(x)))
            axes.plot(x, anchor * x ** fit["exponent"], linestyle="--", color=line[0].get_color(), alpha=0.6)
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_xlabel("reachable states")
    axes.set_ylabel("iterations to maximum success")
    axes.set_title(f"{learner}: iterations to max success (95 % bootstrap intervals)")
    axes.legend()
    figure.tight_layout()
    temporary = _temporary(path)
    figure.savefig(temporary, format="png", dpi=FIGURE_DPI)
    plt.close(figure)
    os.replace(temporary, path)


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


# ---------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------
class _OneLineParser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose errors are one line on stderr and exit code 2."""

    def error(self, message):
        print(f"{self.prog}: error: {message}", file=sys.stderr)
        sys.exit(EXIT_USAGE)


def _choice_list(allowed, what: str):
    def parse(text: str) -> tuple[str, ...]:
        chosen = tuple(dict.fromkeys(part.strip() for part in text.split(",") if part.strip()))
        bad = [name for name in chosen if name not in allowed]
        if bad or not chosen:
            raise argparse.ArgumentTypeError(f"unknown {what} {', '.join(bad) or text!r}; "
                                             f"allowed: {', '.join(allowed)} (comma separated)")
        return chosen
    return parse


def segment_list(text: str) -> tuple[int, ...]:
    """``"2,3,5"`` -> ``(2, 3, 5)``: sorted, distinct segment counts >= 2."""
    try:
        values = sorted({int(part) for part in text.split(",") if part.strip()})
    except ValueError:
        values = []
    if not values or values[0] < 2:
        raise argparse.ArgumentTypeError(f"expected comma-separated segment counts >= 2, got {text!r}")
    return tuple(values)


def positive_float(text: str) -> float:
    """A finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line of the study."""
    from tableclean_suite.learners import learner_names
    from tableclean_suite.rewards import reward_pattern_names

    parser = _OneLineParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--learners", type=_choice_list(learner_names(), "learner"), default=DEFAULT_LEARNERS,
                        help=f"comma-separated learners; allowed: {', '.join(learner_names())} "
                             f"(default: {','.join(DEFAULT_LEARNERS)})")
    parser.add_argument("--rewards", type=_choice_list(reward_pattern_names(), "reward pattern"),
                        default=DEFAULT_REWARDS, help=f"comma-separated reward patterns; allowed: "
                        f"{', '.join(reward_pattern_names())} (default: {','.join(DEFAULT_REWARDS)})")
    parser.add_argument("--segments", type=segment_list, default=DEFAULT_SEGMENTS,
                        help="comma-separated segment counts N >= 2 of the family (default: 2..9)")
    parser.add_argument("--objects", type=positive_int, default=DEFAULT_OBJECTS,
                        help=f"objects M per spec (default: {DEFAULT_OBJECTS})")
    parser.add_argument("--runs", type=positive_int, default=DEFAULT_RUNS,
                        help=f"runs per cell (default: {DEFAULT_RUNS})")
    parser.add_argument("--base-window", type=positive_int, default=DEFAULT_BASE_WINDOW,
                        help=f"iterations for the paper's spec (default: {DEFAULT_BASE_WINDOW})")
    parser.add_argument("--window-exponent", type=positive_float, default=DEFAULT_WINDOW_EXPONENT,
                        help=f"window = base * (L / L0) ** exponent (default: {DEFAULT_WINDOW_EXPONENT})")
    parser.add_argument("--resamples", type=positive_int, default=DEFAULT_RESAMPLES,
                        help=f"bootstrap resamples (default: {DEFAULT_RESAMPLES})")
    parser.add_argument("--seed", type=int, default=DEFAULT_SEED, help=f"training seed (default: {DEFAULT_SEED})")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"output folder (default: {DEFAULT_OUT})")
    return parser


def _config(args, infos: list[SpecInfo], fits: dict, verdicts: dict, seconds: float, fit_learner: str) -> dict:
    return {
        "study": "scaling",
        "learners": list(args.learners), "rewards": list(args.rewards), "segments": list(args.segments),
        "objects": args.objects, "runs": args.runs, "base_window": args.base_window,
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


def run_study(args) -> int:
    """Describe the specs, train every cell, print and write everything; returns 0."""
    started = time.perf_counter()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    paper_plan_length = paper_plan_steps()
    specs = [family_spec(n, args.objects) for n in args.segments]
    described = [describe_spec(s, paper_plan_length, args.base_window, args.window_exponent) for s in specs]
    infos = [info for info, _ in described]
    print(f"Scaling study: {len(infos)} specs x {len(args.learners)} learners x {len(args.rewards)} rewards, "
          f"{args.runs} runs per cell.")
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
        _config(args, infos, fits, verdicts, seconds, fit_learner)), indent=2, allow_nan=False) + "\n")
    print(f"\nWrote {out}/scaling.csv, scaling_specs.csv, scaling.png, config.json in {seconds:.1f} s wall.")
    return 0


def main(argv=None, prog: str = PROG) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    args = build_parser(prog).parse_args(argv)
    return run_study(args)


if __name__ == "__main__":
    sys.exit(main(prog="python -m tableclean_suite.bench.scaling"))
