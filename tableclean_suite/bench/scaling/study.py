"""Training one cell of the scaling study (spec x gamma x learner x reward, S seeds of R runs), in
run chunks of at most ``CHUNK_BYTES`` of records, each reduced to per-run figures as it goes;
`cell_row` turns a trained cell into its ``scaling.csv`` row and bootstrap medians.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from tableclean_suite.bench.scaling.family import ALPHA, EPSILON, SpecInfo
from tableclean_suite.bench.scaling.statistics import (learning_times, lower_median, percentile_bounds,
                                                       pooled_resamples, seeds_then_runs)
from tableclean_suite.metrics import plateau_start
from tableclean_suite.resources import RECORD_CODE_ARRAYS, WORD_BYTES

#: Records of one training chunk stay below this many bytes (runs per chunk follow from it).
CHUNK_BYTES = 64 * 2**20


def window_sums(outcomes, episode_end, tail_start: int) -> tuple[np.ndarray, np.ndarray]:
    """Per run of ``(R, T)`` records: ``(tail, never)``, the ``(R,)`` int64 count of iterations from
    ``tail_start`` on whose run's latest finished episode succeeded (reached the terminal state with no
    improper action), and ``(R,)`` 1.0 where the run never had a terminal outcome, else 0.0."""
    from tableclean_suite.learners.kernel import EPISODE_TERMINAL
    from tableclean_suite.task import Outcome

    runs, window = outcomes.shape
    improper = np.cumsum(outcomes == int(Outcome.IMPROPER), axis=1, dtype=np.int32)
    run, last = np.nonzero(episode_end)
    same_run = run[1:] == run[:-1]
    before = np.where(np.r_[False, same_run], improper[run, np.r_[0, last[:-1]]], 0)
    success = (episode_end[run, last] == EPISODE_TERMINAL) & (improper[run, last] == before)
    held = np.where(np.r_[same_run, False], np.r_[last[1:], 0], window) - np.maximum(last, tail_start)
    tail = np.bincount(run, weights=success * np.maximum(held, 0), minlength=runs).astype(np.int64)
    return tail, (~(outcomes == int(Outcome.TERMINAL)).any(axis=1)).astype(np.float64)


@dataclass
class CellRecords:
    """What one trained cell keeps, per seed (rows) and run (columns).

    Attributes:
        seeds: ``(S,)`` the training seeds.
        learned_at: ``(S, R)`` int64 learning times (iterations; -1 = censored at the window).
        tail_success: ``(S, R)`` each run's success over the window's last quarter (the window mean).
        never_terminal: ``(S, R)`` 1.0 for a run that never reached the terminal state.
        seconds: wall time of training and reduction.
    """

    seeds: tuple
    learned_at: np.ndarray
    tail_success: np.ndarray
    never_terminal: np.ndarray
    seconds: float


def runs_per_chunk(window: int, n_states: int, n_actions: int, itemsize: int, runs: int) -> int:
    """Runs per training chunk so one chunk's records and Q-tables stay below ``CHUNK_BYTES``."""
    per_run = window * (WORD_BYTES + RECORD_CODE_ARRAYS * itemsize) + n_states * n_actions * WORD_BYTES
    return max(1, min(runs, CHUNK_BYTES // per_run))


def train_cell(model, info: SpecInfo, learner: str, reward: str, runs: int, seeds, gamma: float) -> CellRecords:
    """Train ``runs`` runs for each of ``seeds`` (discount ``gamma``) in chunks, keeping per-run figures."""
    from tableclean_suite.learners import train

    started = time.perf_counter()
    seeds = tuple(int(s) for s in seeds)
    learned = np.zeros((len(seeds), runs), dtype=np.int64)
    tail = np.zeros((len(seeds), runs), dtype=np.int64)
    never = np.zeros((len(seeds), runs), dtype=np.float64)
    tail_start = plateau_start(info.window)
    chunk = runs_per_chunk(info.window, model.n_states, model.n_actions, np.dtype(model.record_dtype).itemsize, runs)
    for row, seed in enumerate(seeds):
        for first in range(0, runs, chunk):
            count = min(chunk, runs - first)
            result = train(learner=learner, reward=reward, runs=count, iterations=info.window, alpha=ALPHA,
                           gamma=gamma, epsilon=EPSILON, max_itr=info.max_itr, seed=seed, task=model,
                           first_run=first)
            part = slice(first, first + count)
            learned[row, part] = result.learned_at
            tail[row, part], never[row, part] = window_sums(result.outcomes, result.episode_end, tail_start)
            del result
    return CellRecords(seeds, learned, tail / (info.window - tail_start), never, time.perf_counter() - started)


def cell_row(info: SpecInfo, learner: str, reward: str, gamma: float, records: CellRecords, resamples: int,
             rng: np.random.Generator) -> tuple[dict, np.ndarray]:
    """One ``scaling.csv`` row and the cell's ``(resamples,)`` bootstrap medians.

    The point figures pool every seed's runs (the Kaplan-Meier median, which is the
    [lower_median][tableclean_suite.bench.scaling.statistics.lower_median] as every run shares the
    budget, the restricted mean to the window and the censored share); every
    interval is the percentile interval of seeds-then-runs resamples
    ([`seeds_then_runs`][tableclean_suite.bench.scaling.statistics.seeds_then_runs]), one set of draws
    per cell shared by its figures.  ``seed_medians`` lists each seed's own median.
    """
    times = learning_times(records.learned_at)
    n_seeds, runs = times.shape
    index = seeds_then_runs(n_seeds, runs, resamples, rng)
    medians = lower_median(pooled_resamples(times, index))
    pooled = times.ravel()
    median = float(lower_median(pooled))
    row = {"family": info.family, "spec": info.name, "segments": info.segments, "objects": info.objects,
           "reachable": info.reachable, "reachable_from_start": info.reachable_from_start,
           "plan_length": info.plan_length, "gamma": gamma, "learner": learner, "reward": reward,
           "seeds": n_seeds, "runs": runs, "window": info.window, "max_itr": info.max_itr,
           "optimal_success": info.optimal_success}
    low, high = percentile_bounds(medians)
    row.update(learning_time=median, learning_time_low=low, learning_time_high=high,
               censored_share=float(np.isinf(pooled).mean()),
               learning_time_rmst=float(np.minimum(pooled, info.window).mean()),
               seed_medians=";".join(f"{m:g}" for m in lower_median(times)))
    for name, values in (("success_window_mean", records.tail_success), ("never_terminal_share",
                                                                         records.never_terminal)):
        row[name] = float(values.mean())
        row[name + "_low"], row[name + "_high"] = percentile_bounds(pooled_resamples(values, index).mean(axis=1))
    row["censored"] = not math.isfinite(median)
    row["window_mean_over_optimum"] = row["success_window_mean"] / info.optimal_success
    row["seconds"] = records.seconds
    return row, medians

