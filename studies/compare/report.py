"""The plant comparison's summary tables, figures and Markdown report (`lwrl compare`)."""

import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from lwrl.studies.compare import closed_loop as cl  # noqa: E402
from lwrl.studies.compare import open_loop as ol  # noqa: E402
from lwrl import tasks  # noqa: E402
from lwrl.analysis.plots import plot_learning_curve, save_figure  # noqa: E402

FLOOR = 1e-16
"""Errors below this (exact agreement) are drawn at it on the logarithmic axes."""
LAST_EPISODES = 20
"""The late-learning window of the closed-loop table."""


def _pm(mean: float, error: float, digits: int = 1) -> str:
    return f"{mean:.{digits}f} ± {error:.{digits}f}"


def _pair_name(plant: str, against: str) -> str:
    return f"{ol.LABELS[plant]} vs {ol.LABELS[against]}"


def divergence_table(result: ol.OpenLoop) -> pd.DataFrame:
    """Per pair: the median over trials of the time within tolerance (and its range), the
    trials that left it, and per variable the median over trials of the largest |error| over
    1 s, 10 s and the horizon."""
    rows = []
    for (plant, against), trials in result.trials.groupby(["plant", "against"], sort=False):
        row = {"pair": _pair_name(plant, against),
               "time within tolerance (s), median [min, max]":
                   f"{trials['time_within_s'].median():.2f} [{trials['time_within_s'].min():.2f}, "
                   f"{trials['time_within_s'].max():.2f}]",
               "trials leaving": f"{int(trials['left'].sum())} of {len(trials)}"}
        for column in trials.columns:
            if "_max_" in column:
                variable, _, span = column.partition("_max_")
                row[f"largest error of {variable}, {span.replace('_', ' ')}"] = f"{trials[column].median():.2g}"
        rows.append(row)
    return pd.DataFrame(rows)


def energy_table(result: ol.OpenLoop) -> pd.DataFrame:
    """Per plant: energy minus the reference's at the horizon (mean ± SE over trials), the
    median of its largest magnitude, and the reference's own change (friction)."""
    rows = []
    for plant, trials in result.energy.groupby("plant", sort=False):
        n = len(trials)
        rows.append({"plant": ol.LABELS[plant],
                     "drift at the horizon (J)": f"{trials['drift_J'].mean():+.3g} ± "
                                                 f"{trials['drift_J'].std(ddof=1) / math.sqrt(n):.2g}",
                     "largest drift magnitude (J), median": f"{trials['max_abs_drift_J'].median():.3g}",
                     "reference's change (J), mean": f"{trials['reference_change_J'].mean():+.3g}"})
    return pd.DataFrame(rows)


def learning_table(result: cl.ClosedLoop) -> pd.DataFrame:
    """Per plant: the measure per episode (up-time, else steps), mean ± SE over agents, over
    all episodes and the last `LAST_EPISODES`."""
    value, label = result.measure
    stats = [cl.agent_statistics(cl.per_agent_means(result.episodes, ["compared"], value, last=last),
                                 ["compared"], value).set_index("compared")
             for last in (None, LAST_EPISODES)]
    return pd.DataFrame([{"plant": ol.LABELS[plant],
                          f"{label}, all episodes": _pm(stats[0].loc[plant, "mean"], stats[0].loc[plant, "error"]),
                          f"{label}, last {LAST_EPISODES}": _pm(stats[1].loc[plant, "mean"], stats[1].loc[plant, "error"]),
                          "agents": int(stats[0].loc[plant, "agents"])}
                         for plant in cl.PLANTS])


def transfer_statistics(result: cl.ClosedLoop) -> pd.DataFrame:
    """Per training and evaluation plant: the greedy measure, mean and SE over agents."""
    keys, value = ["trained_on", "evaluated_on"], result.measure[0]
    return cl.agent_statistics(cl.per_agent_means(result.transfer, keys, value), keys, value)


