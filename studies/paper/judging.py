"""How the paper's items are judged: the report section, the choice of a best cell on one
half of the seeds and its measure on the other, the confirmation runs at the chosen cells,
and the texts of episodes and verdicts.

Where a best alpha (or lambda) is chosen, it is chosen on the first half of each run's agents
(seeds) and measured on the second half, so that the choice does not flatter the number it
is judged by (the winner's curse). Items with `confirm` take a confirmation run: more agents
on fresh seeds at the cells chosen on the first half (`lwrl reproduce --agents-per-cell N`);
the verdict is then judged on it, and the paper-sized run's own verdict is kept beside it.
"""

import dataclasses
import math
from typing import Callable

import numpy as np
import pandas as pd

from lwrl.analysis import statistics as st

CELL = ("features", "trace", "lam", "alpha")
"""The settings that tell the runs of an item's grid apart."""


@dataclasses.dataclass
class Section:
    """An item's part of the report."""

    rows: list
    """(quantity, ours, paper's) triples, from the paper-sized run."""
    verdict: str
    """`yes`, `partly` or `no`: the confirmation run's where there is one."""
    rule: str
    """How the verdict was decided."""
    notes: list = dataclasses.field(default_factory=list)
    figures: list = dataclasses.field(default_factory=list)
    claim: str = ""
    """The paper's sentence the verdict judges."""
    measure: str = ""
    """The quantity lwrl measures for it, and on which agents."""
    confirmed: dict | None = None
    """Quantity -> the confirmation run's value (None: no confirmation run)."""
    confirmation: str = ""
    """The confirmation run: how many agents, which seeds."""
    paper_sized_verdict: str | None = None
    """The paper-sized run's own verdict, where the verdict is the confirmation's."""
    evidence: list = dataclasses.field(default_factory=list)
    """The judged quantities' `Evidence`, for the figure of claims against intervals."""


@dataclasses.dataclass(frozen=True)
class Item:
    """One figure or table of the paper."""

    name: str
    title: str
    configs: Callable[[str, bool, str], list]
    """`configs(plant, quick, integrator)`: the runs it needs."""
    analyse: Callable[..., Section]
    """`analyse(results, figure_dir, confirmation=None)`: figures and the report section;
    `confirmation` the results of the runs `confirm` asked for."""
    confirm: Callable[[list, pd.DataFrame, int], list] | None = None
    """`confirm(configs, results, agents)`: the confirmation runs, `agents` fresh agents at
    each cell the analysis chooses from `results` (None: the item takes none)."""


def per_agent(results: pd.DataFrame, value: str, keys=CELL):
    """Each agent's mean of `value` over its episodes, with the run's keys, its seed and
    whether it is in the first half of its run's agents (`selection`); NaN for an agent that
    diverged (its run cannot count as a working configuration)."""
    grouped = results.groupby(list(keys) + ["agent", "seed"], sort=True)
    means = grouped[value].mean()
    means[grouped["diverged"].any()] = np.nan
    table = means.reset_index()
    size = table.groupby(list(keys))["agent"].transform("count")
    table["selection"] = table["agent"] < size / 2
    return table


def best_alpha(agents: pd.DataFrame, value: str, minimise: bool,
               keys=("features", "trace", "lam"), over=("alpha",)):
    """Per `keys`, the cell (values of `over`) whose agents' mean `value` is best, with that
    mean and its standard error over agents; also every cell. Cells with a diverged agent
    are excluded from the choice."""
    cells = agents.groupby(list(keys) + list(over))[value].agg(
        mean=lambda v: v.mean() if v.notna().all() else np.nan,
        error=lambda v: v.std(ddof=1) / math.sqrt(len(v)) if len(v) > 1 else np.nan)
    cells = cells.reset_index()
    valid = cells.dropna(subset=["mean"])
    by = valid.groupby(list(keys))["mean"]
    return valid.loc[by.idxmin() if minimise else by.idxmax()].reset_index(drop=True), cells


@dataclasses.dataclass
class Choice:
    """The cells chosen per `keys` and the agents they are measured on."""

    cells: pd.DataFrame
    """`keys`, `over` and `mean` (on the agents the choice was made on) per chosen cell."""
    measured: pd.DataFrame
    """The per-agent rows the chosen cells are judged on (the other half of the seeds)."""
    how: str
    """The choice, in words, for the report."""


def seeds_text(rows: pd.DataFrame) -> str:
    """The seeds of `rows` in words: `seed 3` or `seeds 0–9`."""
    seeds = sorted(rows["seed"].unique())
    return f"seed {seeds[0]}" if len(seeds) == 1 else f"seeds {seeds[0]}–{seeds[-1]}"


