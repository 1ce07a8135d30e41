"""Figures 3-7 of the paper and the Kaplan-Meier curves of the per-run learning time (Figure 8)
from the long frame of [curves_long][tableclean_suite.bench.tables.curves_long]; each reward pattern
has one colour in every figure, sweeps colour by value.  matplotlib is imported at the first figure.
"""

from __future__ import annotations

import io

import numpy as np

from tableclean_suite import metrics

#: The paper's patterns get fixed colours; user patterns take the next free ones.
REWARD_COLORS = {"r1": "#1f77b4", "r2": "#ff7f0e", "r3": "#2ca02c", "r4": "#d62728"}
_EXTRA_COLORS = ("#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf")

METRIC_LABELS = {
    "success": "success rate (%)",
    "average_reward": "average reward (return / episode length)",
    "terminal": "terminal reached (%)",
    "episodes": "episodes finished",
    "not_learned": "runs not yet optimal for good (%)",
}
_PERCENT_METRICS = ("success", "terminal", "not_learned")
LEARNER_TITLES = {"q_learning": "Q-learning", "sarsa": "SARSA", "expected_sarsa": "Expected SARSA"}
X_LABEL = "training iterations (environment steps)"


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (imported on first use: ~0.6 s)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def reward_color(reward: str, known=()) -> str:
    """The colour of a reward pattern; user patterns cycle through extra colours by their order in ``known``."""
    if reward in REWARD_COLORS:
        return REWARD_COLORS[reward]
    others = [r for r in dict.fromkeys(known) if r not in REWARD_COLORS]
    index = others.index(reward) if reward in others else len(others)
    return _EXTRA_COLORS[index % len(_EXTRA_COLORS)]


def _select(curves: pd.DataFrame, **where) -> pd.DataFrame:
    """The rows of ``curves`` whose columns equal the values in ``where``."""
    return curves[np.logical_and.reduce([(curves[column] == value).to_numpy(dtype=bool)
                                         for column, value in where.items()])]


def _scale(metric: str) -> float:
    return 100.0 if metric in _PERCENT_METRICS else 1.0


def _what(metric: str) -> str:
    """A metric's name for titles, e.g. ``"Success rate"``."""
    return METRIC_LABELS.get(metric, metric).split(" (")[0].capitalize()


def _style(ax, metric: str, title: str, legend_title: str | None):
    ax.set_xlabel(X_LABEL)
    ax.set_ylabel(METRIC_LABELS.get(metric, metric))
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.margins(x=0)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(title=legend_title, loc="upper right" if metric == "not_learned" else "lower right",
                  fontsize="small", title_fontsize="small")


#: Opacity of the 95 % bands.
BAND_ALPHA = 0.2


def _line(ax, line: pd.DataFrame, metric: str, color, label: str) -> None:
    """Draw one curve of ``line`` (a frame's rows sorted by iteration), its ``low``-``high`` band shaded
    first when the frame has one."""
    iterations, scale = line["iteration"].to_numpy(), _scale(metric)
    if "low" in line.columns and not line["low"].isna().all():
        ax.fill_between(iterations, line["low"].to_numpy(dtype=float) * scale,
                        line["high"].to_numpy(dtype=float) * scale, color=color, alpha=BAND_ALPHA, linewidth=0)
    ax.plot(iterations, line["value"].to_numpy(dtype=float) * scale, color=color, linewidth=1.3, label=label)


def plot_rewards(
    curves: pd.DataFrame,
    learner: str,
    metric: str,
    experiment: str = "main",
    plateau_fraction: float | None = 0.25,
    title: str | None = None,
    levels: dict | None = None,
):
    """One line per reward pattern of ``learner``'s ``metric`` (``"success"`` drawn in %,
    ``"average_reward"``, ...) vs iterations in ``experiment``'s rows of the long ``curves`` frame, with
    its band shaded where the frame has ``low``/``high`` (Figures 3-5); returns ``(fig, ax)``.

    Each line's level is drawn dotted: ``levels[reward]`` (in the metric's units, e.g. the exact
    asymptotes; labelled "asymptote") or else the mean over the last ``plateau_fraction`` (None: none).
    ``title`` defaults to e.g. ``"Success rate per reward pattern (Q-learning)"``.
    """
    fig, ax = pyplot().subplots(figsize=(7, 4.2))
    rows = _select(curves, learner=learner, metric=metric, experiment=experiment)
    rewards = list(dict.fromkeys(rows["reward"]))
    for reward in rewards:
        line = rows[rows["reward"] == reward].sort_values("iteration")
        values = line["value"].to_numpy(dtype=float) * _scale(metric)
        color = reward_color(reward, rewards)
        label = reward
        if levels is not None and reward in levels:
            level, kind = float(levels[reward]) * _scale(metric), "asymptote"
        elif plateau_fraction is not None:
            level, kind = metrics.plateau(values, plateau_fraction), "plateau"
        else:
            level = kind = None
        if level is not None:
            ax.axhline(level, color=color, linestyle=":", linewidth=0.9, alpha=0.8)
            label = f"{reward} ({kind} " + (f"{level:.1f}%)" if metric in _PERCENT_METRICS else f"{level:.3f})")
        _line(ax, line, metric, color, label)
    _style(ax, metric, title or f"{_what(metric)} per reward pattern ({LEARNER_TITLES.get(learner, learner)})",
           "reward")
    return fig, ax


