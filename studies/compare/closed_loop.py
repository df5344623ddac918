"""Closed-loop comparison of the plants: the same agents learning on each, then transferred.

Each plant of `PLANTS` trains the same agent configuration (the task's defaults,
`agent.paper_settings`) with the same seeds; every trained batch is then run
greedily (ε = 0, no learning) on every plant, from starts drawn with seeds away from the
training ones (`EVAL_SEED`, as `lwrl eval`).
"""

import dataclasses

import numpy as np
import pandas as pd

from lwrl import tasks
from lwrl.runners.config import RunConfig
from lwrl.runners.run import run
from lwrl.runners.sweep import results_table
from lwrl.studies.compare.domains import COMPARISONS

PLANTS = ("mujoco", "semi_implicit", "explicit")
"""The plants agents learn on: MuJoCo (Euler) and the analytic plant in both Euler readings."""
EVAL_SEED = 1_000_000
"""Seed of the first agent's evaluation episodes (`lwrl eval`'s default)."""


def eval_episodes_of(task: str) -> int:
    """Greedy episodes per agent and plant: the domain's `transfer_episodes` (fewer where
    the start is fixed and a greedy agent's episodes repeat)."""
    return COMPARISONS.of(tasks.split_name(task)[0]).transfer_episodes


def measure(task: str) -> tuple[str, str]:
    """`(column, label)` of what the plants are held to, per episode: the up-time where the
    task has one, else the steps."""
    if tasks.definition(*tasks.split_name(task)).has_uptime:
        return "uptime_s", "up-time (s)"
    return "steps", "steps per episode"


def plant_config(task: str, plant: str, **fields) -> RunConfig:
    """The `RunConfig` of `task` on a plant of `PLANTS` (other fields as given)."""
    if plant not in PLANTS:
        raise ValueError(f"unknown plant {plant!r}; allowed: {', '.join(PLANTS)}")
    if plant == "mujoco":
        return RunConfig(task=task, plant="mujoco", **fields)
    return RunConfig(task=task, plant="analytic", integrator=plant, **fields)


@dataclasses.dataclass
class ClosedLoop:
    """The closed-loop study's results."""

    episodes: pd.DataFrame
    """Training: one row per plant, agent and episode (`sweep.results_table`'s columns
    plus `compared`, the plant's name in `PLANTS`)."""
    transfer: pd.DataFrame
    """Greedy evaluation: one row per training plant (`trained_on`), evaluation plant
    (`evaluated_on`), agent and episode."""
    configs: dict
    """`{plant: RunConfig}` of the training runs."""
    measure: tuple
    """`(column, label)` of the per-episode quantity compared (`measure`)."""
    replay: object
    """The first greedy episode of agent 0 trained on MuJoCo and run there (an
    `EpisodeRecording`), whose actions the Rerun recording replays on every plant."""


def closed_loop(task: str, agents: int, episodes: int | None = None, seed: int = 0,
                eval_episodes: int | None = None, progress=None,
                learner: str | None = None) -> ClosedLoop:
    """Train `agents` agents of `learner` (default: the paper's; seeds `seed`, `seed + 1`,
    ...) for `episodes` episodes (default: the paper's) on every plant, then run each trained
    batch greedily for `eval_episodes` episodes on every plant. `progress(episodes_done)` is
    called as episodes finish."""
    eval_episodes = eval_episodes_of(task) if eval_episodes is None else eval_episodes
    chosen = {} if learner is None else {"learner": learner}
    configs = {plant: plant_config(task, plant, agents=agents, episodes=episodes, seed=seed,
                                   **chosen)
               for plant in PLANTS}
    trained, tables = {}, []
    for plant, config in configs.items():
        trained[plant], results = run(config, progress=progress)
        tables.append(results_table(config, results).assign(compared=plant))
    rows, replay = [], None
    for trained_on, agent in trained.items():
        for evaluated_on in PLANTS:
            config = plant_config(task, evaluated_on, agents=agents, episodes=eval_episodes,
                                  seed=EVAL_SEED, **chosen)
            record = [(0, 0)] if trained_on == evaluated_on == "mujoco" else ()
            _, results = run(config, agents=agent, learn=False, greedy=True, progress=progress,
                             record=record)
            if record:
                replay = results.recordings[0]
            rows.append(pd.DataFrame(results.columns(config.seeds)).assign(
                trained_on=trained_on, evaluated_on=evaluated_on))
    return ClosedLoop(pd.concat(tables, ignore_index=True), pd.concat(rows, ignore_index=True),
                      configs, measure(task), replay)


def total_episodes(task: str, agents: int, episodes: int | None = None,
                   eval_episodes: int | None = None, learner: str | None = None) -> int:
    """The episodes `closed_loop` runs (for a progress bar)."""
    chosen = {} if learner is None else {"learner": learner}
    config = RunConfig(task=task, agents=agents, episodes=episodes, **chosen)
    eval_episodes = eval_episodes_of(task) if eval_episodes is None else eval_episodes
    return len(PLANTS) * agents * (config.episodes + len(PLANTS) * eval_episodes)


def per_agent_means(table: pd.DataFrame, keys, value: str, last: int | None = None) -> pd.DataFrame:
    """Each agent's mean `value` over its episodes (the `last` ones if given), per `keys`."""
    if last is not None:
        table = table[table["episode"] > table["episode"].max() - last]
    return table.groupby(list(keys) + ["agent"])[value].mean().reset_index()


def agent_statistics(per_agent: pd.DataFrame, keys, value: str) -> pd.DataFrame:
    """Mean and standard error over agents of `value`, per `keys`."""
    grouped = per_agent.groupby(list(keys))[value]
    return pd.DataFrame({"mean": grouped.mean(), "error": grouped.std(ddof=1) / np.sqrt(grouped.count()),
                         "agents": grouped.count()}).reset_index()


def parting_episodes(episodes: pd.DataFrame, first: str = "mujoco",
                     second: str = "semi_implicit") -> pd.Series:
    """Per seed, the first episode whose steps or return differ (relative 1e-9) between the
    agents trained on two plants; NaN where the histories agree throughout."""
    a, b = (episodes[episodes["compared"] == plant].set_index(["seed", "episode"]).sort_index()
            for plant in (first, second))
    same = (a["steps"] == b["steps"]) & np.isclose(a["return"], b["return"], rtol=1e-9, atol=1e-12)
    differing = same[~same].reset_index()
    return differing.groupby("seed")["episode"].min().reindex(sorted(a.index.unique("seed")))
