"""Learning results as statistics: means with standard errors over agents, per block of
episodes, and the files a run writes."""

import csv
import math

import numpy as np

from lwrl import outputs

COLUMNS = ("agent", "seed", "episode", "steps", "return", "uptime_s", "truncated", "diverged")
"""Columns of `episodes.csv`, one row per agent and episode; a column per parameter drawn
per episode follows (`EpisodeResults.physical`)."""


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


UNDEFINED = "—"
"""What a table shows where a value is undefined (a footnote says why)."""
HEADERS = {"steps": "steps", "return": "return", "uptime_s": "up-time (s)"}
"""The summary's column header of each measure."""


def plural(count: int, noun: str, nouns: str | None = None) -> str:
    """`1 agent`, `2 agents` (`nouns`: the plural where it is not `noun + s`)."""
    return f"{count} {noun if count == 1 else nouns or noun + 's'}"


def format_rows(rows: list[dict], with_uptime: bool) -> str:
    """The block table as text, aligned on the decimal points: `mean ± standard error` per
    column; only the mean where no block has a standard error (one agent); `—` where a value
    is undefined (`table_notes` says why)."""
    names = ["steps", "return"] + (["uptime_s"] if with_uptime else [])
    with_errors = any(math.isfinite(row[name][1]) for row in rows for name in names)
    means = {name: [f"{row[name][0]:.2f}" if math.isfinite(row[name][0]) else UNDEFINED
                    for row in rows] for name in names}
    errors = {name: ["" if not math.isfinite(row[name][0]) else
                     f"{row[name][1]:.2f}" if math.isfinite(row[name][1]) else UNDEFINED
                     for row in rows] for name in names}
    columns = {}
    for name in names:
        mean_width = max(len(text) for text in means[name])
        error_width = max(len(text) for text in errors[name])
        cells = [mean.rjust(mean_width) + (f" ± {error.rjust(error_width)}" if error
                                           else " " * (error_width + 3)) if with_errors else
                 mean.rjust(mean_width) for mean, error in zip(means[name], errors[name])]
        width = max(len(HEADERS[name]), *(len(cell) for cell in cells))
        columns[name] = [HEADERS[name].rjust(width)] + [cell.rjust(width) for cell in cells]
    first = ["episodes"] + [row["episodes"] for row in rows]
    first = [text.rjust(max(map(len, first))) for text in first]
    lines = ["   ".join([label, *(columns[name][i] for name in names)]).rstrip()
             for i, label in enumerate(first)]
    return "\n".join(lines)


def table_notes(rows: list[dict], results, seeds, with_uptime: bool) -> list[str]:
    """What the table's numbers are (over which agents and seeds), and why a value is `—`."""
    names = ["steps", "return"] + (["uptime_s"] if with_uptime else [])
    agents = len(seeds)
    seed_text = f"seed {seeds[0]}" if agents == 1 else f"seeds {seeds[0]}..{seeds[-1]}"
    notes = [f"one agent ({seed_text}): its own values, no standard error" if agents == 1
             else f"means ± standard errors over {agents} agents ({seed_text})"]
    cells = [row[name] for row in rows for name in names]
    if any(not math.isfinite(mean) for mean, _ in cells):
        if results.interrupted:
            why = "the run was interrupted"
        elif np.all(results.diverged_episode >= 0):
            why = "every agent had diverged"
        else:
            why = "no agent ran them"
        notes.append(f"{UNDEFINED}: episodes not run ({why})")
    if agents > 1 and any(math.isfinite(mean) and not math.isfinite(error) for mean, error in cells):
        notes.append(f"± {UNDEFINED}: one agent ran these episodes, so no standard error")
    return notes


def divergence_note(results, seeds) -> str:
    """One line naming the agents that diverged and when, or that none did."""
    diverged = np.flatnonzero(results.diverged_episode >= 0)
    if len(diverged) == 0:
        return "no agent diverged"
    listed = ", ".join(f"agent {b} (seed {seeds[b]}, episode {results.diverged_episode[b] + 1})"
                       for b in diverged)
    verb = "was" if len(diverged) == 1 else "were"
    return (f"{len(diverged)} of {plural(len(seeds), 'agent')} diverged and {verb} frozen: "
            f"{listed}")


def write_csv(path, results, seeds) -> None:
    """`episodes.csv`: one row per agent and episode (NaN where an episode was not run) and
    the values drawn for it, whole or not at all."""
    drawn = tuple(results.physical)
    with outputs.atomic_write(path, newline="") as file:
        writer = csv.writer(file)
        writer.writerow(COLUMNS + drawn)
        columns = results.columns(seeds)
        for row in zip(*(columns[name] for name in COLUMNS + drawn)):
            agent, seed, episode, steps, total, uptime, truncated, diverged = row[:len(COLUMNS)]
            writer.writerow([agent, seed, episode, "" if math.isnan(steps) else int(steps),
                             total, uptime, int(truncated), int(diverged), *row[len(COLUMNS):]])
