"""The benchmark's greedy evaluation (docs/FINDINGS.md, "The light-weight claim judged again:
the second benchmark's rule", "Greedy evaluation, apart from training"): each agent runs
`EPISODES` episodes without exploring or learning, from starts of its own (its seed +
`EVALUATION_SEED`), without a budget, on the task's own episodes (the pendulum's 60 s, the
cart-pole's 240 s) but for the tasks measured in steps (Mountain-Car, the acrobot), capped
at `STEP_CAP` steps, so that an episode that does not reach the goal counts `STEP_CAP`. Its measure is the paper's, averaged over those episodes
(`task_measure`, `measure`). The two reference rows (`references`) run on the same starts
(`run_references`).

The robustness study evaluates its trained agents alike in its nominal cell
(studies/robustness/plan.py `evaluation`, the same 10 000 added to the seeds); one study
does not import another (tests/test_architecture.py), so the replacement is written here.
"""

import dataclasses
import hashlib

import numpy as np
import pandas as pd

from lwrl import tasks
from lwrl.runners.config import RunConfig
from lwrl.runners.stepped import run_batched
from lwrl.studies.paper.benchmark import protocol
from lwrl.studies.paper.benchmark.protocol import variant
from lwrl.studies.paper.benchmark.references import ROWS
from lwrl.tasks.batched import BatchedEnv
from lwrl.tasks.task_definition import TaskDefinition

EVALUATION_SEED = 10_000
"""Added to an agent's seed for its evaluation episodes' starts (and sensor streams)."""
EPISODES = 10
"""Greedy episodes per agent and evaluation."""
STEP_CAP = 1000
"""The most steps of an evaluation episode of a task measured in steps; one that does not
reach the goal counts this."""


@dataclasses.dataclass(frozen=True)
class Measure:
    """A task's measure from the paper: a column of the results, averaged over an agent's
    episodes, and which way is better."""

    column: str
    label: str
    higher_is_better: bool


STEPS = Measure("steps", "mean steps per episode", False)
"""Mountain-Car's and the acrobot's measure: steps per episode (the paper's Fig. 2 and 3)."""
UPTIME = Measure("uptime_s", "mean up-time per episode (s)", True)
"""The pendulum's and the cart-pole's: seconds up per episode (Fig. 5, 6 and 8)."""


def task_definition(task: str) -> TaskDefinition:
    """The definition of `task` (DOMAIN.TASK, or a benchmark task's `DOMAIN.TASK-continuous`,
    `protocol.variant`) at its defaults, or a one-line ValueError naming the suite's tasks
    (`tasks.split_name`, `tasks.domain`, `tasks.task_options`)."""
    name, actions = variant(task)
    return tasks.definition(*tasks.split_name(name), actions=actions)


def task_measure(task: str) -> Measure:
    """The up-time where the task keeps one (the pendulum, the cart-pole), else the steps
    per episode (Mountain-Car, the acrobot)."""
    return UPTIME if task_definition(task).has_uptime else STEPS


def episode_options(task: str) -> dict:
    """The task options of an evaluation episode: a `time_limit` of `STEP_CAP` steps, in the
    task's unit of time, for a task measured in steps; none (the task's own episodes) for
    the others."""
    if task_measure(task) != STEPS:
        return {}
    return {"time_limit": STEP_CAP * task_definition(task).control_timestep}


def step_cap(task: str) -> int:
    """The most steps of an evaluation episode of `task`: `STEP_CAP` on a task measured in
    steps, else its own episode's (`episode_options`)."""
    if task_measure(task) == STEPS:
        return STEP_CAP
    return int(task_definition(task).step_limit)


def episode_seconds(task: str) -> float:
    """The length in seconds of an evaluation episode of `task` that runs to its end: the
    most up-time an episode can count."""
    return step_cap(task) * task_definition(task).control_timestep


def starts(task: str, plant: str = "analytic") -> np.ndarray:
    """`(protocol.AGENTS, EPISODES, d)`: the first observation of each evaluation episode of
    each agent of seeds 0 up (`evaluation_env`'s, from the environments' own start streams,
    which nothing but a new episode draws from)."""
    env = evaluation_env(task, protocol.AGENTS, plant)
    return np.stack([env.reset().observation for _ in range(EPISODES)], axis=1)


