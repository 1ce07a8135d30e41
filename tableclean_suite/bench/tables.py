"""Tables 3 and 4 of the paper, ours beside the paper's: pure functions, DataFrames in and out.

A *cell record* is one dict per (experiment, trained cell): ``learner, reward, alpha, gamma,
experiment, cell_id`` plus ``Summary.scalars()``; its curves travel as ``{metric: (iterations,)
array}`` (``Summary.curves()``, `curves_long`).  The paper's numbers are data in `paper_data`.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from tableclean_suite.bench.paper_data import (PAPER_LEARNER, PAPER_TABLE3, PAPER_TABLE4,  # noqa: F401
                                                PAPER_TABLE4_COLUMNS, SOURCE_QUOTED)
from tableclean_suite.bench.statistics import ASYMPTOTES, LEARNING_TIME_COLUMNS, RUN_MEANS, RUN_SHARES
from tableclean_suite.metrics import ITERATION_SCALARS, SUMMARY_SCALARS

#: Identifying columns of a cell record, in table order.
KEY_COLUMNS = ("learner", "reward", "alpha", "gamma", "experiment")

#: Experiments, in table order.
EXPERIMENTS = ("main", "alpha_sweep", "gamma_sweep")

#: Curves written to ``curves.csv`` (the others are cheap to recompute and would triple the file).
CURVE_METRICS = ("success", "average_reward", "episodes")

PAPER_COLUMNS = tuple(c for c in PAPER_TABLE3.columns if c != "reward")

#: Suffixes of an interval's bounds, next to the number they bound.
LOW, HIGH = "_low", "_high"


def _with_bounds(names, bounded) -> tuple[str, ...]:
    """Each of ``names``, followed by its interval's bound columns when it is in ``bounded``."""
    return tuple(c for name in names for c in ((name, name + LOW, name + HIGH) if name in bounded else (name,)))


#: Scalars of [`Summary`][tableclean_suite.metrics.Summary] that carry an interval (per-run means).
INTERVAL_SCALARS = tuple(name for name in SUMMARY_SCALARS if name in RUN_MEANS or name in RUN_SHARES)

#: The per-run learning time's columns, and each scalar, followed by its interval's bounds when it has one.
LEARNING_COLUMNS = _with_bounds(LEARNING_TIME_COLUMNS, LEARNING_TIME_COLUMNS)
SCALAR_COLUMNS = _with_bounds(SUMMARY_SCALARS, INTERVAL_SCALARS)

#: Settling of each cell ([`tableclean_suite.settling`][tableclean_suite.settling]): drift (a fraction) with its
#: interval, the checkpoint iteration and whether the drift is within tolerance (empty: not measured).
DRIFT = "behaviour_drift"
SETTLING_COLUMNS = (DRIFT, DRIFT + LOW, DRIFT + HIGH, "checkpoint_iteration", "settled")

#: Every column of ``table3.csv``; an interval column ``X`` has its bounds in ``X_low``/``X_high``.
TABLE3_COLUMNS = ("cell_id", *KEY_COLUMNS, *LEARNING_COLUMNS, *SCALAR_COLUMNS, *SETTLING_COLUMNS, *PAPER_COLUMNS)

#: Table 4's numbers of our rows: the paper's three and the per-run learning time.
TABLE4_NUMBERS = (*PAPER_TABLE4_COLUMNS[1:], "learning_time_median", "censored_percent")
#: Table 4's numbers that carry intervals.
TABLE4_INTERVALS = ("max_success_rate_percent", "learning_time_median", "censored_percent")
TABLE4_COLUMNS = (PAPER_TABLE4_COLUMNS[0], *_with_bounds(TABLE4_NUMBERS, TABLE4_INTERVALS), "source")

#: Widest a printed table may be (characters); the CSV files hold every column.
PRINT_WIDTH = 120

#: ``source`` of a row of this run in Table 4.
SOURCE_OURS = "this run"
#: How the printed Table 4 marks a row trained here and a row quoted from the paper.
MARK_RUN_HERE, MARK_QUOTED = "run here", "quoted"

