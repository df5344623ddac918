"""Agents that stall at the start: training episodes that run to the time limit before the
agent first reaches the goal, read from benchmarks' run tables, with what the agents reach
after the whole budget.

It answers why DQN's zoo set on the acrobot reached the goal with 1 of its 3 agents in the
second benchmark's search and with 19 of 20 in its row (docs/FINDINGS.md, the third
benchmark's section, "Why DQN's zoo set on the acrobot scored 1 of 3 in a search and 19 of
20 in a row"):

    python -m lwrl.studies.paper.benchmark.stalled_starts docs/benchmark2 docs/benchmark3 \\
        --runs acrobot.swingup-analytic-dqn_jax-256x256-lr0.00063-t100000

For each benchmark directory, the training runs whose names start with `--runs` (one
configuration's runs: a name is its task, plant, learner, network, rate and horizon, and the
command refuses names that hold different settings), and in them each agent once (a seed's
shorter trainings repeat its longer one's first episodes): its seed; how many of its first
training episodes ran to the time limit (`truncated`) before one reached the goal, and the
steps they took; whether its greedy episodes after the whole budget all reach the goal
(`—` where it was not trained that far). Then, per block of seeds (a search's, a row's:
seeds that share their thousands), the agents stalled at the start, the share over all
blocks with its Clopper-Pearson interval (`analysis.thresholds.success_share`), and for each
block the binomial probability of as many stalled agents or more at that share.
"""

import argparse
import pathlib
import sys

import numpy as np
import pandas as pd
from scipy import stats

from lwrl import outputs
from lwrl.analysis import thresholds
from lwrl.runners import summary
from lwrl.studies.paper.benchmark import protocol

RUN_FIELDS = ("run", "episodes", "agents", "budget", "learn", "greedy", "trained")
"""The run tables' columns that say how a run was made, not with which settings."""

BLOCK = 1000
"""Seeds that share their thousands form a block: the benchmarks seed each search and row
from its own thousand."""


def settings_of(table: pd.DataFrame) -> tuple:
    """A training table's learner and task settings, as `(column, text)` pairs."""
    columns = [c for c in table.columns if c not in RUN_FIELDS + summary.COLUMNS]
    return tuple((c, str(table[c].iloc[0])) for c in sorted(columns))


def stalled(steps: np.ndarray, truncated: np.ndarray, budget: int) -> tuple:
    """`(episodes, steps)`: the first training episodes that ran to the time limit before
    one ended at the goal, and the steps they took. The last episode of a training that
    spent its whole `budget` is cut by the budget, not by the time limit, and is not one."""
    if steps.sum() >= budget:
        steps, truncated = steps[:-1], truncated[:-1]
    count = int(np.argmin(truncated)) if not truncated.all() else len(truncated)
    return count, int(steps[:count].sum())


def reached(greedy: pd.DataFrame) -> dict:
    """Per agent, whether every greedy episode of an evaluation ended at the goal."""
    return {int(agent): not episodes["truncated"].astype(bool).any()
            for agent, episodes in greedy.groupby("agent")}


