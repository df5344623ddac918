"""`lwrl bench`'s protocol: one for every learner of the registry (Främling 2008's
light-weight claim, judged against DQN and PPO; docs/FINDINGS.md states the rule).

Per task: the paper's measure, the episodes every learner runs (the same seeds and starts
for all), and each learner's settings. The paper's agent is NRBF Sarsa(lambda) with the
task's settings (`lwrl train`'s defaults); its other trace, true online Sarsa(lambda), the
CMAC (Mountain-Car, Fig. 2) and ASE/ACE (the cart-pole, Table 1) stand beside it.

Every learner takes the settings tuned for it elsewhere (`runners.config.tuned_settings`):
DQN and PPO rl-baselines3-zoo's (`Learner.tuned`, `agent.stable_baselines.ZOO` says from
where and what does not carry over) for the environment each domain is tuned as
(`agent.zoo.TUNED_AS`: MountainCar-v0 for Mountain-Car, CartPole-v1 for the cart-pole,
Acrobot-v1 for the acrobot and, as the zoo's only discrete swing-up, for the pendulum).
"""

import dataclasses

from lwrl.runners.config import RunConfig, tuned_settings

@dataclasses.dataclass(frozen=True)
class Measure:
    """A task's measure from the paper: a column of the results, averaged over an agent's
    episodes, and which way is better."""

    column: str
    label: str
    higher_is_better: bool
    criterion: float
    """The level an agent's episode must reach (at most, for steps; at least, for up-time)
    for the wall time until the criterion."""
    source: str


@dataclasses.dataclass(frozen=True)
class BenchTask:
    """One task of the benchmark: its measure, episodes, options and the zoo's set."""

    task: str
    measure: Measure
    episodes: int
    task_options: dict = dataclasses.field(default_factory=dict)
    cut: str = ""
    """What the protocol cuts from the paper's, in one sentence (empty: nothing)."""
    extra: tuple = ()
    """Learners of the task beyond every task's: `(label, learner, settings)`."""


STEPS = Measure("steps", "mean steps per episode", False, 100.0, "Fig. 2 and 3")
UPTIME = Measure("uptime_s", "mean up-time per episode (s)", True, 40.0, "Fig. 5, 6 and 8")

TASKS = {
    "mountain_car.cost_to_go": BenchTask(
        "mountain_car.cost_to_go", STEPS, 20,
        cut="20 episodes, Fig. 2's protocol (the paper's agent converges in about 40, Fig. 3).",
        extra=(("cmac", "sarsa", dict(features="cmac", trace="replacing_reset", lam=0.9,
                                      alpha=0.5, normalise_alpha=True)),)),
    "pendulum.swingup": BenchTask(
        "pendulum.swingup", UPTIME, 30,
        cut="30 of Fig. 5's 200 episodes (the paper's agent is up about 40 s after about 10)."),
    "cartpole.balance": BenchTask(
        "cartpole.balance", UPTIME, 30, task_options={"time_limit": 60.0},
        cut="30 episodes of 60 s (3000 steps) instead of 200 of 240 s (12 000 steps): at "
            "the baselines' CPU per learning step (the table) the paper's protocol, up to "
            "2.4 million steps per agent, would take a DQN or PPO agent hours; up-times are "
            "capped at 60 s.",
        extra=(("ase_ace", "ase_ace", {}),)),
    "acrobot.swingup": BenchTask(
        "acrobot.swingup", STEPS, 20,
        cut="20 episodes (docs/acrobot runs 100 to 300)."),
}
"""The benchmark's tasks, in the order they run (the cheapest for the baselines first)."""


def episode_budgets() -> dict:
    """`{task: (episodes, task options)}`: every task's episodes and episode options, which
    the benchmark gives every learner (`lwrl robustness` trains DQN and PPO with them)."""
    return {name: (bench.episodes, dict(bench.task_options)) for name, bench in TASKS.items()}


def other_trace(task: str) -> str:
    from lwrl.runners.config import task_defaults
    return "accumulating" if task_defaults(task)["trace"] == "replacing" else "replacing"


def learners(task: str) -> list:
    """`(label, learner, settings)` of every learner on `task`, the paper's agent first."""
    bench = TASKS[task]
    return [("paper", "sarsa", {}), ("sarsa-" + other_trace(task), "sarsa", {"trace": other_trace(task)}),
            ("true_online_sarsa", "true_online_sarsa", {}), *bench.extra,
            *((name, name, tuned_settings(task, name)) for name in DEEP)]


DEEP = ("dqn", "ppo", "dqn_jax", "ppo_jax")
"""The deep learners: Stable-Baselines3's DQN and PPO and the same learners trained as JAX
populations (`agent.dqn_jax`, `agent.ppo_jax`), with the zoo's settings."""
LABELS = ("paper", "sarsa-accumulating", "sarsa-replacing", "true_online_sarsa", "cmac",
          "ase_ace", *DEEP)


def check_tasks(names) -> list:
    unknown = [name for name in names if name not in TASKS]
    if unknown:
        raise ValueError(f"unknown bench task {unknown[0]!r}; allowed: {', '.join(TASKS)}")
    return [name for name in TASKS if name in names]


def check_learners(labels, tasks) -> list:
    """The labels asked for (None: all), checked against the tasks' learners."""
    known = {label for task in tasks for label, _, _ in learners(task)}
    if labels is None:
        return sorted(known, key=LABELS.index)
    unknown = [label for label in labels if label not in known]
    if unknown:
        raise ValueError(f"unknown bench learner {unknown[0]!r}; allowed: {', '.join(sorted(known, key=LABELS.index))}")
    return list(labels)


def configs(tasks, labels, plant: str, agents: int, quick: bool = False) -> list:
    """`(task, label, RunConfig)` of every cell: `agents` agents (seeds 0 ..) per learner
    and task; `quick`: 2 episodes of at most 200 steps, a smoke test."""
    cells = []
    for task in tasks:
        bench = TASKS[task]
        options, episodes = dict(bench.task_options), bench.episodes
        if quick:
            from lwrl import tasks as suite
            definition = suite.definition(*suite.split_name(task))
            options["time_limit"] = min(200, definition.step_limit) * definition.control_timestep
            episodes = 2
        for label, learner, settings in learners(task):
            if label not in labels:
                continue
            settings = quick_settings(learner, settings) if quick else settings
            plant_of = plant if plant in suite_plants(task) else suite_plants(task)[0]
            cells.append((task, label, RunConfig(
                task=task, plant=plant_of, learner=learner, agents=agents, episodes=episodes,
                seed=0, task_options=options, **settings)))
    return cells


def quick_settings(learner: str, settings: dict) -> dict:
    """A learner's settings cut for a smoke test: DQN's and PPO's horizons, buffers and
    rollouts (both implementations') a few hundred steps (the others are cheap as they are)."""
    if learner in ("dqn", "dqn_jax"):
        return dict(settings, timesteps=min(settings.get("timesteps", 10**6), 400),
                    buffer_size=min(settings.get("buffer_size", 10**6), 1000))
    if learner in ("ppo", "ppo_jax"):
        return dict(settings, n_steps=64, batch_size=64, timesteps=400)
    return settings


def suite_plants(task: str) -> tuple:
    from lwrl import tasks as suite
    return tuple(suite.ENVIRONMENT_PLANTS[suite.split_name(task)[0]])
