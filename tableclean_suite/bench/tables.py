"""Tables 3 and 4 of the paper, ours beside the paper's: pure functions, DataFrames in and out.

Nothing here trains, reads or writes files; :mod:`tableclean_suite.bench.run` does that.

Data contract: a *cell record* is one dict per (experiment, trained cell) with the keys
``learner, reward, alpha, gamma, experiment, cell_id`` plus the scalar fields of
:class:`tableclean_suite.metrics.Summary` (:data:`SUMMARY_SCALARS`, from ``Summary.scalars()``).
Curves travel as ``{metric: ndarray of shape (iterations,)}`` per record (``Summary.curves()``;
see :func:`curves_long`).

The paper's numbers (its Tables 3 and 4, quoted verbatim) are data in :mod:`.paper_data`.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from tableclean_suite.bench.paper_data import (  # noqa: F401  (re-exported)
    PAPER_LEARNER,
    PAPER_TABLE3,
    PAPER_TABLE4,
    PAPER_TABLE4_COLUMNS,
    SOURCE_QUOTED,
)
from tableclean_suite.bench.statistics import EQUIVALENCE_MARGINS, RUN_SCORES
from tableclean_suite.metrics import ITERATION_SCALARS, SUMMARY_SCALARS

#: Identifying columns of a cell record, in table order.
KEY_COLUMNS = ("learner", "reward", "alpha", "gamma", "experiment")

#: Experiments, in table order.
EXPERIMENTS = ("main", "alpha_sweep", "gamma_sweep")

#: Curves written to ``curves.csv`` (the others are cheap to recompute and would triple the file).
CURVE_METRICS = ("success", "average_reward", "episodes")

PAPER_COLUMNS = tuple(c for c in PAPER_TABLE3.columns if c != "reward")

#: Scalars a cell record may lack (added after records of this shape existed; NaN when missing).
OPTIONAL_SCALARS = ("success_window_mean", "average_reward_window_mean", "held_success_iterations",
                    "held_success_episodes", "greedy_success_plateau", "never_terminal_share")

#: Suffixes of an interval's bounds, next to the number they bound.
LOW, HIGH = "_low", "_high"

#: Per-run scores whose IQM Table 3 reports (see :mod:`.statistics`).
IQM_COLUMNS = tuple(f"{score}_iqm{suffix}" for score in RUN_SCORES for suffix in ("", LOW, HIGH))

#: Each scalar followed by its interval's bounds.
SCALAR_COLUMNS = tuple(c for name in SUMMARY_SCALARS for c in (name, name + LOW, name + HIGH))

#: Settling of each cell (:mod:`tableclean_suite.settling`): mean behaviour drift over the window's
#: last quarter (a fraction) with its interval, the checkpoint iteration (0: not measured) and
#: whether the drift is within the run's tolerance (empty when not measured).
DRIFT = "behaviour_drift"
SETTLING_COLUMNS = (DRIFT, DRIFT + LOW, DRIFT + HIGH, "checkpoint_iteration", "settled")

TABLE3_COLUMNS = ("cell_id", *KEY_COLUMNS, *SCALAR_COLUMNS, *IQM_COLUMNS, *SETTLING_COLUMNS, *PAPER_COLUMNS)

#: Table 4's numbers that carry intervals (ours; the quoted rows have none).
TABLE4_NUMBERS = PAPER_TABLE4_COLUMNS[1:]
TABLE4_COLUMNS = (PAPER_TABLE4_COLUMNS[0], *(c for name in TABLE4_NUMBERS for c in (name, name + LOW, name + HIGH)),
                  "source")

#: Title of the behaviour drift in the printed Table 3 (percentage points of success).
DRIFT_TITLE = "drift pp"

#: Printed Table 3 columns beside the paper's definitions (no paper value): title, column, digits,
#: scale.  Held reaching (:func:`tableclean_suite.metrics.held_reaching`), the final greedy
#: policies' success and the share of runs that never reached the terminal state.
HELD_AND_MECHANISM_COLUMNS = (
    ("held success iterations", "held_success_iterations", 0, 1.0),
    ("greedy success %", "greedy_success_plateau", 2, 100.0),
    ("never terminal %", "never_terminal_share", 1, 100.0),
)

#: Label of our numbers in the printed Table 3.
OURS = "ours"

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

_NA = float("nan")


def _ordered(values, preferred):
    """``values``' unique entries, ``preferred`` ones first in that order, then the rest as they come."""
    unique = list(dict.fromkeys(values))
    return [v for v in preferred if v in unique] + [v for v in unique if v not in preferred]