def starts_digest(observations) -> str:
    """A digest of evaluation starts `(agents, episodes, d)` (`starts`): SHA-256 of their
    values rounded to 9 decimals, as float64, its first 16 hexadecimal digits."""
    rounded = np.round(np.asarray(observations, dtype=np.float64), 9) + 0.0  # no -0.0
    return hashlib.sha256(np.ascontiguousarray(rounded, dtype="<f8").tobytes()).hexdigest()[:16]


def protocol_digest(task: str, plant: str = "analytic") -> str:
    """The digest of the protocol's evaluation starts of `task` on `plant` (`starts`,
    `starts_digest`)."""
    return starts_digest(starts(task, plant))


def evaluation(trained: RunConfig) -> RunConfig:
    """The greedy evaluation of the agents of the run `trained` as they ended it
    (`RunConfig.trained`, `Agents.take_over`), on its plant and environment: no learning,
    greedy actions, `EPISODES` episodes, each agent's seed + `EVALUATION_SEED`, the
    evaluation's episodes (`episode_options`, whatever the training's) and no budget."""
    return dataclasses.replace(
        trained, trained=trained.key, learn=False, greedy=True, episodes=EPISODES,
        seed=trained.seed + EVALUATION_SEED, task_options=episode_options(trained.task),
        budget=None)


def evaluation_env(task: str, agents: int, plant: str, seed: int = 0,
                   environment=None, options=None) -> BatchedEnv:
    """The environments of the evaluation of `agents` agents of seeds `seed` up
    (`evaluation`'s seeds, starts and episodes) of `task` on `plant`, made with its kind of
    action (`protocol.variant`) and the environment options `environment` (`BatchedEnv`'s:
    `randomise`, `observation_noise`, `action_delay`; none by default); `options`: task
    options beside the evaluation's (`episode_options`)."""
    name, actions = variant(task)
    domain, task_name = tasks.split_name(name)
    return BatchedEnv(domain, task_name, plant,
                      [EVALUATION_SEED + seed + b for b in range(agents)], actions=actions,
                      **episode_options(task), **(options or {}), **(environment or {}))


def run_references(task: str, agents: int = 20, plant: str = "analytic",
                   episodes: int = EPISODES, environment=None, seed: int = 0,
                   options=None) -> dict:
    """`{row: per-episode results}` of the reference rows (`references.ROWS`) on `task`:
    `agents` agents each, on the starts of the evaluation of agents of seeds `seed` up
    (`evaluation_env`, with the environment options `environment` and the task options
    `options`), `episodes` episodes each; the results as a table of
    `EpisodeResults.columns` (`seed` the environment's)."""
    tables = {}
    for row, make in ROWS.items():
        env = evaluation_env(task, agents, plant, seed, environment, options)
        results = run_batched(env, make(env), episodes, learn=False, greedy=True)
        tables[row] = pd.DataFrame(results.columns(env.seeds))
    return tables


def evaluate_references(task: str, agents: int = 20, plant: str = "analytic") -> dict:
    """`{row: (agents,) measures}` of the reference rows on `task` (`run_references`,
    `EPISODES` episodes, `measure`)."""
    return {row: measure(table, task)
            for row, table in run_references(task, agents, plant).items()}


def measure(results: pd.DataFrame, task: str, diverged_as_worst: bool = False) -> np.ndarray:
    """One number per agent, in seed order: the mean over its episodes of `task`'s measure
    (`task_measure`) in `results`, one run's per-episode table with a `seed` column and the
    measure's (`EpisodeResults.columns`, `runners.sweep.results_table`). An agent whose
    learning diverged in training acts no more, and its episodes have no measure: NaN, or
    with `diverged_as_worst` the worst outcome of an episode (`worst`)."""
    column = task_measure(task).column
    values = results.groupby("seed", sort=True)[column].mean().to_numpy()
    return np.where(np.isnan(values), worst(task), values) if diverged_as_worst else values


def worst(task: str) -> float:
    """The worst measure of an evaluation episode of `task`: 0 s up, or `STEP_CAP` steps
    (the goal not reached)."""
    return 0.0 if task_measure(task).higher_is_better else float(STEP_CAP)
