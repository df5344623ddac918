"""`lwrl bench`'s protocol: one for every learner of the registry (Främling 2008's
light-weight claim, judged against DQN and PPO; docs/FINDINGS.md states the rule).

Per task: the paper's measure, the episodes every learner runs (the same seeds and starts
for all), and each learner's settings. The paper's agent is NRBF Sarsa(lambda) with the
task's settings (`lwrl train`'s defaults); its other trace, true online Sarsa(lambda), the
CMAC (Mountain-Car, Fig. 2) and ASE/ACE (the cart-pole, Table 1) stand beside it.

DQN and PPO take rl-baselines3-zoo's tuned sets (`hyperparams/dqn.yml`, `hyperparams/ppo.yml`
of DLR-RM/rl-baselines3-zoo at commit 22e3ff2450fd92033f7f032915e1f64894a09584): MountainCar-v0
for Mountain-Car, CartPole-v1 for the cart-pole, Acrobot-v1 for the acrobot and, as the
zoo's only discrete swing-up, for the pendulum (its Pendulum-v1 sets are for continuous
torque). The zoo's `n_timesteps` is each learner's horizon (`timesteps`: the schedules',
the exploration's); PPO's `n_envs` parallel environments become one environment with a
rollout of `n_envs x n_steps` transitions; the zoo's `normalize: true` (VecNormalize, for
PPO on MountainCar and Acrobot) has no counterpart here and is left out.
"""

import dataclasses

from lwrl.runners.config import RunConfig

ZOO = "DLR-RM/rl-baselines3-zoo, hyperparams/{dqn,ppo}.yml at commit 22e3ff2450fd92033f7f032915e1f64894a09584"

DQN_ZOO = {
    "MountainCar-v0": dict(timesteps=120_000, learning_rate=4e-3, batch_size=128, buffer_size=10_000,
                           learning_starts=1000, gamma=0.98, target_update_interval=600,
                           train_freq=16, gradient_steps=8, exploration_fraction=0.2,
                           exploration_final_eps=0.07, net_arch="256,256"),
    "CartPole-v1": dict(timesteps=50_000, learning_rate=2.3e-3, batch_size=64, buffer_size=100_000,
                        learning_starts=1000, gamma=0.99, target_update_interval=10,
                        train_freq=256, gradient_steps=128, exploration_fraction=0.16,
                        exploration_final_eps=0.04, net_arch="256,256"),
    "Acrobot-v1": dict(timesteps=100_000, learning_rate=6.3e-4, batch_size=128, buffer_size=50_000,
                       learning_starts=0, gamma=0.99, target_update_interval=250, train_freq=4,
                       gradient_steps=-1, exploration_fraction=0.12, exploration_final_eps=0.1,
                       net_arch="256,256"),
}
"""rl-baselines3-zoo's DQN sets (policy MlpPolicy)."""

PPO_ZOO = {
    "MountainCar-v0": dict(timesteps=1_000_000, n_steps=16 * 16, gae_lambda=0.98, gamma=0.99,
                           n_epochs=4, ent_coef=0.0),
    "CartPole-v1": dict(timesteps=100_000, n_steps=8 * 32, batch_size=256, gae_lambda=0.8,
                        gamma=0.98, n_epochs=20, ent_coef=0.0, learning_rate=1e-3,
                        learning_rate_schedule="linear", clip_range=0.2,
                        clip_range_schedule="linear"),
    "Acrobot-v1": dict(timesteps=1_000_000, n_steps=16 * 256, gae_lambda=0.94, gamma=0.99,
                       n_epochs=4, ent_coef=0.0),
}
"""rl-baselines3-zoo's PPO sets (policy MlpPolicy; n_steps = n_envs x n_steps)."""


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
    zoo: str
    task_options: dict = dataclasses.field(default_factory=dict)
    cut: str = ""
    """What the protocol cuts from the paper's, in one sentence (empty: nothing)."""
    extra: tuple = ()
    """Learners of the task beyond every task's: `(label, learner, settings)`."""


STEPS = Measure("steps", "mean steps per episode", False, 100.0, "Fig. 2 and 3")
UPTIME = Measure("uptime_s", "mean up-time per episode (s)", True, 40.0, "Fig. 5, 6 and 8")

TASKS = {
    "mountain_car.cost_to_go": BenchTask(
        "mountain_car.cost_to_go", STEPS, 20, "MountainCar-v0",
        cut="20 episodes, Fig. 2's protocol (the paper's agent converges in about 40, Fig. 3).",
        extra=(("cmac", "sarsa", dict(features="cmac", trace="replacing_reset", lam=0.9,
                                      alpha=0.5, normalise_alpha=True)),)),
    "pendulum.swingup": BenchTask(
        "pendulum.swingup", UPTIME, 30, "Acrobot-v1",
        cut="30 of Fig. 5's 200 episodes (the paper's agent is up about 40 s after about 10)."),
    "cartpole.balance": BenchTask(
        "cartpole.balance", UPTIME, 30, "CartPole-v1", task_options={"time_limit": 60.0},
        cut="30 episodes of 60 s (3000 steps) instead of 200 of 240 s (12 000 steps): at "
            "the baselines' CPU per learning step (the table) the paper's protocol, up to "
            "2.4 million steps per agent, would take a DQN or PPO agent hours; up-times are "
            "capped at 60 s.",
        extra=(("ase_ace", "ase_ace", {}),)),
    "acrobot.swingup": BenchTask(
        "acrobot.swingup", STEPS, 20, "Acrobot-v1",
        cut="20 episodes (docs/acrobot runs 100 to 300)."),
}
"""The benchmark's tasks, in the order they run (the cheapest for the baselines first)."""


def other_trace(task: str) -> str:
    from lwrl.runners.config import task_defaults
    return "accumulating" if task_defaults(task)["trace"] == "replacing" else "replacing"


def learners(task: str) -> list:
    """`(label, learner, settings)` of every learner on `task`, the paper's agent first."""
    bench = TASKS[task]
    return [("paper", "sarsa", {}), ("sarsa-" + other_trace(task), "sarsa", {"trace": other_trace(task)}),
            ("true_online_sarsa", "true_online_sarsa", {}), *bench.extra,
            ("dqn", "dqn", DQN_ZOO[bench.zoo]), ("ppo", "ppo", PPO_ZOO[bench.zoo])]


LABELS = ("paper", "sarsa-accumulating", "sarsa-replacing", "true_online_sarsa", "cmac",
          "ase_ace", "dqn", "ppo")


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
            if quick and learner in ("dqn", "ppo"):
                settings = dict(settings, timesteps=min(settings.get("timesteps", 10**6), 400),
                                buffer_size=min(settings.get("buffer_size", 10**6), 1000)) \
                    if learner == "dqn" else dict(settings, n_steps=64, batch_size=64, timesteps=400)
            plant_of = plant if plant in suite_plants(task) else suite_plants(task)[0]
            cells.append((task, label, RunConfig(
                task=task, plant=plant_of, learner=learner, agents=agents, episodes=episodes,
                seed=0, task_options=options, **settings)))
    return cells


def suite_plants(task: str) -> tuple:
    from lwrl import tasks as suite
    return tuple(suite.ENVIRONMENT_PLANTS[suite.split_name(task)[0]])