#: Table 4 names of Cruz et al.'s methods run here (``literature`` cells), by learner.
LITERATURE_METHODS = {
    "affordance_q_learning": "Affordance RL, given affordances (Q-learning)",
    "learned_affordance_q_learning": "Affordance RL, learned affordances (Q-learning)",
    "interactive_q_learning": "Interactive RL, optimal advisor L={L:g} C={C:g} (Q-learning)",
}


def _ordered(values, preferred):
    """``values``' unique entries, ``preferred`` ones first in that order, then the rest as they come."""
    unique = list(dict.fromkeys(values))
    return [v for v in preferred if v in unique] + [v for v in unique if v not in preferred]


def is_paper_task(model, extra_actions: bool = False) -> bool:
    """Whether ``model`` is the paper's task (2 segments, 1 object, its four actions; with ``extra_actions``,
    others besides), whatever its start and ineffective modes, so that the paper's numbers (with
    ``extra_actions``: its Table 1 and plan) can stand beside ours."""
    from tableclean_suite.task import PAPER_SPEC

    actions = (set(PAPER_SPEC.actions) <= set(model.spec.actions) if extra_actions
               else tuple(model.action_names) == tuple(PAPER_SPEC.actions))
    return (model.n_segments, model.n_objects) == (PAPER_SPEC.segments, PAPER_SPEC.n_objects) and actions


def table3(records: list[dict] | pd.DataFrame, compare_with_paper: bool = True) -> pd.DataFrame:
    """Table 3: one row per (experiment, cell), with the paper's values beside the main Q-learning rows.

    Args:
        records: cell records (see module docstring) or a DataFrame of them.
        compare_with_paper: fill the ``paper_*`` columns (False for another task than the paper's:
            they are then all NaN).

    Returns:
        Columns `TABLE3_COLUMNS` (NaN where the records carry none; iteration columns nullable
        integers), plus ``asymptotes`` when some plateaus are simulated; sorted by experiment,
        learner, reward, alpha, gamma.  ``paper_*`` only on the main `PAPER_LEARNER` rows.
    """
    frame = pd.DataFrame(records).copy()
    missing = [c for c in ("cell_id", *KEY_COLUMNS, *SUMMARY_SCALARS) if c not in frame.columns]
    if missing:
        raise ValueError(f"cell records lack columns: {', '.join(missing)}")
    is_paper_row = (frame["experiment"] == "main") & (frame["learner"] == PAPER_LEARNER) & compare_with_paper
    frame = frame.drop(columns=[c for c in PAPER_COLUMNS if c in frame.columns])
    frame = frame.join(PAPER_TABLE3.set_index("reward"), on="reward")
    frame[list(PAPER_COLUMNS)] = frame[list(PAPER_COLUMNS)].where(is_paper_row)
    numbers = list(dict.fromkeys((*SUMMARY_SCALARS, *LEARNING_COLUMNS, *SCALAR_COLUMNS, *SETTLING_COLUMNS[:4])))
    frame = frame.reindex(columns=list(dict.fromkeys((*frame.columns, *numbers, "settled"))))  # NaN: not carried
    frame[numbers] = frame[numbers].astype(float)
    integers = [*ITERATION_SCALARS, "checkpoint_iteration"]
    frame[integers] = frame[integers].astype("Int64")
    frame["checkpoint_iteration"] = frame["checkpoint_iteration"].replace(0, pd.NA)  # empty: not measured
    frame["settled"] = frame["settled"].astype("boolean")
    frame["alpha"] = frame["alpha"].astype(float)
    frame["gamma"] = frame["gamma"].astype(float)
    first = {"experiment": EXPERIMENTS, "learner": ("q_learning", "sarsa"), "reward": ("r1", "r2", "r3", "r4")}
    rank = {k: {v: i for i, v in enumerate(_ordered(frame[k], order))} for k, order in first.items()}
    frame = frame.sort_values([*first, "alpha", "gamma"], key=lambda c: c.map(rank[c.name]) if c.name in rank else c,
                              kind="stable")
    simulated = ASYMPTOTES in frame.columns and bool((frame[ASYMPTOTES] != "exact").any())
    return frame[[*TABLE3_COLUMNS, *([ASYMPTOTES] if simulated else [])]].reset_index(drop=True)


