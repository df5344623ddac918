"""The second benchmark's protocol (docs/FINDINGS.md, "the second benchmark's rule"): per task
one budget of environment steps that every learner gets, the rows, and the runs that train
them.

Every row trains on the task's own episodes (the paper's: the cart-pole's of 240 s), as many
as its budget holds (`RunConfig.budget` cuts the episode that spends it). A greedy evaluation
at a fraction f of the budget (`FRACTIONS`) evaluates the agents of a run given f times the
budget: the budget cuts a run without changing what came before it (`tests/test_budget.py`),
so that run's agents are the full run's as they were after f of it.

The rows: the paper's agent (NRBF Sarsa(lambda) with the task's settings), its other trace,
true online Sarsa(lambda), the CMAC on Mountain-Car (Fig. 2) and ASE/ACE on the cart-pole
(Table 1) (`linear_rows`, the first benchmark's rows, docs/benchmark), and DQN and PPO, each
on its fastest implementation, the JAX populations `dqn_jax` and `ppo_jax` that
docs/implementations holds to Stable-Baselines3's, starting from rl-baselines3-zoo's sets
with their horizon the budget (so that DQN's exploration and the linear schedules run over
it). Every row is searched the same way (`search`).

On MuJoCo's model (`plant` "mujoco") the linear rows train on the C engine (the `mujoco`
plant) and the deep rows, the JAX populations, on the `mjx` plant: a population trains as one
JAX program (`runners.population`), inside which the C engine cannot be stepped, and MJX
steps the same model with the same step, agreeing with the C engine to round-off
(`lwrl.jax.mjx`, tests/test_jax_mjx.py). On the analytic plant every row trains on it.
"""

import dataclasses

from lwrl import tasks
from lwrl.agent.paper_settings import paper_settings
from lwrl.runners.config import RunConfig, tuned_settings

VERSION = "benchmark2-1"
"""The protocol's version, which an outside results file records (`outside`): a change to the
budgets, fractions, agents, evaluation episodes, cap or starts makes a new one."""
BUDGETS = {"mountain_car.cost_to_go": 100_000, "pendulum.swingup": 90_000,
           "cartpole.balance": 250_000, "acrobot.swingup": 100_000,
           "pendulum.swingup-continuous": 90_000}
"""Environment steps per agent, per task, for every learner (FINDINGS says why these; the
continuous pendulum's are the discrete one's)."""
FRACTIONS = (0.1, 0.25, 0.5, 1.0)
"""The fractions of the budget after which the agents are evaluated greedily."""
AGENTS = 20
"""Agents per row, on seeds 0 to AGENTS - 1 (none of the search's)."""
LEVEL = 0.5
"""The normalised score whose first reaching the compute to a level counts to."""
SHORTEST_EPISODE = 10
"""Steps: fewer on average than the shortest a policy falls in from the cart-pole's start,
or reaches a goal in from most of Mountain-Car's and the acrobot's starts."""
DEEP = {"dqn": "dqn_jax", "ppo": "ppo_jax"}
"""The deep rows and the implementation each runs on (the fastest, docs/guide/speed.md)."""
CONTINUOUS = "-continuous"
"""The suffix of a benchmark task made with continuous actions (`variant`)."""
LIGHT = {"discrete": "paper", "continuous": "actor_critic"}
"""The light-weight row a task's deep rows are judged against, by the kind of action: the
paper's agent, and on a continuous task the actor-critic over its features."""
ACTOR_CRITIC_START = {"alpha": 1.0, "beta": 0.5, "lam": 0.6, "gamma": 0.98, "sigma": 0.3,
                      "r2": 0.01}
"""The settings the actor-critic's row starts its search from: the learner's defaults before
that search, which then chose its defaults (`agent.actor_critic`), kept here so that the
search, its runs' keys and what it chose stay as they were."""
CONTINUOUS_DEEP = {"sac": "sac_jax", "td3": "td3_jax"}
"""The deep rows of a continuous task and the implementation each runs on."""
OTHER_TRACE = {"replacing": "accumulating", "accumulating": "replacing"}
"""The trace of the row beside the paper's agent, by the trace of the task's settings."""


@dataclasses.dataclass(frozen=True)
class Row:
    """One learner of a task's table: its label, the registry's learner and the settings the
    search starts from (its first configuration)."""

    label: str
    learner: str
    settings: dict


