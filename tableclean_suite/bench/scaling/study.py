"""Training one cell of the scaling study in run chunks, reduced as it goes.

A cell is one spec x learner x reward pattern, trained ``runs`` times for the spec's window.
The full ``(R, T)`` records of a large spec do not fit in memory at once, so runs are trained
in chunks of at most ``CHUNK_BYTES`` of records; each chunk feeds the full-resolution curve
sums (``metrics.CurveSums``) and per-run samples on an iteration grid (for the bootstrap),
then is dropped.  :func:`cell_row` reduces a trained cell to its ``scaling.csv`` row.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numba
import numpy as np

from tableclean_suite.bench.scaling.family import ALPHA, EPSILON, GAMMA, SpecInfo
from tableclean_suite.bench.scaling.statistics import (PLATEAU_FRACTION, THRESHOLD, bootstrap_cell, plateau_rise,
                                                       plateau_verdict)

#: Per-run curves are kept at the union of this many evenly spaced iterations ...
LINEAR_GRID_POINTS = 500
#: ... and this many geometrically spaced ones (relative resolution window ** (1 / points) - 1,
#: under 1 % for windows up to 10**6 iterations), for the bootstrap.
GEOMETRIC_GRID_POINTS = 1500
#: Records of one training chunk stay below this many bytes (runs per chunk follow from it).
CHUNK_BYTES = 64 * 2**20
_REWARD_BYTES = 8  # float64 reward per iteration
_INT_RECORDS = 4  # outcomes, states, actions, episode_end
_Q_BYTES = 8  # float64 Q-table entry


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
