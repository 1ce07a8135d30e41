"""Training one cell of the scaling study in run chunks, reduced as it goes.

A cell is one spec x gamma x learner x reward pattern, trained ``runs`` times for the spec's
window.  The full ``(R, T)`` records of a large spec do not fit in memory at once, so runs are
trained in chunks of at most ``CHUNK_BYTES`` of records; each chunk is reduced to per-run block
sums (:func:`~tableclean_suite.bench.scaling.statistics.block_edges`: successful iterations and
episodes finished per block, the success over the window's last quarter, whether the run ever
reached the terminal state) and dropped.  :func:`cell_row` turns a trained cell into its
``scaling.csv`` row with the figures of :mod:`.statistics`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numba
import numpy as np

from tableclean_suite.bench.scaling.family import ALPHA, EPSILON, SpecInfo
from tableclean_suite.bench.scaling.statistics import (YARDSTICK_FRACTION, block_edges, block_widths,
                                                       bootstrap_cell)
from tableclean_suite.metrics import DEFAULT_PLATEAU_FRACTION

#: Records of one training chunk stay below this many bytes (runs per chunk follow from it).
CHUNK_BYTES = 64 * 2**20
_REWARD_BYTES = 8  # float64 reward per iteration
_INT_RECORDS = 4  # outcomes, states, actions, episode_end
_Q_BYTES = 8  # float64 Q-table entry


@numba.njit(cache=True)
def _block_sums(outcomes, episode_end, edges, tail_start, improper_code, terminal_outcome, terminal_code,
                success_out, episodes_out, tail_out, never_out):
    """Per run: successful iterations in each block (an iteration counts when the run's latest
    finished episode succeeded) ``success_out (R, G)``, episodes finished by each block's end
    ``episodes_out (R, G)``, successful iterations from ``tail_start`` on ``tail_out (R,)`` and
    1.0 in ``never_out (R,)`` when the run never had a terminal outcome."""
    n_runs, n_iterations = outcomes.shape
    for r in range(n_runs):
        improper = 0
        finished = 0
        latest = 0
        g = 0
        tail = 0
        reached = False
        for t in range(n_iterations):
            if outcomes[r, t] == improper_code:
                improper += 1
            if outcomes[r, t] == terminal_outcome:
                reached = True
            if episode_end[r, t] != 0:
                finished += 1
                latest = 1 if (episode_end[r, t] == terminal_code and improper == 0) else 0
                improper = 0
            if t >= tail_start:
                tail += latest
            success_out[r, g] += latest
            if t == edges[g]:
                episodes_out[r, g] = finished
                g += 1
        tail_out[r] = tail
        never_out[r] = 0.0 if reached else 1.0


def plateau_start(window: int, plateau_fraction: float = DEFAULT_PLATEAU_FRACTION) -> int:
    """0-based first iteration of the window's last ``plateau_fraction`` (metrics' window mean)."""
    return window - max(1, math.ceil(window * plateau_fraction))


@dataclass
class CellRecords:
    """What one trained cell keeps.

    Attributes:
        edges: ``(G,)`` 0-based last iteration of each block.
        block_success: ``(R, G)`` int32 successful iterations of each run in each block.
        episodes: ``(R, G)`` int32 episodes each run finished by each block's end.
        tail_success: ``(R,)`` each run's success over the window's last quarter (the window mean).
        never_terminal: ``(R,)`` 1.0 for a run that never reached the terminal state.
        updates: learner updates performed (runs x window).
        seconds: wall time of training and reduction.
    """

    edges: np.ndarray
    block_success: np.ndarray
    episodes: np.ndarray
    tail_success: np.ndarray
    never_terminal: np.ndarray
    updates: int
    seconds: float

    @property
    def runs(self) -> int:
        return self.block_success.shape[0]


def runs_per_chunk(window: int, n_states: int, n_actions: int, itemsize: int, runs: int) -> int:
    """Runs per training chunk so one chunk's records and Q-tables stay below ``CHUNK_BYTES``."""
    per_run = window * (_REWARD_BYTES + _INT_RECORDS * itemsize) + n_states * n_actions * _Q_BYTES
    return max(1, min(runs, CHUNK_BYTES // per_run))


def train_cell(model, info: SpecInfo, learner: str, reward: str, runs: int, seed: int, gamma: float) -> CellRecords:
    """Train ``runs`` runs of one cell (discount ``gamma``) in chunks, keeping only the block sums."""
    from tableclean_suite.learners import train
    from tableclean_suite.learners.kernel import EPISODE_TERMINAL
    from tableclean_suite.task import Outcome

    started = time.perf_counter()
    edges = block_edges(info.window)
    success = np.zeros((runs, len(edges)), dtype=np.int32)
    episodes = np.zeros((runs, len(edges)), dtype=np.int32)
    tail = np.zeros(runs, dtype=np.int64)
    never = np.zeros(runs, dtype=np.float64)
    tail_start = plateau_start(info.window)
    chunk = runs_per_chunk(info.window, model.n_states, model.n_actions, np.dtype(model.record_dtype).itemsize, runs)
    for first in range(0, runs, chunk):
        count = min(chunk, runs - first)
        result = train(learner=learner, reward=reward, runs=count, iterations=info.window, alpha=ALPHA,
                       gamma=gamma, epsilon=EPSILON, max_itr=info.max_itr, seed=seed, task=model, first_run=first)
        part = slice(first, first + count)
        _block_sums(result.outcomes, result.episode_end, edges, tail_start, int(Outcome.IMPROPER),
                    int(Outcome.TERMINAL), EPISODE_TERMINAL, success[part], episodes[part], tail[part], never[part])
        del result
    return CellRecords(edges, success, episodes, tail / (info.window - tail_start), never, runs * info.window,
                       time.perf_counter() - started)


#: ``scaling.csv`` figures with ``_low``/``_high`` interval columns (see :func:`.statistics.cell_figures`).
INTERVAL_FIGURES = ("yardstick_iterations", "yardstick_episodes", "success_window_mean", "never_terminal_share")


def cell_row(info: SpecInfo, learner: str, reward: str, gamma: float, records: CellRecords,
             counts: np.ndarray) -> dict:
    """One ``scaling.csv`` row: the cell's figures with their intervals, the yardstick's level and
    whether the cell was censored (did not hold the level to the window's end)."""
    level = YARDSTICK_FRACTION * info.optimal_success
    figures = bootstrap_cell(counts, block_success=records.block_success, widths=block_widths(records.edges),
                             edges=records.edges, episodes=records.episodes, tail_success=records.tail_success,
                             never_terminal=records.never_terminal, level=level)
    row = {"family": info.family, "spec": info.name, "segments": info.segments, "objects": info.objects,
           "reachable": info.reachable, "reachable_from_start": info.reachable_from_start,
           "plan_length": info.plan_length, "gamma": gamma, "learner": learner, "reward": reward,
           "runs": records.runs, "window": info.window, "max_itr": info.max_itr,
           "optimal_success": info.optimal_success, "yardstick_level": level}
    for name in INTERVAL_FIGURES:
        value, low, high = figures[name]
        row[name] = value if math.isfinite(value) else math.nan
        row[name + "_low"], row[name + "_high"] = low, high
    row["censored"] = not math.isfinite(figures["yardstick_iterations"][0])
    row["window_mean_over_optimum"] = row["success_window_mean"] / info.optimal_success
    row["seconds"] = records.seconds
    return row
