"""render_png draws a figure once and crops it to its ink: the picture savefig(bbox_inches="tight") gives."""

import io

import numpy as np
import pandas as pd
from PIL import Image

from tableclean_suite.bench import plots


def _curves(iterations=400):
    steps = np.arange(1, iterations + 1)
    parts = []
    for learner in ("q_learning", "sarsa"):
        for k, reward in enumerate(("r1", "r4")):
            value = 0.9 * (1 - np.exp(-steps / (50.0 * (k + 1))))
            parts.append(pd.DataFrame({"learner": learner, "reward": reward, "alpha": 0.3, "gamma": 0.3,
                                       "experiment": "main", "iteration": steps, "metric": "success",
                                       "value": value, "low": value - 0.05, "high": value + 0.05}))
    return pd.concat(parts, ignore_index=True)


def _ink(png: bytes) -> tuple[int, int]:
    """(height, width) of the part of the image that is not white."""
    pixels = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))
    rows, columns = np.flatnonzero((pixels != 255).any(axis=(1, 2))), np.flatnonzero((pixels != 255).any(axis=(0, 2)))
    return rows[-1] - rows[0] + 1, columns[-1] - columns[0] + 1


def test_render_png_is_savefig_tight_drawn_once_and_the_same_bytes_every_time():
    curves = _curves()
    stem = "fig3_success_rate_q_learning"
    png = plots.render_png(stem, curves, 0.25, dpi=80)
    assert png == plots.render_png(stem, curves, 0.25, dpi=80)  # the cache stores these bytes
    plt = plots.pyplot()
    fig, _ = plots.PAPER_FIGURES[stem](curves, 0.25, None)
    buffer = io.BytesIO()
    fig.set_dpi(80)
    fig.savefig(buffer, dpi=80, bbox_inches="tight", format="png")
    plt.close(fig)
    ours, theirs = Image.open(io.BytesIO(png)), Image.open(io.BytesIO(buffer.getvalue()))
    assert ours.info["dpi"] == theirs.info["dpi"]
    assert np.abs(np.subtract(ours.size, theirs.size)).max() <= 6  # their box bounds artists, ours their pixels
    assert np.abs(np.subtract(_ink(png), _ink(buffer.getvalue()))).max() <= 2  # the same picture
    pad = round(plt.rcParams["savefig.pad_inches"] * 80)
    pixels = np.asarray(ours.convert("RGB"))
    assert (pixels[:pad] == 255).all() and (pixels[-pad:] == 255).all() and (pixels[pad] != 255).any()


def test_a_figure_drawn_to_its_edge_is_left_to_savefig():
    plt = plots.pyplot()
    fig, ax = plt.subplots(figsize=(2, 2))
    ax.set_position([0, 0, 1, 1])  # the axes' frame is on the canvas' edge: something may lie beyond it
    ax.plot([0, 1], [0, 1])
    try:
        png = plots._tight_png(fig, 50)
        buffer = io.BytesIO()
        fig.savefig(buffer, dpi=50, **plots.SAVEFIG_OPTIONS)
    finally:
        plt.close(fig)
    assert png == buffer.getvalue()