def is_paper_task(model) -> bool:
    """Whether ``model`` is the paper's task (2 segments, 1 object, its four actions), whatever its
    start and ineffective modes, so that the paper's numbers can stand beside ours."""
    from tableclean_suite.task import PAPER_SPEC

    return ((model.n_segments, model.n_objects) == (PAPER_SPEC.segments, PAPER_SPEC.n_objects)
            and tuple(model.action_names) == tuple(PAPER_SPEC.actions))


def table3(records: list[dict] | pd.DataFrame, compare_with_paper: bool = True) -> pd.DataFrame:
    """Table 3: one row per (experiment, cell), with the paper's values beside the main Q-learning rows.

    Args:
        records: cell records (see module docstring) or a DataFrame of them.
        compare_with_paper: fill the ``paper_*`` columns (False for another task than the paper's:
            they are then all NaN).

    Returns:
        A DataFrame with columns :data:`TABLE3_COLUMNS` (extra input columns are dropped; the
        ``_low``/``_high`` bounds and IQM columns are NaN when the records carry none),
        sorted by experiment (main, alpha_sweep, gamma_sweep), learner, reward, alpha, gamma.
        ``paper_*`` columns are NaN except on ``experiment == "main"`` rows of
        :data:`PAPER_LEARNER` with a reward the paper reports.  Iteration columns are
        nullable integers (``<NA>`` when the curve never reached its level).
    """
    frame = pd.DataFrame(records).copy()
    missing = [c for c in ("cell_id", *KEY_COLUMNS, *SUMMARY_SCALARS)
               if c not in frame.columns and c not in OPTIONAL_SCALARS]
    if missing:
        raise ValueError(f"cell records lack columns: {', '.join(missing)}")
    for column in OPTIONAL_SCALARS:
        if column not in frame.columns:
            frame[column] = _NA
    frame = frame.drop(columns=[c for c in PAPER_COLUMNS if c in frame.columns])
    paper = PAPER_TABLE3.set_index("reward")
    is_paper_row = (frame["experiment"] == "main") & (frame["learner"] == PAPER_LEARNER) & compare_with_paper
    for column in PAPER_COLUMNS:
        frame[column] = [
            paper.at[reward, column] if flag and reward in paper.index else _NA
            for reward, flag in zip(frame["reward"], is_paper_row)
        ]
    for column in SUMMARY_SCALARS:
        if column in ITERATION_SCALARS:
            frame[column] = pd.array([None if _missing(v) else int(v) for v in frame[column]], dtype="Int64")
        else:
            frame[column] = [_NA if _missing(v) else float(v) for v in frame[column]]
    for column in (*SCALAR_COLUMNS, *IQM_COLUMNS, *SETTLING_COLUMNS[:3]):  # NaN when the records carry none
        if column not in SUMMARY_SCALARS:
            values = frame[column] if column in frame.columns else [_NA] * len(frame)
            frame[column] = [_NA if _missing(v) else float(v) for v in values]
    checkpoints = frame["checkpoint_iteration"] if "checkpoint_iteration" in frame.columns else [None] * len(frame)
    frame["checkpoint_iteration"] = pd.array([None if _missing(v) or int(v) == 0 else int(v) for v in checkpoints],
                                             dtype="Int64")  # empty, not 0, where no checkpoint was measured
    settled = frame["settled"] if "settled" in frame.columns else [None] * len(frame)
    frame["settled"] = pd.array([None if _missing(v) else bool(v) for v in settled], dtype="boolean")
    frame["alpha"] = frame["alpha"].astype(float)
    frame["gamma"] = frame["gamma"].astype(float)
    sort_keys = {
        "experiment": _ordered(frame["experiment"], EXPERIMENTS),
        "learner": _ordered(frame["learner"], ("q_learning", "sarsa")),
        "reward": _ordered(frame["reward"], ("r1", "r2", "r3", "r4")),
    }
    rank = {k: {v: i for i, v in enumerate(order)} for k, order in sort_keys.items()}
    frame = frame.assign(**{f"_rank_{k}": frame[k].map(r) for k, r in rank.items()})
    frame = frame.sort_values(["_rank_experiment", "_rank_learner", "_rank_reward", "alpha", "gamma"], kind="stable")
    return frame[list(TABLE3_COLUMNS)].reset_index(drop=True)


