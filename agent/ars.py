"""Augmented Random Search, ARS V1-t and V2-t (Mania, Guy & Recht 2018, arXiv:1803.07055,
Algorithm 1; the equations in `agent.random_search`), over a linear policy of the
observation, trained as a population in one jitted JAX program (`runners.population`,
`agent.jax_population`).

Each iteration j of an agent draws N directions delta_k (`directions`) and runs the policy
theta_j + nu delta_k, then theta_j - nu delta_k, for one episode each, in its own task one
after another (2N episodes; every one of their steps counts against the run's budget, as
any learner's steps do). After the 2N-th episode the b best directions by max(r_plus,
r_minus) (`top`) move the policy: theta_j+1 = theta_j + alpha / (b sigma_R) sum (r_plus -
r_minus) delta_k (`random_search.ars_step`). A discrete action is the argmax of the linear
scores theta x (one row per action), a continuous one theta x clipped to [-1, 1]. V2
(`variant`) reads the state as (x - mu) / sigma, mu and sigma those of every state acted on
in learning so far, as they were when the iteration began (V1: the state itself). The
policy starts at 0 (sb3-contrib's `zero_policy`). A greedy decision is theta_j's.

The directions of an iteration are drawn from its key and the direction's index
(`random_search.direction`), so that an episode draws its own and the update draws them all
again, the same numbers, rather than keeping N of them. The agents and the directions of the
update are vectorised (`vmap`); the rollouts of one agent are its episodes in turn, as the
run's protocol gives each agent one task and records its episodes in order.

Defaults: sb3-contrib's ARS (N 8, b = N, alpha 0.02, nu 0.05) with the paper's V2;
rl-baselines3-zoo's set for CartPole-v1 (`ZOO_SETS`).
"""

import dataclasses

import numpy as np

from lwrl.agent.arithmetic import Count, Counts
from lwrl.agent.jax_population import PopulationAgents, Program, jax_unavailable, masked
from lwrl.agent.learner_contract import Learner, LearnerSettings
from lwrl.settings import check_count, check_non_negative, check_positive, setting

ZOO = "DLR-RM/rl-baselines3-zoo, hyperparams/ars.yml at commit 22e3ff2450fd92033f7f032915e1f64894a09584"
"""Where the zoo's sets (`ZOO_SETS`) come from."""
ZOO_SETS = {"CartPole-v1": dict(timesteps=50_000, directions=2, variant="v1")}
"""The zoo's tuned sets whose policy is linear (`LinearPolicy`), translated: `n_timesteps`
the horizon, `n_delta` the directions, `n_top` (None: all) the top directions, sb3-contrib's
`learning_rate` and `delta_std` where the set leaves them (0.02, 0.05); no `normalize`: V1.
Its sets for MountainCar-v0, Acrobot-v1 and Pendulum-v1 train an MLP of 16 units
(`MlpPolicy`, `net_arch=[16]`), not a linear policy, and are left out."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class ArsSettings(LearnerSettings):
    """ARS's settings: sb3-contrib's defaults, the paper's V2."""

    timesteps: int = setting(1_000_000, per_agent=True)
    """Environment steps of learning, the rollouts' steps among them (rl-baselines3-zoo's
    `n_timesteps`); the agent then acts greedily."""
    directions: int = setting(8)
    """Directions N drawn per iteration (sb3-contrib's `n_delta`): 2N episodes each."""
    top: int | None = setting(None)
    """Top directions b used in the step (`n_top`), at most N; None: all N."""
    learning_rate: float = setting(0.02, per_agent=True)
    """Step size alpha."""
    delta_std: float = setting(0.05, per_agent=True)
    """Exploration noise nu: the rollouts' policies are theta +- nu delta."""
    variant: str = setting("v2", choices=("v1", "v2"))
    """`v1`: the policy reads the state; `v2`: the state normalised by the running mean and
    standard deviation of the states seen in learning."""

    @property
    def top_directions(self) -> int:
        """b, the directions an update keeps: `top`, or every direction where it is None."""
        return self.directions if self.top is None else self.top

    def check(self, task) -> None:
        check_count("timesteps", self.timesteps, 1)
        check_count("directions", self.directions, 1)
        if self.top is not None:
            check_count("top", self.top, 1)
            if self.top > self.directions:
                raise ValueError(f"top must be at most directions ({self.directions}): the "
                                 f"step uses the best b of the N directions; got {self.top}")
        check_positive("learning_rate", self.learning_rate)
        check_non_negative("delta_std", self.delta_std)

    def label(self) -> str:
        return (f"ars-{self.variant}-n{self.directions}-b{self.top_directions}"
                f"-lr{self.learning_rate:g}-nu{self.delta_std:g}-t{self.timesteps}")

    def describe(self, dim: int) -> str:
        return (f"ARS {self.variant.upper()}-t, linear policy of {dim} state variables, "
                f"{self.directions} directions, top {self.top_directions}, step "
                f"{self.learning_rate:g}, noise {self.delta_std:g}, {self.timesteps} steps")


