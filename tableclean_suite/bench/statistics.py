"""A cell's intervals, curve bands and per-run scores, and the comparisons between cells.

Every interval comes from [tableclean_suite.intervals][] at the run's ``--confidence`` and targets
the statistic's value over unlimited runs of the cell: means over runs (`RUN_MEANS`, behaviour
drift) get [mean_intervals][tableclean_suite.intervals.mean_intervals], shares of runs
(`RUN_SHARES`, or a quantity 0 or 1 in every run) Clopper-Pearson, curves a normal band per
iteration; cells are compared on `RUN_SCORES` by the probability of improvement.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from statistics import NormalDist

import numpy as np

from tableclean_suite import intervals
from tableclean_suite.intervals import DEFAULT_CONFIDENCE, DEFAULT_REPS
from tableclean_suite.learning_time import LearningTime, censored_times, learning_time_summary, survival_curve
from tableclean_suite.settling import Settling

#: Curves that get bands (the ones the figures draw).
BAND_CURVES = ("success", "average_reward")
#: The Kaplan-Meier curve of the per-run learning time, as a curve of the figures: the share of
#: runs not yet optimal for good at each iteration.
NOT_LEARNED = "not_learned"
#: Table 3 scalars that are means over runs of a per-run asymptote: scalar -> per-run quantity
#: ([final_run_facts][tableclean_suite.analysis.final_run_facts]), each with a bootstrap interval over runs.
RUN_MEANS = {"success_plateau": "success", "average_reward_plateau": "average_reward",
             "terminal_plateau": "terminal", "greedy_success_plateau": "greedy_success"}
#: The cell record's column naming how its plateaus were computed: ``exact`` or
#: ``simulated (N episodes per run)`` ([tableclean_suite.analysis.AnalysisPlan][]'s label).
ASYMPTOTES = "asymptotes"
#: Table 3 scalars that are shares of runs (yes/no per run), with a Clopper-Pearson interval.
RUN_SHARES = {"never_terminal_share": "never_terminal"}
#: Per-run scores compared between cells: name -> whether higher is better.
RUN_SCORES = {"learning_time": False, "success_asymptote": True}
#: Practical-equivalence margin of each per-run score (its own units): learning times are exact
#: step counts (0; censored runs tie at the budget); success asymptotes of converged runs differ
#: by exploration noise well below one percentage point (0.01).
EQUIVALENCE_MARGINS = {"learning_time": 0.0, "success_asymptote": 0.01}


def bootstrap_rng(seed: int, label: str) -> np.random.Generator:
    """A generator for one cell's bootstrap: seeded by the run's seed and the cell's label."""
    digest = int.from_bytes(hashlib.sha256(label.encode()).digest()[:8], "little")
    return np.random.default_rng([int(seed), digest])


#: The range of each of [ESTIMATED_FACTS][tableclean_suite.analysis.ESTIMATED_FACTS]: a widened interval is
#: clipped to it.
FACT_LIMITS = {"success": (0.0, 1.0), "terminal": (0.0, 1.0), "greedy_success": (0.0, 1.0),
               "average_reward": (-math.inf, math.inf)}


def with_monte_carlo_error(point: float, low: float, high: float, error: float, confidence: float,
                           limits: tuple[float, float] = (-math.inf, math.inf)) -> tuple[float, float]:
    """An interval ``(low, high)`` around ``point`` (e.g. a bootstrap over runs) widened by a Monte
    Carlo standard ``error``: each side's half-width and ``z x error`` (z the normal quantile of
    ``confidence``) added in quadrature, ``point -+ sqrt(half ** 2 + (z x error) ** 2)``, clipped to
    the quantity's ``limits`` (e.g. `FACT_LIMITS`).  The bootstrap already resamples the simulated
    values, so this errs towards covering.  ``error`` 0: unchanged; NaN: a NaN interval.
    """
    if error == 0.0:
        return low, high
    if not math.isfinite(error):
        return math.nan, math.nan
    z = NormalDist().inv_cdf(0.5 + confidence / 2.0)
    spread = z * float(error)
    return (max(limits[0], point - math.hypot(point - low, spread)),
            min(limits[1], point + math.hypot(high - point, spread)))


