"""Learning results as statistics: means with standard errors over agents, per block of
episodes, and the files a run writes."""

import csv
import math

import numpy as np

from lwrl import outputs

COLUMNS = ("agent", "seed", "episode", "steps", "return", "uptime_s", "truncated", "diverged")
"""Columns of `episodes.csv`, one row per agent and episode."""


def mean_and_error(per_agent: np.ndarray) -> tuple[float, float]:
    """Mean and standard error over agents (NaN entries, i.e. not run, left out)."""
    values = per_agent[np.isfinite(per_agent)]
    if len(values) == 0:
        return math.nan, math.nan
    error = values.std(ddof=1) / math.sqrt(len(values)) if len(values) > 1 else math.nan
    return float(values.mean()), float(error)


def block_rows(results, blocks: int = 10) -> list[dict]:
    """Per block of consecutive episodes: each agent's mean over the block, then the mean
    and standard error of those over agents, for steps, return and up-time."""
    episodes = results.steps.shape[1]
    edges = np.unique(np.linspace(0, episodes, min(blocks, episodes) + 1).round().astype(int))
    rows = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        row = {"episodes": f"{lo + 1}-{hi}" if hi - lo > 1 else f"{hi}"}
        for name, values in (("steps", results.steps), ("return", results.returns),
                             ("uptime_s", results.uptime)):
            block = values[:, lo:hi]
            ran = np.isfinite(block).any(axis=1)
            per_agent = np.full(len(block), np.nan)
            per_agent[ran] = np.nanmean(block[ran], axis=1)
            row[name] = mean_and_error(per_agent)
        rows.append(row)
    return rows


def format_rows(rows: list[dict], with_uptime: bool) -> str:
    """The block table as text: `mean ± standard error` per column."""
    names = ["steps", "return"] + (["uptime_s"] if with_uptime else [])
    header = f"{'episodes':>10}" + "".join(f"{name:>22}" for name in names)
    lines = [header]
    for row in rows:
        cells = "".join(f"{row[name][0]:>12.2f} ± {row[name][1]:<7.2f}" for name in names)
        lines.append(f"{row['episodes']:>10}{cells}")
    return "\n".join(lines)


def divergence_note(results, seeds) -> str:
    """One line naming the agents that diverged and when, or that none did."""
    diverged = np.flatnonzero(results.diverged_episode >= 0)
    if len(diverged) == 0:
        return "no agent diverged"
    listed = ", ".join(f"agent {b} (seed {seeds[b]}, episode {results.diverged_episode[b] + 1})"
                       for b in diverged)
    return f"{len(diverged)} of {len(seeds)} agents diverged and were frozen: {listed}"


def write_csv(path, results, seeds) -> None:
    """`episodes.csv`: one row per agent and episode (NaN where an episode was not run),
    whole or not at all."""
    with outputs.atomic_write(path, newline="") as file:
        writer = csv.writer(file)
        writer.writerow(COLUMNS)
        columns = results.columns(seeds)
        for row in zip(*(columns[name] for name in COLUMNS)):
            agent, seed, episode, steps, total, uptime, truncated, diverged = row
            writer.writerow([agent, seed, episode, "" if math.isnan(steps) else int(steps),
                             total, uptime, int(truncated), int(diverged)])