def _missing(value) -> bool:
    return value is None or value is pd.NA or (isinstance(value, float) and math.isnan(value))


def main_rows(table: pd.DataFrame) -> pd.DataFrame:
    """The ``experiment == "main"`` rows of a [`table3`][tableclean_suite.bench.tables.table3] frame."""
    return table[table["experiment"] == "main"].reset_index(drop=True)


def literature_method(learner: str, reward: str) -> str:
    """Table 4's name of a ``literature`` cell, e.g. ``"This run: Affordance RL, given affordances
    (Q-learning) with reward r4"`` (the advisor's L and C are the registered learner's)."""
    from tableclean_suite.learners import get_learner

    template = LITERATURE_METHODS.get(learner, learner)
    registered = get_learner(learner) if learner in LITERATURE_METHODS else None
    name = template.format(L=registered.advice_probability, C=registered.advice_consistency) if registered else template
    return f"This run: {name} with reward {reward}"


#: How the paper's Table 4 names its own rows (quoted only beside a run of the paper's task).
PAPER_OWN_ROWS = "This work"


def table4(table: pd.DataFrame, paper_task: bool = True) -> pd.DataFrame:
    """Table 4: our main Q-learning rows and Cruz et al.'s methods run here, then the paper's rows
    (all quoted and marked so).

    Args:
        table: a [`table3`][tableclean_suite.bench.tables.table3] frame.
        paper_task: [`is_paper_task`][tableclean_suite.bench.tables.is_paper_task]; if not, the paper's
            own rows (`PAPER_OWN_ROWS`) are left out.

    Returns:
        Columns `TABLE4_COLUMNS`; our rows (``source == "this run"``, named ``"This run: Q-learning
        with reward rN"`` or by [`literature_method`][tableclean_suite.bench.tables.literature_method])
        give ``max_success_rate_percent`` = 100 x ``success_plateau`` and the learning time.
    """
    main = table[(table["experiment"] == "main") & (table["learner"] == PAPER_LEARNER)]
    literature = table[table["experiment"] == "literature"]
    ours = pd.concat([main, literature], ignore_index=True)
    sources = {"average_reward_convergence_episodes": ("reward_convergence_episodes", 1.0),
               "max_success_rate_percent": ("success_plateau", 100.0),
               "max_success_episodes": ("max_success_episodes", 1.0),
               "learning_time_median": ("learning_time_median", 1.0),
               "censored_percent": ("censored_share", 100.0)}
    data = {"methodology": [f"This run: Q-learning with reward {r}" for r in main["reward"]]
            + [literature_method(l, r) for l, r in zip(literature["learner"], literature["reward"])]}
    for name, (column, scale) in sources.items():
        for suffix in (("", LOW, HIGH) if name in TABLE4_INTERVALS else ("",)):
            data[name + suffix] = scale * ours[column + suffix].astype(float).to_numpy()
    rows = pd.DataFrame({**data, "source": SOURCE_OURS})
    quoted = PAPER_TABLE4.astype({c: float for c in PAPER_TABLE4_COLUMNS[1:]})
    if not paper_task:
        quoted = quoted[~quoted["methodology"].str.startswith(PAPER_OWN_ROWS)]
    return pd.concat([rows, quoted], ignore_index=True)[list(TABLE4_COLUMNS)]


