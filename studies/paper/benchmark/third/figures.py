"""The third benchmark's figures: per task, each row's greedy normalised score on the fine
clock (`clock`), and across tasks the aggregates and performance profiles the report tables
(rliable's figures, `analysis.verdicts.plot_aggregates`, `plot_profiles`).

A row's curve is the mean over its agents at each point of the clock with its 95 % interval
(`analysis.statistics.mean_interval`), against the fraction of the budget on a log axis (the
clock's points are log-spaced); a row continued past the budget goes on to 4 times it, one
whose score was carried from 1 ends there. Dashed, the level the times to the level read;
dotted, the points the verdicts read (1/4, 1 and 4 times the budget).
"""

import os

import numpy as np

from lwrl.analysis import plots, verdicts
from lwrl.analysis.statistics import mean_interval
from lwrl.studies.paper.benchmark import protocol
from lwrl.studies.paper.benchmark.third import clock

FIGURES = "figures"
"""The folder of the benchmark's directory its figures are written to."""


def directory(out_dir: str) -> str:
    """The benchmark's folder of figures (`FIGURES` in `out_dir`), made where it is not."""
    path = os.path.join(out_dir, FIGURES)
    os.makedirs(path, exist_ok=True)
    return path


def row_curve(row) -> tuple:
    """`(fractions, estimates)` of one row (`study.RowRuns`): its points of the clock, those
    past the budget where it was continued."""
    scores = {**row.scores, **(row.longer or {})}
    points = sorted(scores)
    return (np.array([clock.fraction(point) for point in points]),
            [mean_interval(scores[point]) for point in points])


def clock_curves(runs, figure_dir: str) -> list:
    """One task's rows (`study.TaskRuns`) on the fine clock, as `figure_dir/<task>-clock.png`
    and `.svg`; the paths."""
    import matplotlib.pyplot as plt
    figure, axes = plt.subplots(figsize=(9.5, 4.5))
    for label, row in runs.rows.items():
        fractions, estimates = row_curve(row)
        plots.plot_estimates(axes, fractions, estimates, label, marker=".")
    axes.axhline(protocol.LEVEL, color="grey", linewidth=0.8, linestyle="--")
    for point in clock.VERDICTS:
        axes.axvline(clock.fraction(point), color="grey", linewidth=0.6, linestyle=":")
    axes.set_xscale("log", base=2)
    axes.set_xlabel("fraction of the budget of environment steps")
    axes.set_ylabel("greedy normalised score")
    # the legend beside the axes: inside, it hid the rows continued past the budget
    axes.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes.set_title(runs.task)
    figure.tight_layout()
    return plots.save_figure(figure, figure_dir, f"{runs.task}-clock")


def aggregate_figures(estimates: dict, profiles: dict, figure_dir: str, name: str) -> list:
    """The aggregates and the performance profiles at `name` times the budget, as
    `figure_dir/aggregates-<name>` and `profiles-<name>` (`.png`, `.svg`); the paths."""
    return (verdicts.plot_aggregates(estimates, figure_dir, f"aggregates-{name}")
            + verdicts.plot_profiles(profiles, figure_dir, f"profiles-{name}"))