@dataclass
class CellStatistics:
    """A cell's intervals, curve bands, per-run scores and learning-time summary.

    Attributes:
        intervals: ``{scalar: (low, high)}`` for the Table 3 scalars that have an interval
            (`RUN_MEANS`, `RUN_SHARES`).
        bands: ``{curve: (low, high)}``, each ``(T,)``, for the curves in `BAND_CURVES`.
        runs: ``{score: (R,) array}`` per-run scores (`RUN_SCORES`; ``learning_time``
            only when the runs recorded it, censored runs at the budget).
        learning: the per-run learning time's summary (None when the runs did not record it).
        survival: ``(T,)`` its Kaplan-Meier curve, the share of runs not yet optimal for good at
            iterations 1 .. T (its band is ``bands["not_learned"]``); None when not recorded.
        settling: the behaviour drift over the window's last quarter ([settling][tableclean_suite.settling]).
    """

    intervals: dict = field(default_factory=dict)
    bands: dict = field(default_factory=dict)
    runs: dict = field(default_factory=dict)
    learning: LearningTime | None = None
    survival: np.ndarray | None = None
    settling: Settling = field(default_factory=Settling.not_measured)


def curve_bands(sums, support_fraction: float, confidence: float = DEFAULT_CONFIDENCE) -> dict:
    """``{"success", "average_reward": (low, high)}``, each ``(T,)``: the per-iteration
    [mean_band][tableclean_suite.intervals.mean_band] of the mean curves of a
    [`CurveSums`][tableclean_suite.curves.CurveSums] (a run's success is 0 or 1, so its square is
    itself); NaN where the average reward is not supported."""
    from tableclean_suite.curves import supported

    success = intervals.mean_band(sums.success, sums.success, np.full(sums.iterations, float(sums.runs)), confidence)
    low, high = intervals.mean_band(sums.average_sum, sums.average_square, sums.finished_runs, confidence)
    defined = supported(sums.finished_runs, sums.runs, support_fraction)
    return {"success": success, "average_reward": (np.where(defined, low, np.nan), np.where(defined, high, np.nan))}


def cell_statistics(sums, per_run: dict, rng: np.random.Generator, support_fraction: float,
                    samples: int = DEFAULT_REPS, confidence: float = DEFAULT_CONFIDENCE,
                    learned_at: np.ndarray | None = None, budget: int | None = None,
                    drift: np.ndarray | None = None, checkpoint: int = 0,
                    monte_carlo: dict | None = None,
                    average_reward_limits: tuple[float, float] = (-np.inf, np.inf)) -> CellStatistics:
    """Intervals, bands and per-run scores of one cell (see the module docstring).

    Args:
        sums: the cell's [`CurveSums`][tableclean_suite.curves.CurveSums].
        per_run: ``{quantity: (R,)}`` per-run asymptotes, in run order.
        rng: the cell's generator ([`bootstrap_rng`][tableclean_suite.bench.statistics.bootstrap_rng]),
            drawn in a fixed order.
        support_fraction: as [`curves`][tableclean_suite.curves.CurveSums.curves]'.
        samples: bootstrap resamples (>= 1).
        confidence: interval confidence in (0, 1).
        learned_at: ``(R,)`` per-run learning times (``TrainingResult.learned_at``); None: not recorded.
        budget: the iterations each run trained (needed with ``learned_at``).
        drift: per-run behaviour drift ``(R,)`` ([behaviour_drift][tableclean_suite.settling.behaviour_drift]);
            None: not measured.
        checkpoint: the iteration ``drift`` compares with (>= 1 when ``drift`` is given).
        monte_carlo: ``{quantity: standard error}`` of simulated asymptotes' means
            ([tableclean_suite.analysis.monte_carlo_error][]); None or empty: exact.
        average_reward_limits: bounds on a run's average reward per step
            ([step_reward_bounds][tableclean_suite.rewards.RewardPattern.step_reward_bounds]; the
            other quantities lie in [0, 1]).
    """
    present = {scalar: np.asarray(per_run[name], dtype=np.float64)
               for scalar, name in {**RUN_MEANS, **RUN_SHARES}.items() if name in per_run}
    shares = {scalar: values for scalar, values in present.items()
              if scalar in RUN_SHARES or np.isin(values, (0.0, 1.0)).all()}
    means = {scalar: values for scalar, values in present.items() if scalar not in shares}
    limits = {**{scalar: (0.0, 1.0) for scalar in present}, "average_reward_plateau": average_reward_limits}
    _, bounds = intervals.mean_intervals(means, limits, confidence, samples, rng=rng)
    for scalar, values in shares.items():
        bounds[scalar] = intervals.clopper_pearson(int(np.count_nonzero(values)), len(values), confidence)
    for scalar, name in RUN_MEANS.items():
        if scalar in bounds and name in (monte_carlo or {}):
            bounds[scalar] = with_monte_carlo_error(float(present[scalar].mean()), *bounds[scalar], monte_carlo[name],
                                                    confidence, FACT_LIMITS[name])
    runs = {"success_asymptote": np.asarray(per_run["success"], dtype=np.float64)}
    learning = survival = None
    bands = curve_bands(sums, support_fraction, confidence)
    if learned_at is not None:
        learning = learning_time_summary(learned_at, budget, confidence, samples, rng=rng)
        runs["learning_time"] = censored_times(learned_at, budget)[0]  # censored runs count as the budget
        survival, *bands[NOT_LEARNED] = survival_curve(learned_at, budget, confidence)
    settled = Settling.not_measured()
    if drift is not None:
        points, drift_bounds = intervals.mean_intervals({"drift": drift}, {"drift": (0.0, 1.0)}, confidence, samples,
                                                        rng=rng)
        settled = Settling(points["drift"], *drift_bounds["drift"], int(checkpoint))
    return CellStatistics(bounds, bands, runs, learning, survival, settled)