TASK_ROWS = {
    "mountain_car.cost_to_go": (Row("cmac", "sarsa", dict(
        features="cmac", trace="replacing_reset", lam=0.9, alpha=0.5, normalise_alpha=True)),),
    "cartpole.balance": (Row("ase_ace", "ase_ace", {}),),
}
"""The linear rows of one task beyond every task's: the CMAC on Mountain-Car (the paper's
Fig. 2 compares it with the NRBF there) and ASE/ACE on the cart-pole (Table 1's rival)."""


def linear_rows(name: str) -> list:
    """The linear rows of the suite's task `name`, the paper's agent first: NRBF
    Sarsa(lambda) with the task's settings (`lwrl train`'s defaults), the same with the other
    trace (`OTHER_TRACE`), true online Sarsa(lambda), then the task's own (`TASK_ROWS`)."""
    trace = OTHER_TRACE[paper_settings(name).trace]
    return [Row("paper", "sarsa", {}), Row("sarsa-" + trace, "sarsa", {"trace": trace}),
            Row("true_online_sarsa", "true_online_sarsa", {}),
            *(Row(row.label, row.learner, dict(row.settings)) for row in TASK_ROWS.get(name, ()))]


def check_task(task: str, plant: str = "analytic") -> str:
    """`task`, or a one-line ValueError naming the benchmark's tasks on `plant`."""
    if task not in tasks_on(plant):
        raise ValueError(f"unknown benchmark task {task!r} on the {plant} plant; allowed: "
                         f"{', '.join(tasks_on(plant))}")
    return task


def tasks_on(plant: str) -> list:
    """The benchmark's tasks whose domain has `plant` (Mountain-Car has no MuJoCo model)."""
    return [task for task in BUDGETS
            if plant in tasks.domain(variant(task)[0].split(".")[0]).plants.names]


def variant(task: str) -> tuple:
    """`(DOMAIN.TASK, kind of action)` of a benchmark task: `DOMAIN.TASK-continuous` is the
    suite's task made with continuous actions, any other the task with discrete ones."""
    if task.endswith(CONTINUOUS):
        return task[:-len(CONTINUOUS)], "continuous"
    return task, "discrete"


def light(task: str) -> str:
    """The label of the light-weight row of `task` (`LIGHT`)."""
    return LIGHT[variant(task)[1]]


def deep(task: str) -> dict:
    """`{label: learner}` of the deep rows of `task`, by its kind of action."""
    return CONTINUOUS_DEEP if variant(task)[1] == "continuous" else DEEP


def rows(task: str) -> list:
    """The task's rows, the light-weight one first: for a discrete task the linear rows
    (`linear_rows`), then DQN and PPO on their JAX populations with their horizon the
    budget; for a continuous one the actor-critic, then SAC and TD3 alike, every row
    made with continuous actions."""
    check_task(task)
    name, actions = variant(task)
    if actions == "continuous":
        kind = {"actions": actions}
        linear = [Row(LIGHT[actions], "actor_critic", dict(kind, **ACTOR_CRITIC_START))]
    else:
        kind = {}
        linear = linear_rows(name)
    deep_rows = [Row(label, learner, dict(tuned_settings(name, label), timesteps=BUDGETS[task],
                                          **kind))
                 for label, learner in deep(task).items()]
    return linear + deep_rows


def most_episodes(task: str) -> int:
    """The episodes a run may hold: its budget over `SHORTEST_EPISODE`, so that the budget,
    not the count, ends it (an agent whose episodes average fewer steps stops at the count;
    its steps taken are in its table)."""
    return -(-BUDGETS[check_task(task)] // SHORTEST_EPISODE)


def row_plant(task: str, row: Row, plant: str) -> str:
    """The plant `row` of `task` trains on in the benchmark on `plant`: `mjx` for a deep row
    on MuJoCo's model (see the module), else `plant`."""
    return "mjx" if plant == "mujoco" and row.label in deep(task) else plant


def training(task: str, row: Row, settings: dict, seed: int, agents: int,
             fraction: float = 1.0, plant: str = "analytic") -> RunConfig:
    """The run that trains `agents` agents of `row` with `settings` (seeds `seed`..) on the
    task's own episodes for `fraction` of its budget, on `row_plant`."""
    budget = round(fraction * BUDGETS[check_task(task)])
    return RunConfig(task=variant(task)[0], plant=row_plant(task, row, plant),
                     learner=row.learner, agents=agents, seed=seed,
                     episodes=most_episodes(task), budget=budget, **settings)
