"""`lwrl bench`'s search for the baselines: rl-baselines3-zoo tuned DQN and PPO on Gymnasium's
tasks, which are not the paper's (random starts, 60-s and 240-s episodes, the pendulum's
shaped reward), so each baseline gets a small search per task before its row runs.

The candidates (`candidates`): the zoo's set; the same with its learning rate (Adam's step
size, the setting these learners are most sensitive to) times each of `FACTORS`; and the same
with its horizon and warm-up `SHORTER` times shorter (`timesteps`, and DQN's
`learning_starts`). The zoo tuned those for Gymnasium's budgets, 50 000 to 1 000 000 steps,
while the benchmark gives an agent 20 or 30 episodes (on the cart-pole a few hundred steps
until it balances), so that with the zoo's own a DQN agent may still explore at random, or
not yet learn at all, when its run ends. Each
candidate runs `AGENTS` agents on seeds of its own (`SEED`..., none of the benchmark's) under
the benchmark's protocol. The row takes the candidate with the best mean of the task's
measure over its agents (`choose`; the zoo's on a tie, as it is listed first), so the search
can only help the baseline and its choice is judged on other agents than it was chosen on.
Every candidate's runs are kept beside the rows' and listed in the report.

Its budget: `len(FACTORS) + 2` candidates of `AGENTS` agents per baseline and task, about as
much as the row it tunes.
"""

import dataclasses

import numpy as np

from lwrl.analysis import statistics as st
from lwrl.studies.paper import bench_protocol as protocol

SEARCHED = protocol.DEEP
"""The rows that are searched: the baselines, whose settings were tuned elsewhere."""
FACTORS = (0.3, 3.0)
"""The learning rates tried beside the zoo's, as factors of it."""
AGENTS = 2
"""Agents per candidate."""
SHORTER = 10
"""The shorter horizon and warm-up tried beside the zoo's, as a divisor of them."""
SEED = 100
"""The first candidate agent's seed (the benchmark's rows take 0 to N - 1)."""


def candidates(cells) -> dict:
    """`{(task, label): [RunConfig, ...]}`: the zoo's set first, then its learning rate times
    each of `FACTORS`, then its horizon and warm-up shorter, for every searched row of
    `cells` (`(task, label, RunConfig)`)."""
    found = {}
    for task, label, config in cells:
        if label not in SEARCHED:
            continue
        rate = config.agent.learning_rate
        base = dataclasses.replace(config, agents=AGENTS, seed=SEED)
        shorter = {"timesteps": max(1, config.agent.timesteps // SHORTER)}
        if hasattr(config.agent, "learning_starts"):
            shorter["learning_starts"] = config.agent.learning_starts // SHORTER
        found[task, label] = [base] + [dataclasses.replace(base, learning_rate=factor * rate)
                                       for factor in FACTORS] + [dataclasses.replace(base, **shorter)]
    return found


def score(results, config, task: str) -> np.ndarray:
    """Each agent's mean of the task's measure over its episodes, as the rows are scored."""
    column = protocol.TASKS[task].measure.column
    rows = results[results["run"] == config.key]
    return rows.groupby("seed")[column].mean().to_numpy()


def choose(found: dict, results) -> dict:
    """`{(task, label): RunConfig}`: the candidate with the best mean score, per searched row."""
    chosen = {}
    for (task, label), configs in found.items():
        sign = 1.0 if protocol.TASKS[task].measure.higher_is_better else -1.0
        means = [sign * float(np.mean(score(results, config, task))) for config in configs]
        chosen[task, label] = configs[int(np.nanargmax(means))]
    return chosen


def table(task: str, found: dict, chosen: dict, results) -> list:
    """The report's lines on the task's search: every candidate's score, the chosen marked."""
    lines = []
    for (t, label), configs in found.items():
        if t != task:
            continue
        zoo = configs[0].agent.learning_rate
        lines += [f"Search for {label} ({AGENTS} agents each, seeds {SEED} to "
                  f"{SEED + AGENTS - 1}; the row takes the best mean):", "",
                  "| learning rate | × the zoo's | horizon (timesteps) | measure (95 % interval) | chosen |",
                  "|---|---|---|---|---|"]
        for config in configs:
            rate = config.agent.learning_rate
            estimate = st.mean_interval(score(results, config, task))
            mark = "**yes**" if config.key == chosen[t, label].key else ""
            lines.append(f"| {rate:g} | {rate / zoo:g} | {config.agent.timesteps} | "
                         f"{estimate.text(1)} | {mark} |")
        lines.append("")
    return lines