def agents(directory: str, prefix: str) -> pd.DataFrame:
    """One row per training agent of the runs named `prefix…` in `directory/runs` (see the
    module): seed, stalled episodes and steps, reached after the whole budget (or None)."""
    paths = sorted(pathlib.Path(directory, "runs").glob(f"{prefix}-s*.csv.gz"))
    tables = [outputs.read_table(path) for path in paths]
    trainings = [t for t in tables if bool(t["learn"].iloc[0])]
    if not trainings:
        raise ValueError(f"{directory}/runs holds no training run named {prefix}-s…")
    kinds = {settings_of(t) for t in trainings}
    if len(kinds) > 1:
        raise ValueError(f"the runs named {prefix}-s… in {directory} hold {len(kinds)} "
                         "configurations; give a longer name")
    outcomes = {t["trained"].iloc[0]: reached(t) for t in tables if bool(t["greedy"].iloc[0])}
    rows = {}
    for training in sorted(trainings, key=lambda t: int(t["budget"].iloc[0])):
        run, budget = training["run"].iloc[0], int(training["budget"].iloc[0])
        whole = budget >= protocol.BUDGETS.get(training["task"].iloc[0], np.inf)
        for agent, episodes in training.groupby("agent"):
            seed = int(episodes["seed"].iloc[0])
            count, steps = stalled(episodes["steps"].to_numpy(),
                                   episodes["truncated"].astype(bool).to_numpy(),
                                   budget)
            outcome = outcomes.get(run, {}).get(int(agent)) if whole else None
            previous = rows.get(seed, {}).get("reached")
            rows[seed] = {"seed": seed, "stalled": count, "stalled_steps": steps,
                          "reached": previous if outcome is None else outcome}
    return pd.DataFrame(rows.values()).sort_values("seed", ignore_index=True)


def blocks(table: pd.DataFrame, share: float) -> pd.DataFrame:
    """Per block of seeds of `table` (`agents`): its agents, those stalled at the start, and
    the binomial probabilities of as many stalled or more and of as many or fewer where each
    stalls with `share`."""
    grouped = table.assign(block=table["seed"] // BLOCK).groupby("block")
    out = grouped.agg(first=("seed", "min"), last=("seed", "max"), agents=("seed", "size"),
                      stalled=("stalled", lambda s: int((s > 0).sum())))
    out["p_as_many"] = stats.binom.sf(out["stalled"] - 1, out["agents"], share)
    out["p_as_few"] = stats.binom.cdf(out["stalled"], out["agents"], share)
    return out.reset_index(drop=True)


def answer(reached) -> str:
    """`yes`, `no`, or `—` where the agent was not evaluated after the whole budget."""
    return "—" if reached is None or pd.isna(reached) else ("yes" if reached else "no")


def lines(directories, prefix: str) -> list:
    """The report the command prints (see the module)."""
    per = {d: agents(d, prefix) for d in directories}
    every = pd.concat(per.values(), ignore_index=True)
    share = thresholds.success_share(every["stalled"].to_numpy() > 0)
    out = [f"# Stalled starts: {prefix}", ""]
    for directory, table in per.items():
        out += [f"## {directory}", "",
                "| seed | episodes at the time limit before the goal | their steps "
                "| greedy episodes reach the goal after the whole budget |", "|---|---|---|---|"]
        out += [f"| {r.seed} | {r.stalled} | {r.stalled_steps} | {answer(r.reached)} |"
                for r in table.itertuples()]
        out += [""]
    out += [f"Stalled at the start: {int((every['stalled'] > 0).sum())} of {len(every)} agents, "
            f"{share.text(2)} (Clopper-Pearson).", ""]
    judged = every.dropna(subset=["reached"])
    for name, group in (("stalled", judged[judged["stalled"] > 0]),
                        ("not stalled", judged[judged["stalled"] == 0])):
        out += [f"- {name}: {int(group['reached'].sum())} of {len(group)} reach the goal in "
                "every greedy episode after the whole budget"]
    out += ["", "| benchmark | seeds | agents | stalled | P(as many or more at the share) "
            "| P(as many or fewer) |", "|---|---|---|---|---|---|"]
    for directory, table in per.items():
        out += [f"| {directory} | {b.first}–{b.last} | {b.agents} | {b.stalled} "
                f"| {b.p_as_many:.3g} | {b.p_as_few:.3g} |"
                for b in blocks(table, share.value).itertuples()]
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("directories", nargs="+", help="benchmark directories (with runs/)")
    parser.add_argument("--runs", required=True, help="the runs' name up to its seed")
    args = parser.parse_args(argv)
    try:
        print("\n".join(lines(args.directories, args.runs)))
    except (ValueError, OSError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