def with_interval(value, low, high, digits: int = 0, scale: float = 1.0) -> str:
    """``"222 [205, 240]"``: a number and its interval, rounded to ``digits``; "-" when missing;
    an infinite value or bound (a time beyond the budget) reads ``>T``-style as ``inf``."""
    if _missing(value):
        return "-"
    def text(v):
        return "inf" if math.isinf(float(v)) else f"{scale * float(v):.{digits}f}"
    if _missing(low) or _missing(high):
        return text(value)
    return f"{text(value)} [{text(low)}, {text(high)}]"


def _interval_texts(rows: pd.DataFrame, column: str, digits: int, scale: float = 1.0) -> list[str]:
    """[`with_interval`][tableclean_suite.bench.tables.with_interval] of ``column`` and its bounds, row by row."""
    return [with_interval(v, lo, hi, digits, scale) for v, lo, hi in zip(rows[column], rows[column + LOW],
                                                                          rows[column + HIGH])]


def _by_cell(rows: pd.DataFrame, columns: dict) -> pd.DataFrame:
    """``columns`` as a frame indexed by the rows' (learner, reward)."""
    return pd.DataFrame(columns, index=pd.MultiIndex.from_frame(rows[["learner", "reward"]]))


def display_learning_time(table: pd.DataFrame) -> pd.DataFrame:
    """Table 3's headline for printing, main rows: the per-run learning time (iterations until
    the run's greedy policy is optimal for good) - median, quartiles, restricted mean to the
    budget, censored share - each with its interval."""
    rows = main_rows(table)
    quartiles = [f"{with_interval(q1, None, None)}-{with_interval(q3, None, None)}"
                 for q1, q3 in zip(rows["learning_time_q1"], rows["learning_time_q3"])]
    return _by_cell(rows, {"median [CI]": _interval_texts(rows, "learning_time_median", 0),
                           "quartiles": quartiles,
                           "RMST [CI]": _interval_texts(rows, "learning_time_rmst", 0),
                           "censored % [CI]": _interval_texts(rows, "censored_share", 1, 100.0)})


def display_plateaus(table: pd.DataFrame) -> pd.DataFrame:
    """Table 3's plateaus for printing, main rows: per-run asymptotes averaged over runs,
    with intervals, the paper's success rate beside ours, the behaviour drift and settling (and how
    the asymptotes were computed when some are simulated: ``asymptotes``)."""
    rows = main_rows(table)
    paper = (100.0 * rows["paper_success_rate"].astype(float)).round(2)
    return _by_cell(rows, {"success % [CI]": _interval_texts(rows, "success_plateau", 2, 100.0),
                           "paper": [_quoted_text(v, 2) for v in paper],
                           "greedy success % [CI]": _interval_texts(rows, "greedy_success_plateau", 2, 100.0),
                           "never terminal %": _interval_texts(rows, "never_terminal_share", 1, 100.0),
                           "drift pp [CI]": _interval_texts(rows, DRIFT, 2, 100.0),
                           "settled": _settled_marks(rows["settled"]),
                           **({ASYMPTOTES: rows[ASYMPTOTES].tolist()} if ASYMPTOTES in rows.columns else {})})


def plateaus_kind(table: pd.DataFrame) -> str:
    """How the main rows' plateaus were computed, for Table 3b's legend: ``exact``, the simulation's
    label when all are simulated alike, else ``exact or simulated (column 'asymptotes')``; a
    simulation's Monte Carlo error is inside the intervals."""
    if ASYMPTOTES not in table.columns:
        return "exact"
    kinds = list(dict.fromkeys(main_rows(table)[ASYMPTOTES]))
    if kinds == ["exact"]:
        return "exact"
    if len(kinds) == 1:
        return f"{kinds[0][:-1]}; Monte Carlo error inside the intervals)"
    return "exact or simulated (column 'asymptotes'; Monte Carlo error inside the intervals)"


#: The paper's definitions printed beside its values: title, our column, the paper's, digits.
PAPER_DEFINITIONS = (
    ("conv. itr", "reward_convergence_iterations", "paper_reward_convergence_iterations", 0),
    ("conv. eps", "reward_convergence_episodes", "paper_reward_convergence_episodes", 1),
    ("touch itr", "max_success_iterations", "paper_max_success_iterations", 0),
    ("touch eps", "max_success_episodes", "paper_max_success_episodes", 1),
)