def transfer_table(statistics: pd.DataFrame) -> pd.DataFrame:
    """The transfer matrix as text: rows trained on, columns evaluated on."""
    cells = statistics.assign(cell=[_pm(m, e) for m, e in zip(statistics["mean"], statistics["error"])])
    matrix = cells.pivot(index="trained_on", columns="evaluated_on", values="cell")
    matrix = matrix.loc[list(cl.PLANTS), list(cl.PLANTS)]
    matrix.index = [f"trained on {ol.LABELS[p]}" for p in matrix.index]
    matrix.columns = [f"on {ol.LABELS[p]}" for p in matrix.columns]
    return matrix.reset_index(names="")


def plot_divergence(result: ol.OpenLoop, domain: str, task: str):
    """|error| against time, one panel per compared variable, one line per pair (median
    over trials, band between the quartiles), logarithmic, with the tolerance."""
    variables = list(ol.tolerances(domain))
    figure, panels = plt.subplots(1, len(variables), figsize=(6.5 * len(variables), 4.5), squeeze=False)
    for axes, variable in zip(panels[0], variables):
        for (plant, against), rows in result.steps[result.steps["variable"] == variable].groupby(
                ["plant", "against"], sort=False):
            line, = axes.plot(rows["time_s"], np.maximum(rows["median"], FLOOR),
                              label=_pair_name(plant, against),
                              linestyle="--" if plant == "semi_implicit" else "-")  # on MuJoCo's
            axes.fill_between(rows["time_s"], np.maximum(rows["q25"], FLOOR),
                              np.maximum(rows["q75"], FLOOR), color=line.get_color(), alpha=0.2)
        axes.axhline(ol.tolerances(domain)[variable], color="black", linestyle="--",
                     label=f"tolerance {ol.tolerances(domain)[variable]:g}")
        axes.set_yscale("log")
        axes.set_xlabel("time (s)")
        axes.set_ylabel(f"|error| of {variable}")
        axes.grid(alpha=0.3)
    panels[0][0].set_title(f"{task}, open loop: median over {result.trials['seed'].nunique()} "
                           "random-action trials, quartile bands", loc="left")
    panels[0][-1].legend(fontsize=8)
    return figure


def plot_learning_curves(result: cl.ClosedLoop, task: str):
    """The plants' learning curves side by side (mean ± one SE over agents)."""
    figure, panels = plt.subplots(1, len(cl.PLANTS), figsize=(5 * len(cl.PLANTS), 4), sharey=True)
    for axes, plant in zip(panels, cl.PLANTS):
        plot_learning_curve(result.episodes[result.episodes["compared"] == plant], *result.measure,
                            f"{task}: {ol.LABELS[plant]}", axes=axes)
    return figure


def plot_transfer(statistics: pd.DataFrame, task: str, label: str):
    """The greedy measure (`label`) per training plant (groups) and evaluation plant (bars),
    ± one SE."""
    figure, axes = plt.subplots(figsize=(8, 4))
    width = 0.8 / len(cl.PLANTS)
    for i, evaluated_on in enumerate(cl.PLANTS):
        cells = statistics[statistics["evaluated_on"] == evaluated_on].set_index("trained_on").loc[list(cl.PLANTS)]
        axes.bar(np.arange(len(cl.PLANTS)) + (i - 1) * width, cells["mean"], width,
                 yerr=cells["error"], capsize=3, label=f"evaluated on {ol.LABELS[evaluated_on]}")
    axes.set_xticks(np.arange(len(cl.PLANTS)), [f"trained on\n{ol.LABELS[p]}" for p in cl.PLANTS])
    axes.set_ylabel(f"greedy {label}")
    axes.set_title(f"{task}: transfer between plants")
    axes.legend(fontsize=8)
    axes.grid(alpha=0.3, axis="y")
    return figure


def write_figures(open_result, closed_result, transfer, domain: str, task: str, figure_dir: str) -> dict:
    """The three figures as PNG and SVG; `{name: [paths]}`."""
    return {"divergence": save_figure(plot_divergence(open_result, domain, task), figure_dir, "divergence"),
            "learning_curves": save_figure(plot_learning_curves(closed_result, task), figure_dir,
                                           "learning_curves"),
            "transfer": save_figure(plot_transfer(transfer, task, closed_result.measure[1]),
                                    figure_dir, "transfer")}


