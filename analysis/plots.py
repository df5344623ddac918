"""Figures that several studies draw: learning curves with error bands, and saving a
figure as PNG and SVG. Needs the 'paper' extra (matplotlib, pandas, scipy)."""

import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from lwrl import outputs  # noqa: E402
from lwrl.analysis import statistics  # noqa: E402


def save_figure(figure, figure_dir: str, name: str) -> list:
    """`figure` as `figure_dir/name.png` and `.svg`, each whole or not at all; return the paths."""
    paths = []
    for extension in ("png", "svg"):
        path = os.path.join(figure_dir, f"{name}.{extension}")
        with outputs.atomic_path(path) as temporary:
            figure.savefig(temporary, format=extension, dpi=120, bbox_inches="tight")
        paths.append(path)
    plt.close(figure)
    return paths


def plot_learning_curve(results: pd.DataFrame, value: str, ylabel: str, title: str, axes=None,
                        interval: bool = False, label: str = "mean over agents"):
    """Mean over agents per episode, with a band of one standard error, or with `interval`
    of its 95 % bootstrap interval over agents (`analysis.statistics`); on `axes` if given
    (a panel of a larger figure), else on a figure of its own."""
    curve = results.groupby("episode")[value].agg(["mean", "std", "count"])
    if interval:
        per_episode = results.pivot_table(index="seed", columns="episode", values=value)
        bounds = statistics.episode_intervals(per_episode.to_numpy())
        low, high, band = bounds[0], bounds[1], "95 % interval over agents"
    else:
        error = curve["std"] / np.sqrt(curve["count"])
        low, high, band = curve["mean"] - error, curve["mean"] + error, "± one standard error"
    figure, axes = plt.subplots(figsize=(6, 4)) if axes is None else (axes.figure, axes)
    line, = axes.plot(curve.index, curve["mean"], label=label)
    axes.fill_between(curve.index, low, high, alpha=0.3, color=line.get_color(), label=band)
    axes.set_xlabel("episode")
    axes.set_ylabel(ylabel)
    axes.set_title(title)
    axes.legend()
    axes.grid(alpha=0.3)
    return figure, curve
