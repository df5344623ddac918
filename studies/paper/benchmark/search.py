"""The second benchmark's search, the same for every row (docs/FINDINGS.md, "the second
benchmark's rule"): `CONFIGURATIONS` configurations of a row's settings, the first its own
(the task's defaults for lwrl's learners, rl-baselines3-zoo's set for the deep ones), the
others drawn at random from the ranges of `RANGES` around it, each trained by `AGENTS`
agents on `SEEDS` with the task's whole budget and scored by its final greedy normalised
score; the row then runs the best one on the benchmark's seeds, which the search never uses.

The ranges follow what each learner's authors and tuners vary: for the linear learners the
step size alpha (log-uniform over a factor of 4 either side of the task's), lambda, epsilon,
the NRBF grid (the task's n and one either side) and the RBFs' width r^2; for ASE/ACE its
step sizes, trace decays and exploration noise (Barto, Sutton and Anderson 1983); for the
continuous actor-critic the critic's and the actor's step sizes, lambda, gamma, the
exploration's sigma (van Hasselt and Wiering 2007 vary these), the grid and the width; for
the deep learners the width, the learning rate, the exploration schedule, the warm-up, the
training frequency or rollout length, the epochs and batch, as rl-baselines3-zoo's
hyperparameter search samples them (`rl_zoo3/hyperparams_opt.py`: `sample_dqn_params`,
`sample_ppo_params`, `sample_sac_params`, `sample_td3_params`, narrowed to what a CPU can
train in the budget: no network beyond 256 x 256). Observation normalisation, which the zoo turns on for PPO on
Mountain-Car and the acrobot, is not searched: neither implementation of lwrl's takes it
(SB3's `VecNormalize` is a wrapper of Gymnasium environments, not a learner setting).

The draws are a fixed random stream per task and row (`SEED`), so the search is the same
on every machine and its runs resume.
"""

import dataclasses
import math

import numpy as np

from lwrl.runners.config import learner_settings, task_defaults
from lwrl.studies.paper.benchmark import protocol

CONFIGURATIONS = 16
AGENTS = 3
SEEDS = (1000, 1001, 1002)
"""The search's agents' seeds: none of the benchmark's rows' (0 to 19)."""
SEED = 20261203
"""The configurations' draws: a stream per task and row, `SEED` then their positions."""


@dataclasses.dataclass(frozen=True)
class LogUniform:
    """A number drawn log-uniformly in [low, high] (`around`: factors of the start's value)."""

    name: str
    low: float
    high: float
    around: bool = False

    def draw(self, rng, start: dict):
        scale = start[self.name] if self.around else 1.0
        return float(scale * math.exp(rng.uniform(math.log(self.low), math.log(self.high))))


@dataclasses.dataclass(frozen=True)
class Uniform:
    """A number drawn uniformly in [low, high]."""

    name: str
    low: float
    high: float

    def draw(self, rng, start: dict):
        return float(rng.uniform(self.low, self.high))


@dataclasses.dataclass(frozen=True)
class Choice:
    """One of `values` (`around`: the start's value plus each of them)."""

    name: str
    values: tuple
    around: bool = False

    def draw(self, rng, start: dict):
        value = self.values[int(rng.integers(len(self.values)))]
        return start[self.name] + value if self.around else value


NRBF = (LogUniform("alpha", 0.25, 4.0, around=True), Uniform("lam", 0.0, 0.95),
        Choice("epsilon", (0.0, 0.01, 0.05, 0.1)), Choice("n", (-1, 0, 1), around=True),
        LogUniform("r2", 0.0025, 0.04))
CMAC = (LogUniform("alpha", 0.25, 4.0, around=True), Uniform("lam", 0.0, 0.95),
        Choice("epsilon", (0.0, 0.01, 0.05, 0.1)), Choice("n", (-1, 0, 1), around=True),
        Choice("tilings", (4, 5, 8, 10)))
OFF_POLICY_CONTINUOUS = (Choice("net_arch", ("64,64", "128,128", "256,256")),
                         LogUniform("learning_rate", 1e-4, 3e-3),
                         Choice("batch_size", (64, 128, 256)),
                         Choice("learning_starts", (100, 1000, 10_000)),
                         Choice("train_freq", (1, 4, 16)), Choice("tau", (0.005, 0.01, 0.02)),
                         Choice("gamma", (0.98, 0.99, 0.999)))
