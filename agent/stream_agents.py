"""What the streaming learners (`agent.stream_q`, `agent.stream_ac`) share: their settings
and the plumbing that carries one transition per agent per step through the population
program (`agent.jax_population`, `runners.population`), apart from their equations
(`agent.streaming`).

Per step, as the authors' wrappers and loops do it (`mohmdelsayed/streaming-drl`:
`normalization_wrappers.py`, `stream_q.py`, `stream_ac_continuous.py`):

- `act`: an observation that starts an episode first enters the observation statistics
  (one that continues an episode entered them as the previous transition's next
  observation); the learner acts on it normalised (`running_stats.normalised`). Acting greedily
  (evaluation, or after `timesteps`) the statistics are left as they are;
- `record`: the next observation enters the statistics and is normalised, the reward is
  scaled (`streaming.scaled_reward`), and the normalised transition is kept;
- `update`, after every step: the learner's update on that transition (`learn`), its traces
  zeroed first where the transition starts an episode (and after it where it ends one, or
  where the learner says so: stream-Q's exploratory actions).

Where lwrl departs from the authors' scripts, and why (docs/guide/learners.md): a time limit
is not a terminal state (the target bootstraps from it, as every learner of lwrl does; the
authors' `done = terminated or truncated` does not), and the observation is the task's, without
the authors' `AddTimeInfo` feature (the episode's elapsed time), which the greedy controller
of a task does not have.

The program is `mapped` (`agent.jax_population.Program`): the agents act and learn one after
another, as vmapped over the batch an agent's numbers were not the same alone and in a batch
(XLA's CPU code for one agent differs from that for several; written out as sums over the
inputs the networks still differed), at a third of the vmapped program's speed.

In the contract's terms: `weights` are the networks' parameters and the observation
statistics (a greedy decision needs both); `delta` is not kept per step, and there are no
action values at the observations (no `q`).
"""

import dataclasses

import numpy as np

from lwrl.agent.arithmetic import BACKWARD_MACS, Count, mlp_forward
from lwrl.agent.jax_population import PopulationAgents, Program, masked
from lwrl.agent.learner_contract import LearnerSettings
from lwrl.agent.stable_baselines import check_layers, check_network
from lwrl.settings import WHEN_SET, check_flag, check_positive, check_unit_interval, setting

SOURCE = ("Elsayed, Vasan & Mahmood (2024), arXiv:2410.14606; mohmdelsayed/streaming-drl at "
          "commit 407dca7")