def choose(agents: pd.DataFrame, value: str, minimise: bool, keys, over) -> Choice:
    """Per `keys`, the best cell over `over`, chosen on the first half of each run's agents
    and measured on the second half; where there is nothing to choose (one cell per `keys`),
    every agent is measured."""
    names = " and ".join("α" if name == "alpha" else "λ" for name in over)
    if (agents.groupby(list(keys))[list(over)].nunique() <= 1).all(axis=None):
        best, _ = best_alpha(agents, value, minimise, keys, over)
        return Choice(best, agents, f"one {names} per cell, measured on every agent "
                                    f"({seeds_text(agents)})")
    first, second = agents[agents["selection"]], agents[~agents["selection"]]
    best, _ = best_alpha(first, value, minimise, keys, over)
    return Choice(best, second, f"the best {names} chosen on the first half of each cell's "
                                f"agents ({seeds_text(first)}) and measured on the second half "
                                f"({seeds_text(second)})")


def at(rows: pd.DataFrame, cell, columns=CELL) -> pd.DataFrame:
    """The rows of `rows` in `cell` (a mapping with the values of `columns` it has)."""
    mask = np.ones(len(rows), dtype=bool)
    for column in columns:
        if column in cell:
            mask &= np.isclose(rows[column], cell[column]) if column in ("lam", "alpha") \
                else (rows[column] == cell[column]).to_numpy()
    return rows[mask]


def fresh_agents(config, agents: int):
    """`config` with `agents` fresh agents: seeded from the end of the run's own seeds on, so
    they share no seed with it."""
    return dataclasses.replace(config, agents=agents, seed=config.seed + config.agents)


def at_cells(configs, cells: pd.DataFrame, agents: int) -> list:
    """The runs of `configs` in the chosen `cells`, each with `agents` fresh agents
    (`fresh_agents`)."""
    chosen = [row for _, row in cells.iterrows()]
    settings = [(getattr(c.settings, "features", None), getattr(c.settings, "trace", None),
                 getattr(c.settings, "lam", None), getattr(c.settings, "alpha", None)) for c in configs]
    return [fresh_agents(config, agents) for config, (features, trace, lam, alpha)
            in zip(configs, settings)
            if features is not None and any(
                features == row["features"] and trace == row["trace"]
                and math.isclose(lam, row["lam"]) and math.isclose(alpha, row["alpha"])
                for row in chosen)]


def matrix(results: pd.DataFrame, value: str) -> np.ndarray:
    """`value` as an agents x episodes array (agents in seed order)."""
    return results.pivot_table(index="seed", columns="episode", values=value).to_numpy()


def episode_text(estimate: st.Estimate, episodes: int) -> str:
    """An episode number and its interval; beyond the run's last episode reads "never"."""
    def one(x):
        return "never" if x > episodes else f"{x:g}"
    if math.isnan(estimate.low):
        return one(estimate.value)
    return f"{one(estimate.value)} [{one(estimate.low)}, {one(estimate.high)}]"


def trace_verdict(outcomes) -> tuple[str, int, int, int]:
    """From the per-lambda outcomes (+1 the paper's trace better, -1 worse, 0 a tie not
    excluded): the verdict and the counts of better, worse and ties."""
    wins, losses = outcomes.count(1), outcomes.count(-1)
    ties = len(outcomes) - wins - losses
    if losses == 0 and wins >= (len(outcomes) + 1) // 2:
        return "yes", wins, losses, ties
    return ("no" if losses > wins else "partly"), wins, losses, ties


def score_verdict(score: int, yes: int, partly: int) -> str:
    """`yes` from a score of `yes` up, `partly` from `partly` up, else `no`."""
    return "yes" if score >= yes else "partly" if score >= partly else "no"


def merge_confirmation(section: Section, confirmed: tuple | None, description: str) -> Section:
    """`section` (the paper-sized run's) with the confirmation run's rows, verdict and rule."""
    if confirmed is None:
        return section
    rows, verdict, rule, evidence = confirmed
    order = list(dict.fromkeys(item.label for item in section.evidence + evidence))
    pairs = sorted([(item, "paper-sized run", False) for item in section.evidence]
                   + [(item, "confirmation run", True) for item in evidence],
                   key=lambda pair: order.index(pair[0].label))  # each quantity's two rows together
    section.evidence = [dataclasses.replace(item, label=f"{item.label}, {run}", judged=judged)
                        for item, run, judged in pairs]
    section.paper_sized_verdict, section.verdict = section.verdict, verdict
    section.rule = f"{rule} (the paper-sized run alone: {section.paper_sized_verdict})"
    section.confirmed = {quantity: ours for quantity, ours, _ in rows}
    known = {quantity for quantity, _, _ in section.rows}
    section.rows += [row[:1] + ("—",) + row[2:] for row in rows if row[0] not in known]
    section.confirmation = description
    return section


def confirmation_text(confirmation: pd.DataFrame) -> str:
    """The confirmation run in words: agents per cell and their seeds."""
    per_run = confirmation.groupby("run")["agent"].nunique()
    agents = per_run.iloc[0] if per_run.nunique() == 1 else f"{per_run.min()} to {per_run.max()}"
    return f"{agents} agents per cell, {seeds_text(confirmation)}, at the cells chosen above"