def _missing(value) -> bool:
    return value is None or value is pd.NA or (isinstance(value, float) and math.isnan(value))


def main_rows(table: pd.DataFrame) -> pd.DataFrame:
    """The ``experiment == "main"`` rows of a :func:`table3` frame."""
    return table[table["experiment"] == "main"].reset_index(drop=True)


def sweep_rows(table: pd.DataFrame) -> pd.DataFrame:
    """The alpha- and gamma-sweep rows of a :func:`table3` frame."""
    return table[table["experiment"].isin(["alpha_sweep", "gamma_sweep"])].reset_index(drop=True)


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
        table: a :func:`table3` frame.
        paper_task: whether the run was on the paper's task (:func:`is_paper_task`); if not, the
            paper's own rows (:data:`PAPER_OWN_ROWS`, measured on its task) are left out and only
            the literature's quoted rows stay.

    Returns:
        Columns :data:`TABLE4_COLUMNS`.  Our rows are named
        ``"This run: Q-learning with reward rN"`` (main Q-learning cells) and
        :func:`literature_method` (``literature`` cells), with ``max_success_rate_percent``
        = 100 x ``success_plateau`` and ``source == "this run"``; each number is followed by its
        interval's ``_low``/``_high`` bounds (NaN on the quoted rows).
    """
    main = table[(table["experiment"] == "main") & (table["learner"] == PAPER_LEARNER)]
    literature = table[table["experiment"] == "literature"]
    ours = pd.concat([main, literature], ignore_index=True)
    sources = {"average_reward_convergence_episodes": ("reward_convergence_episodes", 1.0),
               "max_success_rate_percent": ("success_plateau", 100.0),
               "max_success_episodes": ("max_success_episodes", 1.0)}
    data = {"methodology": [f"This run: Q-learning with reward {r}" for r in main["reward"]]
            + [literature_method(l, r) for l, r in zip(literature["learner"], literature["reward"])]}
    for name, (column, scale) in sources.items():
        for suffix in ("", LOW, HIGH):
            data[name + suffix] = scale * ours[column + suffix].astype(float).to_numpy()
    rows = pd.DataFrame({**data, "source": SOURCE_OURS})
    quoted = PAPER_TABLE4.astype({c: float for c in TABLE4_NUMBERS})
    if not paper_task:
        quoted = quoted[~quoted["methodology"].str.startswith(PAPER_OWN_ROWS)]
    for name in TABLE4_NUMBERS:
        quoted[name + LOW] = quoted[name + HIGH] = _NA
    return pd.concat([rows, quoted], ignore_index=True)[list(TABLE4_COLUMNS)]


def with_interval(value, low, high, digits: int = 0, scale: float = 1.0) -> str:
    """``"222 [205, 240]"``: a number and its interval, rounded to ``digits``; "-" when missing."""
    if _missing(value):
        return "-"
    text = lambda v: f"{scale * float(v):.{digits}f}"  # noqa: E731
    if _missing(low) or _missing(high):
        return text(value)
    return f"{text(value)} [{text(low)}, {text(high)}]"


def display_table3(table: pd.DataFrame) -> pd.DataFrame:
    """The main rows of Table 3 for printing: ours (``"value [low, high]"``, or the value alone
    when there is no interval) beside the paper's.

    Index (learner, reward); two-level columns (quantity, ``ours``/``paper``) for the
    reward-convergence and max-success iterations and episodes and the success rate in %,
    plus our maximum average reward and average-reward plateau, the behaviour drift (percentage
    points) and whether the cell settled (``NO``: its figures depend on the window).
    """
    rows = main_rows(table)
    pairs = {
        "reward conv. iterations": ("reward_convergence_iterations", "paper_reward_convergence_iterations", 0),
        "reward conv. episodes": ("reward_convergence_episodes", "paper_reward_convergence_episodes", 1),
        "max success iterations": ("max_success_iterations", "paper_max_success_iterations", 0),
        "max success episodes": ("max_success_episodes", "paper_max_success_episodes", 1),
        "success %": ("success_plateau", "paper_success_rate", 2),
    }
    data = {}
    for title, (ours, paper, digits) in pairs.items():
        scale = 100.0 if title == "success %" else 1.0
        data[(title, OURS)] = [with_interval(v, lo, hi, digits, scale) for v, lo, hi in
                                          zip(rows[ours], rows[ours + LOW], rows[ours + HIGH])]
        paper_values = (scale * rows[paper].astype(float)).round(digits)
        data[(title, "paper")] = paper_values.astype("Int64") if digits == 0 else paper_values
    for title, column, digits, scale in HELD_AND_MECHANISM_COLUMNS:
        data[(title, OURS)] = [with_interval(v, lo, hi, digits, scale) for v, lo, hi in
                               zip(rows[column], rows[column + LOW], rows[column + HIGH])]
    for title, column in (("max avg reward", "max_average_reward"), ("avg reward plateau", "average_reward_plateau")):
        data[(title, OURS)] = [with_interval(v, lo, hi, 3) for v, lo, hi in
                                          zip(rows[column], rows[column + LOW], rows[column + HIGH])]
    data[(DRIFT_TITLE, OURS)] = [with_interval(v, lo, hi, 2, 100.0) for v, lo, hi in
                                 zip(rows[DRIFT], rows[DRIFT + LOW], rows[DRIFT + HIGH])]
    data[("settled", OURS)] = _settled_marks(rows["settled"])
    frame = pd.DataFrame(data)
    frame.index = pd.MultiIndex.from_arrays([rows["learner"], rows["reward"]], names=["learner", "reward"])
    return _dashes(frame)


def table3_notes(threshold: float, hold: int) -> str:
    """The printed Table 3's legend for the columns beside the paper's definitions (two lines)."""
    return (f"  held success iterations = first iteration after which the success curve stays >= "
            f"{100 * threshold:g}% of the plateau for {hold} iterations (the paper-definition column, max success "
            "iterations, is the first touch); greedy success % = the final greedy policies' exact success "
            "(epsilon = 0);\n  never terminal % = runs that never reached the terminal state in the window.  Every "
            "interval holds its point (same-estimator percentile bootstrap, extended to the point where needed).")


def comparisons_title() -> str:
    """The heading of the printed probabilities of improvement, with their equivalence margins."""
    margins = ", ".join(f"{score} {margin:g}" for score, margin in EQUIVALENCE_MARGINS.items())
    return (f"Probability of improvement (a run of X beats a run of Y by more than the margin; pairs within it "
            f"count half; 0.5 = no difference; margins: {margins}):")


def display_scores(table: pd.DataFrame) -> pd.DataFrame:
    """IQMs of the per-run scores of the main rows, with their intervals, for printing."""
    rows = main_rows(table)
    data = {"learner": rows["learner"], "reward": rows["reward"]}
    for score, digits, scale, title in (("success_asymptote", 2, 100.0, "IQM asymptotic success %"),
                                        ("first_success_iterations", 0, 1.0, "IQM iterations to first success")):
        column = f"{score}_iqm"
        data[title] = [with_interval(v, lo, hi, digits, scale)
                       for v, lo, hi in zip(rows[column], rows[column + LOW], rows[column + HIGH])]
    return pd.DataFrame(data)


def display_comparisons(frame: pd.DataFrame) -> pd.DataFrame:
    """Probabilities of improvement for printing: "X over Y", the score, P [95 % CI]."""
    def name(learner, reward, other_learner, other_reward):
        return reward if learner == other_learner else learner

    return pd.DataFrame({
        "comparison": [f"{name(lx, rx, ly, ry)} over {name(ly, ry, lx, rx)}"
                       + (f" ({lx})" if lx == ly else f" ({rx})")
                       for lx, rx, ly, ry in zip(frame["learner_x"], frame["reward_x"], frame["learner_y"],
                                                 frame["reward_y"])],
        "score": frame["score"],
        "P(improvement) [95% CI]": [with_interval(p, lo, hi, 2) for p, lo, hi in zip(
            frame["probability_of_improvement"], frame["probability_of_improvement_low"],
            frame["probability_of_improvement_high"])],
    })


def _dashes(frame: pd.DataFrame) -> pd.DataFrame:
    """For printing: missing values as "-", whole numbers without a trailing ".0"."""
    def cell(value):
        if _missing(value):
            return "-"
        if isinstance(value, (float, np.floating)) and float(value).is_integer():
            return int(value)
        return value

    return frame.astype(object).apply(lambda column: column.map(cell))


def display_sweeps(table: pd.DataFrame) -> pd.DataFrame:
    """The sweep rows for printing (no paper columns: the paper gives only Figures 6-7)."""
    rows = sweep_rows(table)
    return pd.DataFrame(
        {
            "experiment": rows["experiment"],
            "learner": rows["learner"],
            "reward": rows["reward"],
            "alpha": rows["alpha"],
            "gamma": rows["gamma"],
            "conv_itr [95% CI]": _intervals(rows, "reward_convergence_iterations", 0),
            "conv_eps": rows["reward_convergence_episodes"].round(1),
            "succ_itr [95% CI]": _intervals(rows, "max_success_iterations", 0),
            "succ_eps": rows["max_success_episodes"].round(1),
            "held_itr [95% CI]": _intervals(rows, "held_success_iterations", 0),
            "success_% [95% CI]": _intervals(rows, "success_plateau", 2, 100.0),
            "max_avg_r": rows["max_average_reward"].round(3),
            "settled": _settled_marks(rows["settled"]),
        }
    ).pipe(_dashes)


def _settled_marks(flags) -> list[str]:
    """``yes``/``NO`` per settled flag, ``-`` where settling was not measured."""
    return ["-" if flag is pd.NA else ("yes" if flag else "NO") for flag in flags]


def _intervals(rows: pd.DataFrame, column: str, digits: int, scale: float = 1.0) -> list[str]:
    return [with_interval(v, lo, hi, digits, scale) for v, lo, hi in zip(rows[column], rows[column + LOW],
                                                                          rows[column + HIGH])]


def _quoted_text(value, digits: int) -> str:
    """A number without interval as the paper prints it: "-" if missing, no trailing ".0"."""
    if _missing(value):
        return "-"
    return f"{round(float(value), digits):g}"


def display_table4(table4_frame: pd.DataFrame) -> pd.DataFrame:
    """Table 4 for printing: numbers rounded (ours with their intervals), "-" where the paper gives
    none, a ``source`` column saying "run here" or "quoted" on every row."""
    frame = table4_frame.copy()
    for name, digits in (("average_reward_convergence_episodes", 1), ("max_success_rate_percent", 2),
                         ("max_success_episodes", 1)):
        frame[name] = [_quoted_text(v, digits) if _missing(lo) or _missing(hi) else with_interval(v, lo, hi, digits)
                       for v, lo, hi in zip(frame[name], frame[name + LOW], frame[name + HIGH])]
    frame = frame.drop(columns=[name + suffix for name in TABLE4_NUMBERS for suffix in (LOW, HIGH)])
    frame["source"] = [MARK_QUOTED if s == SOURCE_QUOTED else MARK_RUN_HERE for s in frame["source"]]
    frame = frame[["source", *(c for c in frame.columns if c != "source")]]
    return frame.rename(
        columns={
            "average_reward_convergence_episodes": "avg_reward_conv_episodes",
            "max_success_rate_percent": "max_success_%",
            "max_success_episodes": "max_success_episodes",
        }
    )


def curves_long(records: list[dict], curves: list[dict], metrics=CURVE_METRICS, stride: int = 1) -> pd.DataFrame:
    """Curves in long format: one row per (record, iteration, metric).

    Args:
        records: cell records (only :data:`KEY_COLUMNS` are used).
        curves: per record, ``{metric: ndarray (iterations,)}``.
        metrics: which curves to include.
        stride: keep iterations 1, 1 + stride, ... (and always the last).

    Returns:
        Columns ``learner, reward, alpha, gamma, experiment, iteration, metric, value, low, high``;
        ``iteration`` is the 1-based iteration count, as on the figures' x axes; ``low``/``high``
        bound the curve's 95 % band where the curve set has ``<metric>_low``/``_high`` (else NaN).
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
            part = pd.DataFrame({"iteration": keep + 1, "metric": metric, "value": values[keep],
                                 "low": bounds["low"][keep], "high": bounds["high"][keep]})
            for key in reversed(KEY_COLUMNS):
                part.insert(0, key, record[key])
            parts.append(part)
    columns = [*KEY_COLUMNS, "iteration", "metric", "value", "low", "high"]
    if not parts:
        return pd.DataFrame(columns=columns)
    return pd.concat(parts, ignore_index=True)[columns]