#: Table 3 columns of the per-run learning time ([`LearningTime`][tableclean_suite.learning_time.LearningTime]
#: field of each), every one followed by its ``_low``/``_high`` interval bounds in ``table3.csv``.
LEARNING_TIME_COLUMNS = {"learning_time_median": "median", "learning_time_q1": "q1", "learning_time_q3": "q3",
                         "learning_time_rmst": "rmst", "censored_share": "censored_share"}


def learning_time_record(learning: LearningTime | None) -> dict:
    """The `LEARNING_TIME_COLUMNS` of a cell record with their bounds (NaN when not recorded)."""
    record = {}
    for column, name in LEARNING_TIME_COLUMNS.items():
        stem = "censored" if name == "censored_share" else name
        values = ((getattr(learning, name), getattr(learning, f"{stem}_low"), getattr(learning, f"{stem}_high"))
                  if learning is not None else (np.nan, np.nan, np.nan))
        record[column], record[f"{column}_low"], record[f"{column}_high"] = values
    return record


def comparisons(cells: list[dict], confidence: float = DEFAULT_CONFIDENCE, samples: int = DEFAULT_REPS,
                seed: int = 0):
    """Probabilities of improvement between reward patterns (same learner) and between learners
    (same reward), on every per-run score both cells have.

    Args:
        cells: ``{"learner", "reward", "runs": {score: (R,)}}`` of the main cells.

    Returns:
        A DataFrame with columns `COMPARISON_COLUMNS` (X improves on Y by more than
        ``margin`` with that probability; pairs within it count half).
    """
    import pandas as pd

    return pd.DataFrame(comparison_rows(cells, confidence, samples, seed), columns=COMPARISON_COLUMNS)


def comparison_rows(cells: list[dict], confidence: float = DEFAULT_CONFIDENCE, samples: int = DEFAULT_REPS,
                    seed: int = 0) -> list[dict]:
    """The rows of [`comparisons`][tableclean_suite.bench.statistics.comparisons] as dicts of plain
    values (str, bool, float), in a fixed order, every interval drawn from one generator seeded by ``seed``."""
    rows = []
    rng = np.random.default_rng(seed)
    for i, x in enumerate(cells):
        for y in cells[i + 1:]:
            same_learner, same_reward = x["learner"] == y["learner"], x["reward"] == y["reward"]
            if same_learner == same_reward:
                continue
            for score, higher in RUN_SCORES.items():
                if score not in x["runs"] or score not in y["runs"]:
                    continue
                margin = EQUIVALENCE_MARGINS[score]
                p, low, high = intervals.improvement_estimate(x["runs"][score], y["runs"][score], higher, margin,
                                                              confidence, samples, rng=rng)
                rows.append(dict(zip(COMPARISON_COLUMNS, ("reward" if same_learner else "learner", x["learner"],
                                                          x["reward"], y["learner"], y["reward"], score, higher,
                                                          margin, p, low, high))))
    return rows


#: Columns of [`comparisons`][tableclean_suite.bench.statistics.comparisons], in order.
COMPARISON_COLUMNS = ("comparison", "learner_x", "reward_x", "learner_y", "reward_y", "score", "higher_is_better",
                      "margin", "probability_of_improvement", "probability_of_improvement_low",
                      "probability_of_improvement_high")