"""The paper and the authors' code the streaming learners follow."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class StreamSettings(LearnerSettings):
    """What every streaming learner takes (the authors' defaults)."""

    timesteps: int = setting(500_000, per_agent=True)
    """Environment steps of learning (the authors' `total_steps`, the exploration schedule's
    horizon); the agent then acts greedily."""
    net_arch: str = setting("32,32")
    """Hidden layers' widths, comma-separated (the authors' `hidden_size`, two layers)."""
    learning_rate: float = setting(1.0, per_agent=True)
    """ObGD's step size alpha."""
    gamma: float = setting(0.99, per_agent=True)
    """Discount factor gamma in [0, 1]."""
    lam: float = setting(0.8, flags=("--lambda",), per_agent=True)
    """Trace decay lambda in [0, 1]."""
    kappa: float = setting(2.0, per_agent=True)
    """ObGD's bound kappa (the value network's, `kappa_value`)."""
    sparsity: float = setting(0.9)
    """Fraction of each layer's weights initialised to 0, in [0, 1)."""
    normalize_observations: bool = setting(True, key=WHEN_SET)
    """Normalise each observation by the running mean and variance of those seen in
    learning: the deep learners' JAX populations as SB3's `VecNormalize(norm_obs=True)`
    (clipped to +-10; off by default), the streaming learners as their authors'
    `NormalizeObservation` (on by default)."""

    def layers(self) -> list:
        """The hidden layers' widths of `net_arch`, checked."""
        return list(check_layers(self.net_arch))

    def check(self, task) -> None:
        check_network(self)
        check_unit_interval("lam", self.lam)
        check_positive("kappa", self.kappa)
        check_flag("normalize_observations", self.normalize_observations)
        if not (isinstance(self.sparsity, (int, float)) and 0.0 <= self.sparsity < 1.0):
            raise ValueError(f"sparsity must be a number in [0, 1) (the fraction of each "
                             f"layer's weights set to 0); got {self.sparsity!r}")

    def describe_stream(self) -> str:
        """The network and ObGD's settings in words, for a run's header."""
        return (f"MLP {self.net_arch} (layer norm, leaky ReLU, {self.sparsity:g} sparse), "
                f"ObGD lr {self.learning_rate:g} kappa {self.kappa:g}, gamma {self.gamma:g}, "
                f"lambda {self.lam:g}, {self.timesteps} steps"
                + ("" if self.normalize_observations else ", observations in task units"))


HYPER = ("timesteps", "learning_rate", "gamma", "lam", "kappa")
"""The per-agent settings every streaming learner's program takes as arrays."""


class StreamAgents(PopulationAgents):
    """B streaming agents as one pytree (see the module). Subclasses give the networks
    (`networks`), the choice of an action (`choose`), the update (`learn`) and their own
    per-agent settings (`HYPER`)."""

    HYPER = HYPER
    """The per-agent settings the program takes as arrays (`HYPER`, and a subclass's own)."""

    def networks(self, key) -> dict:
        """The initial parameters, a pytree of float32 arrays."""
        raise NotImplementedError

    def choose(self, params, x, key, hyper, greedy, clock):
        """`(action, extras)` at the normalised observation `x` (float32 `(d,)`); `extras`
        keeps what `learn` needs of the choice (at least `action`, as `learn` takes it, and
        `reset`, whether the traces are zeroed after the update)."""
        raise NotImplementedError

    def blank_extras(self) -> dict:
        """Zeros of the structure of `choose`'s `extras` (the state's kept transition)."""
        raise NotImplementedError

    def learn(self, params, traces, transition, hyper):
        """`(params, traces)` after the learner's update on `transition` (`x`, `extras`,
        `reward` scaled, `next_x`, `terminated`), from `traces` zeroed where it starts an
        episode."""
        raise NotImplementedError

    def initial_state(self, key):
        jax, jnp = self.jax, self.jnp
        from lwrl.agent import running_stats
        net_key, key = jax.random.split(key)
        params = self.networks(net_key)
        x = jnp.zeros(self.dim, jnp.float32)
        false = jnp.zeros((), bool)
        return {"params": params, "traces": jax.tree.map(jnp.zeros_like, params),
                "observations": running_stats.stats_start(self.dim),
                "rewards": running_stats.stats_start(), "return_trace": jnp.zeros(()),
                "last": jnp.zeros(self.dim), "ended": jnp.ones((), bool),
                "transition": {"x": x, "next_x": x, "reward": jnp.zeros(()),
                               "terminated": false, "ended": false, "fresh": false,
                               "extras": self.blank_extras()},
                "key": key}

    @staticmethod
    def weight_tree(state):
        return {"params": state["params"], "observations": state["observations"]}

    def normalised_states(self, weights, states):
        """Task-unit `states` `(n, d)` as the learner reads them (`input`), float32."""
        return self.input(states, weights["observations"])

    def input(self, observation, stats):
        """What the networks read of an observation: normalised by the running statistics
        `stats` (`running_stats.normalised`), or as it is where the settings say not to
        normalise; float32."""
        from lwrl.agent import running_stats
        if not self.settings[0].normalize_observations:
            return observation.astype(self.jnp.float32)
        return running_stats.normalised(observation, stats).astype(self.jnp.float32)

    def program(self) -> Program:
        jax, jnp = self.jax, self.jnp
        from lwrl.agent import running_stats, streaming
        hyper = {name: np.array([getattr(s, name) for s in self.settings]) for name in self.HYPER}
        hyper["learning_steps"] = hyper["timesteps"]
        choose, learn = self.choose, self.learn

        def act(state, observation, key, hyper, greedy, clock):
            continuing = ~state["ended"] & jnp.all(observation == state["last"])
            kept = continuing | greedy
            stats = jax.tree.map(lambda old, new: jnp.where(kept, old, new), state["observations"],
                                 running_stats.stats_add(state["observations"], observation))
            x = self.input(observation, stats)
            action, extras = choose(state["params"], x, key, hyper, greedy, clock)
            return action, {"x": x, "observations": stats, "fresh": ~continuing, "extras": extras}

        def record(state, extras, observation, action, reward, terminated, truncated,
                   final_observation, hyper, clock, write):
            stats = running_stats.stats_add(extras["observations"], final_observation)
            ended = terminated | truncated
            scaled, trace, rewards = streaming.scaled_reward(
                reward, state["return_trace"], state["rewards"], hyper["gamma"],
                ended.astype(jnp.float64))
            transition = {"x": extras["x"], "extras": extras["extras"], "reward": scaled,
                          "next_x": self.input(final_observation, stats),
                          "terminated": terminated, "ended": ended, "fresh": extras["fresh"]}
            return masked(write, state, observations=stats, rewards=rewards, return_trace=trace,
                          last=final_observation.astype(state["last"].dtype), ended=ended,
                          transition=transition)

        def update(state, next_observation, next_start, hyper, clock, due):
            del next_observation, next_start, clock
            transition = state["transition"]
            traces = streaming.cleared(state["traces"], transition["fresh"])
            params, traces = learn(state["params"], traces, transition, hyper)
            traces = streaming.cleared(traces, transition["ended"] | transition["extras"]["reset"])
            return masked(due, state, params=params, traces=traces)

        return Program(act=act, record=record, update=update,
                       update_due=lambda hyper, clock: clock >= 0, hyper=hyper,
                       mapped=True)


def network_forward(sizes) -> Count:
    """One forward pass of a streaming network of layer widths `sizes`: the MLP's
    multiply-adds (`arithmetic.mlp_forward`), and each hidden layer's normalisation, 2 per
    unit (the variance's square, the scaling) and one square root, counted with the
    exponentials; leaky ReLU none."""
    hidden = sizes[1:-1]
    return mlp_forward(sizes, False) + Count(2 * sum(hidden), len(hidden))


def trained_pass(sizes) -> Count:
    """A forward and backward pass of the network (`arithmetic.BACKWARD_MACS`), the backward
    pass reusing the forward pass's square roots."""
    forward = network_forward(sizes)
    return Count((1 + BACKWARD_MACS) * forward.macs, forward.exps)


def observation_counts(dim: int, normalise: bool = True) -> tuple:
    """`(normalised, transition)`: an observation normalised, d multiply-adds and d square
    roots (none where the settings turn the normalisation off); and what a transition adds
    beside the networks: the next observation into the statistics (2 d), normalised, and the
    reward scaled (4 and a square root)."""
    normalised = Count(dim, dim) if normalise else Count(0)
    return normalised, normalised + Count(2 * dim + 4, 1)


def obgd_count(parameters: int) -> Count:
    """ObGD over `parameters` (`streaming.obgd`): the trace's decay and gradient, its L1 norm
    and the step, 3 multiply-adds each."""
    return Count(3 * parameters)


def stream_memory(parameters: int, dim: int) -> int:
    """Bytes of one streaming agent of `parameters` float32 network parameters: the
    parameters and their traces, and the statistics and the transition (float64)."""
    return 2 * 4 * parameters + 8 * (6 * dim + 16)