#: ``float_format`` of ``curves.csv`` (printf style, as ``DataFrame.to_csv(float_format=...)``).
CURVES_FLOAT_FORMAT = "%.6g"
#: Characters that make ``DataFrame.to_csv`` quote a text field (then :func:`csv_text` defers to pandas).
_CSV_SPECIAL = (",", '"', "\n", "\r")


def _formatted_floats(values: np.ndarray, float_format: str, na_rep: str) -> list[str]:
    """``values`` (float64) as ``to_csv`` writes them: ``float_format % v``, ``na_rep`` for NaN.

    Each distinct bit pattern is formatted once (curves repeat values a lot; found by hashing, not
    sorting); identical bits give identical text, so -0.0 and 0.0 stay apart.
    """
    values = np.ascontiguousarray(values, dtype=np.float64)
    codes, bits = pd.factorize(values.view(np.int64))
    texts = [na_rep if v != v else float_format % v for v in np.asarray(bits, dtype=np.int64).view(np.float64).tolist()]
    return np.asarray(texts, dtype=object)[codes].tolist()


def csv_text(frame: pd.DataFrame, float_format: str = CURVES_FLOAT_FORMAT, na_rep: str = "") -> str:
    """``frame.to_csv(index=False, float_format=float_format, na_rep=na_rep)`` as a string, byte for
    byte, formatting column by column (pandas formats every cell through Python calls: ~2 s for
    the default ``curves.csv``).

    Columns of float64, integer or text (object of ``str``) dtype are formatted here; a frame
    with any other dtype, non-string objects, missing text or text that needs CSV quoting is
    handed to pandas.
    """
    columns = []
    for name in frame.columns:
        series = frame[name]
        kind = series.dtype.kind
        if kind == "f" and series.dtype == np.float64:
            columns.append(_formatted_floats(series.to_numpy(), float_format, na_rep))
        elif kind in "iu":
            columns.append([str(v) for v in series.to_numpy().tolist()])
        elif kind == "O":
            texts = series.tolist()
            distinct = set(texts)
            if not all(type(t) is str and not any(c in t for c in _CSV_SPECIAL) for t in distinct):
                return frame.to_csv(index=False, float_format=float_format, na_rep=na_rep)
            columns.append(texts)
        else:
            return frame.to_csv(index=False, float_format=float_format, na_rep=na_rep)
    names = [str(name) for name in frame.columns]
    if not all(type(n) is str and not any(c in n for c in _CSV_SPECIAL) for n in frame.columns) or not names:
        return frame.to_csv(index=False, float_format=float_format, na_rep=na_rep)
    if not len(frame):
        return ",".join(names) + "\n"
    return ",".join(names) + "\n" + "\n".join(map(",".join, zip(*columns))) + "\n"