def markdown_table(table: pd.DataFrame) -> list[str]:
    lines = ["| " + " | ".join(map(str, table.columns)) + " |", "|" + "---|" * len(table.columns)]
    return lines + ["| " + " | ".join(map(str, row)) + " |" for row in table.itertuples(index=False)]


def _block(text: str, table: pd.DataFrame, figure: str | None = None) -> list[str]:
    """A paragraph, its table and (optionally) its figure, as report lines."""
    return [text, ""] + markdown_table(table) + [""] + ([figure, ""] if figure else [])


def report(comparison, figures: dict, paper_sections: dict, out_dir: str) -> str:
    """The Markdown report of a `compare.Comparison`."""
    open_result, closed_result = comparison.open_loop, comparison.closed_loop
    domain = comparison.task.split(".")[0]
    config = closed_result.configs["mujoco"]
    seeds = config.seeds
    angles = tasks.definition(*tasks.split_name(comparison.task)).angles
    tolerance = ", ".join(f"{name} {value:g} {'rad' if name in angles else 'm'}"
                          for name, value in ol.tolerances(domain).items())

    def figure(name):
        return f"![{name}]({os.path.relpath(figures[name][0], out_dir)})"

    parting = cl.parting_episodes(closed_result.episodes)
    lines = [f"# {comparison.task}: the analytic and physics-engine plants compared"
             f"{' — quick smoke run' if comparison.quick else ''}", "",
             f"Seeds {seeds[0]}..{seeds[-1]} ({len(seeds)}): open-loop trials and agents alike. "
             "Wall time on this machine: " + ", ".join(
                 f"{part} {seconds:.0f} s" for part, seconds in comparison.timings.items()) + ".",
             "", "Plants: " + "; ".join(f"`{name}` {label}" for name, label in ol.LABELS.items()) + ".",
             "", "## Open loop", ""]
    lines += _block(
        f"Each trial starts from the task's start (seed s) and applies the same "
        f"{open_result.horizon} uniformly random actions ({open_result.horizon * open_result.timestep:g} s) "
        f"on every plant, ignoring terminations. Tolerance: {tolerance} from the other plant "
        "(angles compared modulo 2π). The reference is MuJoCo's RK4 with "
        f"{open_result.substeps} steps per control step; `reference_2x` halves its step again, "
        "so the last row bounds the reference's own error.",
        divergence_table(open_result), figure("divergence"))
    lines += _block(
        "Energy: zero action from the task's start or, where zero action never leaves it, "
        f"from the domain's `rest_start` (`tasks/{domain}.py`), with the task's friction; "
        "drift is the plant's mechanical energy minus the reference's, mean ± standard error "
        "over the trials.",
        energy_table(open_result))
    lines += ["## Closed loop", ""] + _block(
        f"{len(seeds)} agents per plant of {config.learner}: {config.describe()}, "
        f"{config.episodes} episodes (the task's defaults, `tasks/{domain}.py`); "
        f"means ± standard errors over agents of each agent's mean {closed_result.measure[1]}.",
        learning_table(closed_result), figure("learning_curves"))
    lines += ["MuJoCo and the analytic semi-implicit plant agree to round-off, so their agents "
              "live the same episodes until a round-off difference flips an action: the first "
              "episode whose steps or return differ, per seed: "
              + ", ".join(f"seed {seed}: {'never' if np.isnan(e) else int(e)}"
                          for seed, e in parting.items()) + ".", ""]
    for plant, (item, section) in paper_sections.items():
        lines += [f"The paper's {item} on {ol.LABELS[plant]}: **{section.verdict}** — {section.rule}.", "",
                  "| quantity | ours | paper |", "|---|---|---|"]
        lines += [f"| {quantity} | {ours} | {paper} |" for quantity, ours, paper in section.rows]
        lines.append("")
    lines += ["## Transfer", ""] + _block(
        f"Each trained batch run greedily (ε = 0, no learning) for "
        f"{closed_result.transfer['episode'].max()} episode(s) per agent on every plant, "
        f"from starts of seeds {cl.EVAL_SEED}.. (away from training); "
        f"{closed_result.measure[1]}, mean ± standard error over agents.",
        transfer_table(transfer_statistics(closed_result)), figure("transfer"))
    return "\n".join(lines) + "\n"