def display_paper_definitions(table: pd.DataFrame) -> pd.DataFrame:
    """The paper's Table 3 definitions for printing, main rows: readings of the mean curves
    (average-reward convergence, first touch of the success plateau, maximum average reward),
    ours with the paper's in parentheses, without intervals; and the average-reward plateau."""
    rows = main_rows(table)
    data = {}
    for title, ours, paper, digits in PAPER_DEFINITIONS:
        data[title] = [_quoted_text(v, digits) + ("" if _missing(p) else f" ({_quoted_text(p, digits)})")
                       for v, p in zip(rows[ours], rows[paper])]
    data["max avg r"] = [_quoted_text(v, 3) for v in rows["max_average_reward"]]
    data["avg r plateau [CI]"] = _interval_texts(rows, "average_reward_plateau", 3)
    return _by_cell(rows, data)


def display_comparisons(frame: pd.DataFrame) -> pd.DataFrame:
    """Probabilities of improvement for printing: "X over Y", the score, P [CI]."""
    return pd.DataFrame({
        "comparison": [f"{rx} over {ry} ({lx})" if lx == ly else f"{lx} over {ly} ({rx})"
                       for lx, rx, ly, ry in zip(frame["learner_x"], frame["reward_x"], frame["learner_y"],
                                                 frame["reward_y"])],
        "score": frame["score"],
        "P(improvement) [CI]": [with_interval(p, lo, hi, 2) for p, lo, hi in zip(
            frame["probability_of_improvement"], frame["probability_of_improvement_low"],
            frame["probability_of_improvement_high"])],
    })


def display_sweeps(table: pd.DataFrame) -> pd.DataFrame:
    """The sweep rows for printing (no paper columns: the paper gives only Figures 6-7)."""
    rows = table[table["experiment"].isin(["alpha_sweep", "gamma_sweep"])].reset_index(drop=True)
    return rows[["experiment", "learner", "reward", "alpha", "gamma"]].assign(**{
        "median [CI]": _interval_texts(rows, "learning_time_median", 0),
        "censored %": [_quoted_text(100.0 * v, 1) for v in rows["censored_share"]],
        "first touch": [_quoted_text(v, 0) for v in rows["max_success_iterations"]],
        "success % [CI]": _interval_texts(rows, "success_plateau", 2, 100.0),
        "settled": _settled_marks(rows["settled"])})


def _settled_marks(flags) -> list[str]:
    """``yes``/``NO`` per settled flag, ``-`` where settling was not measured."""
    return ["-" if flag is pd.NA else ("yes" if flag else "NO") for flag in flags]


def _quoted_text(value, digits: int) -> str:
    """A number without interval: "-" if missing, rounded to ``digits``, no trailing ".0"."""
    if _missing(value):
        return "-"
    return f"{round(float(value), digits):g}"


def _short_method(name: str) -> str:
    """A Table 4 method's name for printing (the ``source`` column says where it comes from)."""
    for long, short in (("This run: ", ""), (" (Q-learning)", ""), (" with reward ", ", "),
                        ("optimal advisor ", "advisor ")):
        name = name.replace(long, short)
    return name


def display_table4(table4_frame: pd.DataFrame) -> pd.DataFrame:
    """Table 4 for printing: numbers rounded (ours with their intervals), "-" where the paper gives
    none, a ``source`` column saying "run here" or "quoted" on every row."""
    frame = table4_frame
    return pd.DataFrame({
        "source": [MARK_QUOTED if s == SOURCE_QUOTED else MARK_RUN_HERE for s in frame["source"]],
        "method": [_short_method(m) for m in frame["methodology"]],
        "conv. eps": [_quoted_text(v, 1) for v in frame["average_reward_convergence_episodes"]],
        "success % [CI]": [_quoted_text(v, 2) if _missing(lo) else with_interval(v, lo, hi, 2) for v, lo, hi in zip(
            frame["max_success_rate_percent"], frame["max_success_rate_percent" + LOW],
            frame["max_success_rate_percent" + HIGH])],
        "succ. eps": [_quoted_text(v, 1) for v in frame["max_success_episodes"]],
        "learning time [CI]": _interval_texts(frame, "learning_time_median", 0),
    })


