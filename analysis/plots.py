"""Figures that several studies draw: learning curves with error bands, estimates with their
intervals, claims against
interval estimates, and saving a figure as PNG and SVG. Needs the 'paper' extra (matplotlib,
pandas, scipy)."""

import dataclasses
import math
import os

import matplotlib

matplotlib.use("Agg")
matplotlib.rcParams["svg.hashsalt"] = "lwrl"  # the same figure, the same SVG bytes
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from lwrl import outputs  # noqa: E402
from lwrl.analysis import statistics  # noqa: E402


def plot_estimates(axes, x, estimates, label: str, marker: str = "o"):
    """`estimates` (`statistics.Estimate`s) at `x` on `axes`: their values as a line labelled
    `label`, and where every one has an interval, the intervals as a band of its colour."""
    line, = axes.plot(x, [e.value for e in estimates], marker=marker, label=label)
    if not any(math.isnan(e.low) for e in estimates):
        axes.fill_between(x, [e.low for e in estimates], [e.high for e in estimates],
                          alpha=0.15, color=line.get_color())


def save_figure(figure, figure_dir: str, name: str) -> list:
    """`figure` as `figure_dir/name.png` and `.svg`, each whole or not at all; return the paths."""
    paths = []
    for extension in ("png", "svg"):
        path = os.path.join(figure_dir, f"{name}.{extension}")
        with outputs.atomic_path(path) as temporary:
            figure.savefig(temporary, format=extension, dpi=120, bbox_inches="tight",
                           metadata={"Date": None} if extension == "svg" else None)
        paths.append(path)
    plt.close(figure)
    return paths


def markdown_images(paths, out_dir: str) -> list:
    """A Markdown image line for each PNG of `paths` (`save_figure`'s), relative to `out_dir`."""
    return [f"![{os.path.basename(path)}]({os.path.relpath(path, out_dir)})"
            for path in paths if path.endswith(".png")]


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


STEP_POINTS = 60
"""Points of a curve over environment steps (`curve_by_steps`)."""


def without_cut_episodes(table: pd.DataFrame, step_limit: float) -> pd.DataFrame:
    """`table` (episodes.csv) without the episodes that a budget of steps cut short
    (`RunConfig.budget`): an agent's last episode where it was truncated before the task's
    `step_limit`, whose measure counts only the steps before the cut."""
    ran = table[table["steps"].notna()]
    last = ran["episode"] == ran.groupby("seed")["episode"].transform("max")
    cut = last & (ran["truncated"] == 1) & (ran["steps"] < step_limit)
    return ran[~cut]


def curve_by_steps(table: pd.DataFrame, value: str, points: int = STEP_POINTS) -> tuple:
    """`(steps (P,), agents x P values)`: each agent's `value` of the last episode it finished
    by each of `points` numbers of environment steps, evenly spaced from the step by which
    every agent has finished an episode to the step by which every agent has finished its
    last (so that learners whose episodes differ in length are compared at equal steps).
    Episodes an agent did not run (no steps: NaN rows of episodes.csv) are left out."""
    finished, values = finished_episodes(table, value)
    steps = np.linspace(max(ends[0] for ends in finished), min(ends[-1] for ends in finished),
                        points)
    return steps, values_at_steps(finished, values, steps)


def finished_episodes(table: pd.DataFrame, value: str) -> tuple:
    """`(ends, values)`, per agent in the order of their seeds: the environment step by
    which each episode it ran had finished (its steps summed) and the episode's `value`."""
    finished, values = [], []
    ran = table[table["steps"].notna()]
    for _, agent in ran.sort_values("episode").groupby("seed", sort=True):
        finished.append(agent["steps"].cumsum().to_numpy())
        values.append(agent[value].to_numpy())
    return finished, values


def values_at_steps(finished: list, values: list, steps) -> np.ndarray:
    """agents x len(`steps`): each agent's value of the last episode it had finished by each
    number of `steps` (`finished_episodes`' ends and values; every step at or after the
    agent's first end)."""
    return np.array([agent_values[np.searchsorted(ends, steps, side="right") - 1]
                     for ends, agent_values in zip(finished, values)])


def curve_end(table: pd.DataFrame, value: str, by_steps: bool = False) -> tuple:
    """`(where, Estimate)`: a run's curve at its last point, the mean over agents of `value`
    with its 95 % interval (`statistics.mean_interval`): at its last episode that every agent
    ran, or (`by_steps`) at `curve_by_steps`' last number of steps; `where` is that episode
    or number of steps."""
    if by_steps:
        steps, grid = curve_by_steps(table, value)
        return int(steps[-1]), statistics.mean_interval(grid[:, -1])
    ran = table[table["steps"].notna()]
    last = int(ran.groupby("seed")["episode"].max().min())
    return last, statistics.mean_interval(ran.loc[ran["episode"] == last, value])


