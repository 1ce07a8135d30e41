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
from tableclean_suite.metrics import ITERATION_SCALARS, SUMMARY_SCALARS

#: Identifying columns of a cell record, in table order.
KEY_COLUMNS = ("learner", "reward", "alpha", "gamma", "experiment")

#: Experiments, in table order.
EXPERIMENTS = ("main", "alpha_sweep", "gamma_sweep")

#: Curves written to ``curves.csv`` (the others are cheap to recompute and would triple the file).
CURVE_METRICS = ("success", "average_reward", "episodes")

PAPER_COLUMNS = tuple(c for c in PAPER_TABLE3.columns if c != "reward")

TABLE3_COLUMNS = ("cell_id", *KEY_COLUMNS, *SUMMARY_SCALARS, *PAPER_COLUMNS)

TABLE4_COLUMNS = (*PAPER_TABLE4_COLUMNS, "source")

#: ``source`` of a row of this run in Table 4.
SOURCE_OURS = "this run"

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
        A DataFrame with columns :data:`TABLE3_COLUMNS` (extra input columns are dropped),
        sorted by experiment (main, alpha_sweep, gamma_sweep), learner, reward, alpha, gamma.
        ``paper_*`` columns are NaN except on ``experiment == "main"`` rows of
        :data:`PAPER_LEARNER` with a reward the paper reports.  Iteration columns are
        nullable integers (``<NA>`` when the curve never reached its level).
    """
    frame = pd.DataFrame(records).copy()
    missing = [c for c in ("cell_id", *KEY_COLUMNS, *SUMMARY_SCALARS) if c not in frame.columns]
    if missing:
        raise ValueError(f"cell records lack columns: {', '.join(missing)}")
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


def table4(table: pd.DataFrame) -> pd.DataFrame:
    """Table 4: our main Q-learning rows, then the paper's rows (all quoted and marked so).

    Args:
        table: a :func:`table3` frame.

    Returns:
        Columns :data:`TABLE4_COLUMNS`.  Our rows are named
        ``"This run: Q-learning with reward rN"``, with ``max_success_rate_percent``
        = 100 x ``success_plateau`` and ``source == "this run"``.
    """
    ours = table[(table["experiment"] == "main") & (table["learner"] == PAPER_LEARNER)]
    rows = pd.DataFrame(
        {
            "methodology": [f"This run: Q-learning with reward {r}" for r in ours["reward"]],
            "average_reward_convergence_episodes": ours["reward_convergence_episodes"].astype(float).to_numpy(),
            "max_success_rate_percent": 100.0 * ours["success_plateau"].astype(float).to_numpy(),
            "max_success_episodes": ours["max_success_episodes"].astype(float).to_numpy(),
            "source": SOURCE_OURS,
        }
    )
    quoted = PAPER_TABLE4.astype({c: float for c in TABLE4_COLUMNS[1:-1]})
    return pd.concat([rows, quoted], ignore_index=True)[list(TABLE4_COLUMNS)]


def display_table3(table: pd.DataFrame) -> pd.DataFrame:
    """The main rows of Table 3 for printing: ours beside the paper's.

    Index (learner, reward); two-level columns (quantity, ``ours``/``paper``) for the
    reward-convergence and max-success iterations and episodes and the success rate in %,
    plus our maximum average reward.
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
        for label, column in (("ours", ours), ("paper", paper)):
            values = (scale * rows[column].astype(float)).round(digits)
            data[(title, label)] = values.astype("Int64") if digits == 0 else values
    data[("max avg reward", "ours")] = rows["max_average_reward"].astype(float).round(3)
    frame = pd.DataFrame(data)
    frame.index = pd.MultiIndex.from_arrays([rows["learner"], rows["reward"]], names=["learner", "reward"])
    return _dashes(frame)


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
            "conv_itr": rows["reward_convergence_iterations"],
            "conv_eps": rows["reward_convergence_episodes"].round(1),
            "succ_itr": rows["max_success_iterations"],
            "succ_eps": rows["max_success_episodes"].round(1),
            "success_%": (100 * rows["success_plateau"]).round(2),
            "max_avg_r": rows["max_average_reward"].round(3),
        }
    ).pipe(_dashes)


def display_table4(table4_frame: pd.DataFrame) -> pd.DataFrame:
    """Table 4 for printing: numbers rounded, "-" where the paper gives none, quoted rows marked."""
    frame = table4_frame.copy()
    frame["average_reward_convergence_episodes"] = frame["average_reward_convergence_episodes"].round(1)
    frame["max_success_rate_percent"] = frame["max_success_rate_percent"].round(2)
    frame["max_success_episodes"] = frame["max_success_episodes"].round(1)
    frame = _dashes(frame)
    frame["methodology"] = [
        m + (" *" if s == SOURCE_QUOTED else "") for m, s in zip(frame["methodology"], frame["source"])
    ]
    return frame.drop(columns="source").rename(
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
        Columns ``learner, reward, alpha, gamma, experiment, iteration, metric, value``;
        ``iteration`` is the 1-based iteration count, as on the figures' x axes.
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
            part = pd.DataFrame({"iteration": keep + 1, "metric": metric, "value": values[keep]})
            for key in reversed(KEY_COLUMNS):
                part.insert(0, key, record[key])
            parts.append(part)
    columns = [*KEY_COLUMNS, "iteration", "metric", "value"]
    if not parts:
        return pd.DataFrame(columns=columns)
    return pd.concat(parts, ignore_index=True)[columns]