ACTOR_CRITIC = (LogUniform("alpha", 0.25, 4.0, around=True), LogUniform("beta", 0.05, 1.0),
                Uniform("lam", 0.0, 0.95), LogUniform("sigma", 0.05, 1.0),
                Choice("gamma", (0.95, 0.98, 0.99)), Choice("n", (-1, 0, 1), around=True),
                LogUniform("r2", 0.0025, 0.04))
RANGES = {
    "sarsa": NRBF,
    "true_online_sarsa": NRBF,
    "ase_ace": (LogUniform("alpha", 100.0, 10_000.0), LogUniform("beta", 0.05, 1.0),
                Uniform("delta", 0.5, 0.95), Uniform("lam", 0.5, 0.95),
                LogUniform("sigma", 0.001, 0.1)),
    "dqn_jax": (Choice("net_arch", ("64,64", "128,128", "256,256")),
                LogUniform("learning_rate", 1e-4, 1e-2), Uniform("exploration_fraction", 0.05, 0.5),
                LogUniform("exploration_final_eps", 0.01, 0.2),
                Choice("learning_starts", (0, 1000, 5000)), Choice("train_freq", (1, 4, 16)),
                Choice("gradient_steps", (1, -1)), Choice("batch_size", (32, 64, 128)),
                Choice("target_update_interval", (100, 500, 1000, 5000)),
                Choice("gamma", (0.98, 0.99, 0.999))),
    "ppo_jax": (Choice("net_arch", ("64,64", "128,128", "256,256")),
                LogUniform("learning_rate", 1e-4, 3e-3), Choice("n_steps", (256, 512, 1024, 2048)),
                Choice("n_epochs", (4, 10, 20)), Choice("batch_size", (32, 64, 128, 256)),
                Uniform("gae_lambda", 0.8, 0.99), Choice("ent_coef", (0.0, 0.001, 0.01)),
                Choice("clip_range", (0.1, 0.2, 0.3)), Choice("gamma", (0.98, 0.99, 0.999))),
    "actor_critic": ACTOR_CRITIC,
    "sac_jax": OFF_POLICY_CONTINUOUS,
    "td3_jax": OFF_POLICY_CONTINUOUS + (Choice("noise_std", (0.1, 0.2, 0.3)),),
}
"""What is drawn, per learner; the row's other settings stay its own."""


def ranges(row: protocol.Row) -> tuple:
    """The ranges of `row`'s learner (a CMAC row's are the CMAC's)."""
    if row.settings.get("features") == "cmac":
        return CMAC
    return RANGES[row.learner]


def start(task: str, row: protocol.Row) -> dict:
    """The values the row starts from, for the ranges drawn around them: its settings over
    the task's defaults and its learner's."""
    learner = dataclasses.asdict(learner_settings(row.learner, None))
    defaults = {k: v for k, v in task_defaults(protocol.variant(task)[0]).items()
                if k in learner and learner[k] is None}
    return {**learner, **defaults, **row.settings}


def configurations(task: str, row: protocol.Row) -> list:
    """The row's `CONFIGURATIONS` settings: its own, then the draws (`RANGES`)."""
    rng = np.random.default_rng([SEED, list(protocol.BUDGETS).index(task),
                                 [r.label for r in protocol.rows(task)].index(row.label)])
    base = start(task, row)
    drawn = [dict(row.settings, **{item.name: item.draw(rng, base) for item in ranges(row)})
             for _ in range(CONFIGURATIONS - 1)]
    return [dict(row.settings)] + drawn


def runs(task: str, plant: str = "analytic") -> dict:
    """`{(label, i): RunConfig}`: every configuration of every row of `task`, trained by
    `AGENTS` agents on `SEEDS` with the whole budget."""
    return {(row.label, i): protocol.training(task, row, settings, SEEDS[0], AGENTS, plant=plant)
            for row in protocol.rows(task)
            for i, settings in enumerate(configurations(task, row))}