def plot_sweeps(curves: pd.DataFrame, metric: str, xmax: int | None = None):
    """One panel per sweep (alpha, gamma; those without rows skipped), one line per swept value of
    ``metric`` vs iterations, coloured on viridis (Figures 6-7); ``xmax``: show iterations 1..xmax only
    (None: all).  Returns ``(fig, axes)``, at least one axes."""
    experiments = ("alpha_sweep", "gamma_sweep")
    present = [e for e in experiments if (curves["experiment"] == e).any()] or list(experiments[:1])
    plt = pyplot()
    fig, axes = plt.subplots(1, len(present), figsize=(6.2 * len(present), 4.2), sharey=True, squeeze=False)
    axes, colormap = axes[0], plt.get_cmap("viridis")
    for ax, experiment in zip(axes, present):
        parameter = "alpha" if experiment == "alpha_sweep" else "gamma"
        fixed = "gamma" if parameter == "alpha" else "alpha"
        rows = _select(curves, metric=metric, experiment=experiment)
        values_swept = sorted(rows[parameter].unique())
        for i, value in enumerate(values_swept):
            line = rows[rows[parameter] == value].sort_values("iteration")
            _line(ax, line, metric, colormap(0.85 * i / max(1, len(values_swept) - 1)), f"{parameter} = {value:g}")
        title = f"{_what(metric)}, {parameter} sweep"
        if len(rows):
            first = rows.iloc[0]
            title += (f" ({LEARNER_TITLES.get(first['learner'], first['learner'])}, {first['reward']}, "
                      f"{fixed} = {first[fixed]:g})")
        _style(ax, metric, title, None)
        if xmax is not None and len(rows) and rows["iteration"].max() > xmax:
            ax.set_xlim(1, xmax)
            ax.set_xlabel(f"{X_LABEL}, first {xmax}")
    for ax in axes[1:]:
        ax.set_ylabel("")
        ax.tick_params(labelleft=True)
    fig.tight_layout()
    return fig, axes


#: Iterations shown by the sweep figures: all the sweeps' differences lie before it at the defaults.
SWEEP_XMAX = 1000


def _rewards(curves: pd.DataFrame, plateau_fraction: float, table3, learner: str, metric: str):
    """[`plot_rewards`][tableclean_suite.bench.plots.plot_rewards] with the plateaus (``success_plateau``
    or ``average_reward_plateau``) of ``learner``'s main rows of a Table 3 frame as ``levels`` (None: none)."""
    levels = None
    if table3 is not None:
        rows = table3[(table3["experiment"] == "main") & (table3["learner"] == learner)]
        levels = dict(zip(rows["reward"], rows[f"{metric}_plateau"].astype(float)))
    return plot_rewards(curves, learner, metric, plateau_fraction=plateau_fraction, levels=levels)


#: The paper's figures and the learning-time figure: file stem -> builder ``(curves, plateau_fraction,
#: table3=None) -> (fig, ax)``.
PAPER_FIGURES = {
    "fig3_success_rate_q_learning": lambda c, p, t=None: _rewards(c, p, t, "q_learning", "success"),
    "fig4_average_reward_q_learning": lambda c, p, t=None: _rewards(c, p, t, "q_learning", "average_reward"),
    "fig5_average_reward_sarsa": lambda c, p, t=None: _rewards(c, p, t, "sarsa", "average_reward"),
    "fig6_success_rate_sweeps": lambda c, p, t=None: plot_sweeps(c, "success", xmax=SWEEP_XMAX),
    "fig7_average_reward_sweeps": lambda c, p, t=None: plot_sweeps(c, "average_reward", xmax=SWEEP_XMAX),
    "fig8_learning_time_q_learning": lambda c, p, t=None: plot_rewards(
        c, "q_learning", "not_learned", plateau_fraction=None,
        title="Runs not yet optimal for good, per reward pattern (Q-learning)"),
}