def plot_runs(runs: list, value: str, ylabel: str, log: bool = False, by_steps: bool = False):
    """The learning curves of `runs`, `[(label, per-episode table)]` (each a run's
    episodes.csv: a row per agent and episode), on one axes: each run's mean over its agents
    per episode (or, `by_steps`, at equal numbers of environment steps, `curve_by_steps`)
    with its 95 % bootstrap interval over agents (`plot_learning_curve`,
    `statistics.episode_intervals`); the figure."""
    figure, axes = plt.subplots(figsize=(7, 4))
    for label, table in runs:
        if not by_steps:
            ran = table[table["steps"].notna()]  # not the episodes past a budget
            plot_learning_curve(ran, value, ylabel, "", axes=axes, interval=True, label=label)
            continue
        steps, grid = curve_by_steps(table, value)
        low, high = statistics.episode_intervals(grid)
        line, = axes.plot(steps, grid.mean(axis=0), label=label)
        axes.fill_between(steps, low, high, alpha=0.3, color=line.get_color())
    if by_steps:
        axes.set_xlabel("environment steps of training (per agent)")
        axes.set_ylabel(ylabel)
        axes.grid(alpha=0.3)
    handles, labels = axes.get_legend_handles_labels()
    keep = [i for i, text in enumerate(labels) if not text.startswith("95 %")]
    axes.legend([handles[i] for i in keep], [labels[i] for i in keep], fontsize=8,
                title="mean over agents, 95 % interval shaded", title_fontsize=8)
    if log:
        axes.set_yscale("log")
    return figure


@dataclasses.dataclass(frozen=True)
class Evidence:
    """One judged quantity for `plot_claims`: our estimate beside what the claim accepts."""

    panel: str
    """The quantity and its unit; one panel per distinct `panel`."""
    label: str
    """The row within the panel (e.g. "λ 0.4, confirmation run")."""
    estimate: statistics.Estimate
    accepted: tuple
    """`(low, high)`: the range the verdict's rule counts as reproducing the claim."""
    paper: float | None = None
    """The paper's own value, where it states one."""
    never: float | None = None
    """Values above this read "never" (an episode beyond the run's last)."""
    judged: bool = True
    """False for an estimate shown beside the judged one (e.g. a smaller run's)."""


def plot_claims(evidence: list, title: str):
    """Per judged quantity (a panel each), our 95 % intervals as bars with the point
    estimate (grey where not judged), the range the claim accepts shaded, and the paper's
    value as a diamond: in the style of rliable's interval plots, the paper's claims against
    our estimates at a glance."""
    panels = list(dict.fromkeys(item.panel for item in evidence))
    heights = [1 + 0.28 * sum(item.panel == panel for item in evidence) for panel in panels]
    figure, axes = plt.subplots(len(panels), 1, figsize=(7.5, sum(heights) + 0.6),
                                gridspec_kw={"height_ratios": heights}, squeeze=False)
    for ax, panel in zip(axes[:, 0], panels):
        rows = [item for item in evidence if item.panel == panel]
        never = min((item.never for item in rows if item.never is not None), default=None)

        def shown(x):
            """Where `x` is drawn: an episode beyond the run's last at the one after it."""
            return x if never is None or x <= never else never + 1
        ends = [x for item in rows
                for x in (*item.accepted, item.paper, *(shown(v) for v in (
                    item.estimate.value, item.estimate.low, item.estimate.high)))
                if x is not None and np.isfinite(x)]
        low, high = min(ends), max(ends)
        ax.axvspan(*rows[0].accepted, color="tab:green", alpha=0.15, lw=0,
                   label="what the claim accepts")
        for y, item in enumerate(rows):
            value = shown(item.estimate.value)
            color = "tab:blue" if item.judged else "0.6"
            label = "our estimate, judged" if item.judged else "our estimate, not judged"
            if np.isfinite(item.estimate.low):
                ax.plot([shown(item.estimate.low), shown(item.estimate.high)], [y, y],
                        color=color, lw=3, solid_capstyle="butt")
            ax.plot(value, y, "o", color=color, ms=5, label=label)
            if never is not None and item.estimate.value > never:
                ax.annotate("never", (value, y), xytext=(4, -3), textcoords="offset points",
                            fontsize=7)
            if item.paper is not None:
                ax.plot(item.paper, y, "D", color="tab:red", ms=5,
                        label="the paper" if y == 0 else None)
        ax.set_yticks(range(len(rows)), [item.label for item in rows], fontsize=7)
        ax.set_ylim(len(rows) - 0.5, -0.5)
        pad = 0.05 * (high - low or 1)
        ax.set_xlim(low - pad, high + pad)
        ax.set_title(panel, fontsize=8, loc="left")
        ax.tick_params(axis="x", labelsize=7)
        ax.grid(alpha=0.3, axis="x")
    handles = {label: handle for ax in axes[:, 0]
               for handle, label in zip(*ax.get_legend_handles_labels())}
    figure.legend(handles.values(), handles.keys(), loc="upper right", fontsize=7)
    figure.suptitle(title, fontsize=9, x=0.02, ha="left")
    figure.tight_layout(rect=(0, 0, 1, 1 - 0.5 / figure.get_figheight()))
    return figure