HYPER = ("timesteps", "learning_rate", "delta_std")
"""The per-agent settings the program takes as arrays."""


class ArsAgents(PopulationAgents):
    """B ARS agents as one pytree (see the module)."""

    def outputs(self) -> int:
        """Rows of theta: one score per action, or the one continuous action."""
        return 1 if self.task.continuous else self.task.action.n

    def initial_state(self, key):
        jnp = self.jnp
        from lwrl.agent import running_stats
        settings = self.settings[0]
        zeros = jnp.zeros(self.dim, jnp.float64)
        return {"theta": jnp.zeros((self.outputs(), self.dim), jnp.float64),
                "mean": zeros, "std": jnp.ones(self.dim, jnp.float64),
                "states": running_stats.stats_start(self.dim), "key": key,
                "rollout": jnp.zeros((), jnp.int32), "episode_return": jnp.zeros(()),
                "returns": jnp.zeros(2 * settings.directions, jnp.float64)}

    @staticmethod
    def weight_tree(state):
        return {"theta": state["theta"], "mean": state["mean"], "std": state["std"]}

    def reads(self, tree, x):
        """States `(..., d)` as the policy `tree` reads them (V2: normalised)."""
        from lwrl.agent import random_search
        if self.settings[0].variant == "v1":
            return x
        return random_search.v2_state(x, tree["mean"], tree["std"])

    def policy(self, theta, x):
        """The action of the linear policy `theta` at read states `x`."""
        from lwrl.agent import random_search
        if self.continuous:
            return random_search.continuous_action(theta, x).astype(self.jnp.float32)
        return random_search.discrete_action(theta, x)

    def program(self) -> Program:
        jax, jnp = self.jax, self.jnp
        from lwrl.agent import random_search, running_stats
        settings = self.settings[0]
        rollouts, top = 2 * settings.directions, settings.top_directions
        v2 = settings.variant == "v2"
        hyper = {name: np.array([getattr(s, name) for s in self.settings]) for name in HYPER}
        hyper["learning_steps"] = hyper["timesteps"]
        shape = (self.outputs(), self.dim)

        def act(state, observation, key, hyper, greedy, clock):
            del key, clock
            k = jnp.minimum(state["rollout"], rollouts - 1)
            delta = random_search.direction(jax.random.fold_in(state["key"], k // 2), shape)
            sign = jnp.where(k % 2 == 0, 1.0, -1.0)
            theta = jnp.where(greedy, state["theta"], random_search.perturbed(
                state["theta"], delta, hyper["delta_std"], sign))
            return self.policy(theta, self.reads(state, observation)), {}

        def record(state, extras, observation, action, reward, terminated, truncated,
                   final_observation, hyper, clock, write):
            ended = terminated | truncated
            total = state["episode_return"] + reward
            k = state["rollout"]
            returns = state["returns"].at[k].set(jnp.where(ended, total, state["returns"][k]))
            return masked(write, state, returns=returns, rollout=k + ended.astype(jnp.int32),
                          episode_return=jnp.where(ended, 0.0, total),
                          states=running_stats.stats_add(state["states"], observation))

        def update(state, next_observation, next_start, hyper, clock, due):
            del next_observation, next_start, clock
            deltas = jax.vmap(lambda i: random_search.direction(
                jax.random.fold_in(state["key"], i), shape))(jnp.arange(settings.directions))
            theta = random_search.ars_step(state["theta"], deltas, state["returns"][0::2],
                                           state["returns"][1::2], hyper["learning_rate"], top)
            mean, std = random_search.v2_scale(state["states"]) if v2 else (state["mean"], state["std"])
            key = jax.random.split(state["key"])[0]
            return masked(due & (state["rollout"] == rollouts), state, theta=theta, mean=mean,
                          std=std, key=key, rollout=jnp.zeros((), jnp.int32),
                          returns=jnp.zeros_like(state["returns"]))

        return Program(act=act, record=record, update=update,
                       update_due=lambda hyper, clock: clock >= 0, hyper=hyper)

    def learner_form(self, b: int):
        """Agent b as C that goes on learning on a device (`agent.ars_c`)."""
        from lwrl.agent import ars_c
        return ars_c.learner_form(self, b)

    def action_values(self, states, weights=None):
        """The linear scores theta x of the discrete actions, `(B, ..., A)` (`(..., A)` for
        `weights`), which the agents act greedily on; `NoValues` with continuous actions."""
        from lwrl.agent import random_search
        if self.continuous:
            return super().action_values(states, weights)
        return self.over_agents(states, weights, lambda tree, x: random_search.scores(
            tree["theta"], self.reads(tree, x)))

    def greedy_actions(self, states, weights=None):
        """The clipped linear action of continuous actions, `(B, ...)` (`(...)` for
        `weights`); `NoValues` with discrete actions."""
        from lwrl.agent import random_search
        if not self.continuous:
            return super().greedy_actions(states, weights)
        return self.over_agents(states, weights, lambda tree, x: random_search.continuous_action(
            tree["theta"], self.reads(tree, x)))


def make(settings, task, seeds) -> ArsAgents:
    """B ARS agents trained as one JAX program, agent b with `settings[b]` and its random
    stream from `seeds[b]`."""
    return ArsAgents(settings, task, seeds)


def load(document, arrays) -> ArsAgents:
    """The agents `ArsAgents.saved` wrote (a ValueError if the parts do not fit)."""
    return ArsAgents.loaded(document, arrays, ArsSettings)


def memory(settings, task) -> int:
    """Bytes of one agent (float64): its policy, V2's scale and statistics, the returns of
    an iteration's rollouts."""
    dim = len(task.state_names)
    return 8 * ((1 if task.continuous else task.action.n) * dim + 5 * dim + 2 * settings.directions + 8)


def arithmetic(settings, task, steps=None) -> Counts:
    """Its counted arithmetic (`Learner.arithmetic`): a greedy decision is p d multiply-adds
    (p = A scores, or the one continuous action), V2's normalisation d more; an agent-step of
    learning adds the perturbed policy theta + nu delta (p d) and the state into V2's
    statistics (2 d), and its share of the iteration's update (N p d for the sum, 4 b for
    sigma_R, 2 d and d square roots for V2's scale, counted with the exponentials) counted as
    if each of its 2N episodes took one step: an upper bound, as an episode's length is not
    known from the shapes (the normal draws are not counted)."""
    del steps
    dim = len(task.state_names)
    outputs, read = (1 if task.continuous else task.action.n), (dim if settings.variant == "v2" else 0)
    decision = Count(outputs * dim + read)
    iteration = Count(settings.directions * outputs * dim + 4 * settings.top_directions
                      + 2 * dim, dim)
    update = Count(outputs * dim + 2 * dim) + iteration * (1 / (2 * settings.directions))
    return Counts(decision, decision + update, update,
                  f"linear policy {outputs} x {dim}, {settings.variant.upper()}, "
                  f"{settings.directions} directions ({__name__}.arithmetic)")


LEARNER = Learner(
    name="ars", title="Augmented Random Search (V1-t, V2-t) over a linear policy, in JAX",
    source="Mania, Guy & Recht (2018), arXiv:1803.07055, Algorithm 1; modestyachts/ARS; "
           "sb3-contrib's ARS",
    settings=ArsSettings, make=make, load=load, memory=memory,
    unavailable=jax_unavailable("ars"),
    tuned=ZOO_SETS, population=True, arithmetic=arithmetic)
"""The `ars` learner as the registry holds it (`agent.LEARNERS`)."""
ArsAgents.learner = LEARNER
