"""Fig. 5: the best pendulum agent's up-time per episode, and the episode from which the
agents' mean stays above 40 s (section 4.2)."""

import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from lwrl.analysis import statistics as st  # noqa: E402
from lwrl.analysis.plots import Evidence, plot_learning_curve, save_figure  # noqa: E402
from lwrl.runners.config import RunConfig  # noqa: E402
from lwrl.studies.paper.judging import (Section, confirmation_text, episode_text,  # noqa: E402
                                        fresh_agents, matrix, merge_confirmation, seeds_text)

BALANCED_S = 40.0
"""Pendulum: more than 40 s up means balanced to the end (section 4.2)."""


def configs(plant, quick, integrator):
    return [RunConfig(task="pendulum.swingup", plant=plant, integrator=integrator,
                      trace="replacing", alpha=1.5, lam=0.4, agents=2 if quick else 10,
                      episodes=3 if quick else 200)]


def confirm(configs, results, agents):
    del results  # one cell: nothing to choose
    return [fresh_agents(config, agents) for config in configs]


def first_episode_over(results: pd.DataFrame, value: str, level: float) -> pd.Series:
    """Per agent, the first episode with `value` above `level` (NaN if none)."""
    over = results[results[value] > level]
    first = over.groupby("agent")["episode"].min()
    return first.reindex(sorted(results["agent"].unique()))


def _stays_balanced(uptime):
    """The episode from which the mean up-time over agents stays above 40 s to the end."""
    return st.first_from_which(uptime.mean(axis=-2) > BALANCED_S)


def judge(results):
    uptime = matrix(results, "uptime_s")
    agents, episodes = uptime.shape
    stays = st.matrix_interval(_stays_balanced, uptime)
    over = (uptime > BALANCED_S).mean(axis=0)
    start = int(stays.value) if stays.value <= episodes else 11
    later = over[start - 1:]
    first = first_episode_over(results, "uptime_s", BALANCED_S)
    median = first.median() if first.notna().sum() * 2 > len(first) else math.inf
    curve = uptime.mean(axis=0)
    mean_first = np.argmax(curve > BALANCED_S) + 1 if (curve > BALANCED_S).any() else math.inf
    rows = [("episode from which the mean up-time over agents stays above 40 s to the end",
             episode_text(stays, episodes), "about 10"),
            ("fraction of agents above 40 s per episode, from the episode above (or from "
             "episode 11, after the paper's about 10, where the mean never stays) to the end: "
             "median (lowest, highest)",
             f"{np.median(later):.2f} ({later.min():.2f}, {later.max():.2f}), episodes {start} "
             f"to {episodes}" if len(later) else "— (no such episode)",
             "—"),
            ("mean up-time over agents and all episodes (s)",
             st.mean_interval(uptime.mean(axis=1)).text(), "—"),
            ("first episode whose mean up-time over agents exceeds 40 s (touched once)",
             "never" if mean_first > episodes else f"{mean_first:g}", "—"),
            ("agents that ever exceed 40 s; median over agents of the first such episode "
             "(the earlier rule)",
             f"{first.notna().sum()} of {len(first)}; {'never' if median > episodes else f'{median:g}'}",
             "—")]
    verdict = "yes" if 5 <= stays.value <= 20 else "partly" if stays.value <= 50 else "no"
    evidence = [Evidence("Fig. 5: the episode from which the agents' mean up-time stays above "
                         "40 s", f"mean over {agents} agents", stays, (5, 20), paper=10, never=episodes)]
    rule = (f"the mean up-time stays above 40 s from episode {episode_text(stays, episodes)}; "
            "yes if from an episode within 5 to 20 (the paper's about 10), partly if within "
            f"50, no if later or never ({agents} agents)")
    return rows, verdict, rule, evidence


def analyse(results, figure_dir, confirmation=None):
    figure, axes = plt.subplots(2, 1, figsize=(6.5, 6.5), sharex=True,
                                gridspec_kw={"height_ratios": [2, 1]})
    for data, label in ((results, "paper-sized run"), (confirmation, "confirmation run")):
        if data is None:
            continue
        plot_learning_curve(data, "uptime_s", "up-time (s) of a 60 s episode",
                            "Fig. 5: pendulum, replacing, α 1.5, λ 0.4", axes=axes[0],
                            interval=True, label=f"mean over {data['seed'].nunique()} agents, {label}")
        fraction = (matrix(data, "uptime_s") > BALANCED_S).mean(axis=0)
        axes[1].plot(np.arange(1, len(fraction) + 1), fraction, label=label, linewidth=0.8)
    axes[0].axhline(BALANCED_S, color="k", linewidth=0.8, linestyle="--")
    axes[0].set_xlabel("")
    axes[1].set_ylabel("fraction of agents\nabove 40 s")
    axes[1].set_xlabel("episode")
    axes[1].grid(alpha=0.3)
    axes[1].legend(fontsize=7)
    figures = save_figure(figure, figure_dir, "fig5")
    rows, verdict, rule, evidence = judge(results)
    section = Section(rows, verdict, rule, [], figures, evidence=evidence,
                      claim="“An uptime over 40 seconds signifies that the pendulum is "
                            "successfully balanced until the end, which occurs after about 10 "
                            "episodes.” (section 4.2; Fig. 5: “Average up-time for the "
                            "best-performing agent […] as a function of episode”, replacing, "
                            "α 1.5, λ 0.4)",
                      measure="the up-time per episode averaged over the agents (the curve of "
                              "Fig. 5), and the episode from which it stays above 40 s to the "
                              f"end of the run; intervals over agents ({seeds_text(results)})")
    if confirmation is not None:
        merge_confirmation(section, judge(confirmation), confirmation_text(confirmation))
    return section