def available_figures(curves: pd.DataFrame) -> list[str]:
    """Stems of `PAPER_FIGURES` that ``curves`` has data for."""
    experiments = set(curves["experiment"].unique().tolist())
    learners = set(curves.loc[curves["experiment"] == "main", "learner"].unique().tolist())
    sweeps = experiments & {"alpha_sweep", "gamma_sweep"}
    survival = "not_learned" in set(curves["metric"].unique().tolist())
    needs = {
        "fig3_success_rate_q_learning": "q_learning" in learners,
        "fig4_average_reward_q_learning": "q_learning" in learners,
        "fig5_average_reward_sarsa": "sarsa" in learners,
        "fig6_success_rate_sweeps": bool(sweeps),
        "fig7_average_reward_sweeps": bool(sweeps),
        "fig8_learning_time_q_learning": "q_learning" in learners and survival,
    }
    return [stem for stem, ok in needs.items() if ok]


#: zlib level of the PNGs [`render_png`][tableclean_suite.bench.plots.render_png] writes (1: fastest).
PNG_COMPRESS_LEVEL = 1
#: How `render_png` saves a figure with artists beyond its canvas (beside the dpi it is given).
SAVEFIG_OPTIONS = {"bbox_inches": "tight", "format": "png"}


def render_png(stem: str, curves: pd.DataFrame, plateau_fraction: float, table3=None, dpi: int = 100) -> bytes:
    """The PNG bytes of the paper's figure ``stem`` (`PAPER_FIGURES`) drawn from ``curves``
    (plateau lines from ``table3`` when given) at ``dpi`` dots per inch, cropped as
    ``savefig(bbox_inches="tight")`` crops it."""
    plt = pyplot()
    with plt.rc_context({"figure.dpi": dpi}):  # a layout (Figures 6-7) measures texts as they are drawn
        fig, _ = PAPER_FIGURES[stem](curves, plateau_fraction, table3)
    try:
        return _tight_png(fig, dpi)
    finally:
        plt.close(fig)


def _tight_png(fig, dpi: int) -> bytes:
    """PNG of ``fig`` drawn once at ``dpi``, cropped to its pixels not of the figure's colour padded
    by ``savefig.pad_inches`` (``savefig(bbox_inches="tight")`` would draw it twice); a figure drawn
    up to its canvas' edge is saved by ``savefig``, an opaque one as RGB."""
    import matplotlib
    from PIL import Image, PngImagePlugin

    fig.set_dpi(dpi)
    fig.canvas.draw()
    drawn = np.asarray(fig.canvas.buffer_rgba())  # (height, width, 4) uint8, top row first
    height, width = drawn.shape[:2]
    facecolor = np.round(np.asarray(matplotlib.colors.to_rgba(fig.get_facecolor())) * 255).astype(np.uint8)
    ink = (drawn != facecolor).any(axis=2)
    rows, columns = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
    if (not rows.size or rows[0] == 0 or columns[0] == 0 or rows[-1] == height - 1
            or columns[-1] == width - 1):
        buffer = io.BytesIO()
        fig.savefig(buffer, dpi=dpi, **SAVEFIG_OPTIONS)
        return buffer.getvalue()
    pad = int(round(matplotlib.rcParams["savefig.pad_inches"] * dpi))
    top, bottom, left, right = rows[0] - pad, rows[-1] + 1 + pad, columns[0] - pad, columns[-1] + 1 + pad
    crop = np.empty((bottom - top, right - left, 4), dtype=np.uint8)
    crop[...] = facecolor  # the padding past the canvas: the figure's colour, as savefig fills it
    inside_rows, inside_columns = slice(max(top, 0), min(bottom, height)), slice(max(left, 0), min(right, width))
    crop[inside_rows.start - top:inside_rows.stop - top, inside_columns.start - left:inside_columns.stop - left] = \
        drawn[inside_rows, inside_columns]
    opaque = bool((crop[..., 3] == 255).all())
    image = Image.fromarray(np.ascontiguousarray(crop[..., :3]) if opaque else crop)
    info = PngImagePlugin.PngInfo()
    info.add_text("Software", f"Matplotlib version{matplotlib.__version__}, https://matplotlib.org/")
    buffer = io.BytesIO()
    image.save(buffer, format="png", dpi=(dpi, dpi), pnginfo=info, compress_level=PNG_COMPRESS_LEVEL)
    return buffer.getvalue()