def curves_long(records: list[dict], curves: list[dict], metrics=CURVE_METRICS, stride: int = 1) -> pd.DataFrame:
    """Curves in long format: one row per (record, iteration, metric).

    Args:
        records: cell records (only `KEY_COLUMNS` are used).
        curves: per record, ``{metric: ndarray (iterations,)}``.
        metrics: which curves to include.
        stride: keep iterations 1, 1 + stride, ... (and always the last).

    Returns:
        Columns ``learner, reward, alpha, gamma, experiment, iteration`` (1-based) ``, metric, value,
        low, high`` (the band where the curve set has ``<metric>_low``/``_high``, else NaN).
    """
    if len(records) != len(curves):
        raise ValueError(f"{len(records)} records but {len(curves)} curve sets")
    if stride < 1:
        raise ValueError(f"stride must be >= 1, got {stride}")
    parts = []
    for record, curve_set in zip(records, curves):
        for metric in metrics:
            values = np.asarray(curve_set[metric], dtype=float)
            keep = np.arange(0, len(values), stride)
            if len(values) and keep[-1] != len(values) - 1:
                keep = np.r_[keep, len(values) - 1]
            bounds = {side: np.asarray(curve_set.get(f"{metric}_{side}", np.full(len(values), np.nan)), dtype=float)
                      for side in ("low", "high")}
            parts.append(pd.DataFrame({**{key: record[key] for key in KEY_COLUMNS}, "iteration": keep + 1,
                                       "metric": metric, "value": values[keep], "low": bounds["low"][keep],
                                       "high": bounds["high"][keep]}))
    if not parts:
        return pd.DataFrame(columns=[*KEY_COLUMNS, "iteration", "metric", "value", "low", "high"])
    return pd.concat(parts, ignore_index=True)


#: ``float_format`` of ``curves.csv`` (printf style, as ``DataFrame.to_csv(float_format=...)``).
CURVES_FLOAT_FORMAT = "%.6g"

#: Characters that make ``DataFrame.to_csv`` quote a text field (then `csv_text` defers to pandas).
_CSV_SPECIAL = (",", '"', "\n", "\r")


def csv_text(frame: pd.DataFrame) -> str:
    """``frame.to_csv(index=False, float_format=CURVES_FLOAT_FORMAT)`` byte for byte, formatting float64,
    integer and plain-text columns here (each distinct float bit pattern once; pandas formats every cell
    through Python calls, which doubled the time of a run that reuses its cells); anything else (other
    dtypes, non-string objects, text that needs quoting) is left to pandas."""
    def plain(texts) -> bool:
        return all(type(text) is str and not any(c in text for c in _CSV_SPECIAL) for text in texts)

    names, columns = list(frame.columns), []
    for name in names:
        series = frame[name]
        if series.dtype == np.float64:
            codes, bits = pd.factorize(np.ascontiguousarray(series.to_numpy()).view(np.int64))
            texts = [CURVES_FLOAT_FORMAT % v if v == v else "" for v in np.asarray(bits).view(np.float64).tolist()]
            columns.append(np.asarray(texts, dtype=object)[codes].tolist())
        elif series.dtype.kind in "iu":
            columns.append([str(v) for v in series.to_numpy().tolist()])
        elif series.dtype.kind == "O" and plain(set(series.tolist())):
            columns.append(series.tolist())
        else:
            names = []
            break
    if not names or not plain(names):
        return frame.to_csv(index=False, float_format=CURVES_FLOAT_FORMAT)
    return "".join(line + "\n" for line in (",".join(names), *map(",".join, zip(*columns))))
