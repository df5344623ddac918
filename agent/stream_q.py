"""Stream Q(lambda) (Elsayed, Vasan & Mahmood 2024, "Streaming deep reinforcement learning
finally works", arXiv:2410.14606; the authors' `stream_q.py`), trained as a population in one
jitted JAX program (`agent.stream_agents`, `runners.population`): one transition per agent
per step, no replay buffer, no target network, no batch.

Per step of an agent, at the normalised observation x (`agent.stream_agents`): Q(x, .) of an
MLP of `net_arch` (layer normalisation without learned parameters and leaky ReLU after each
hidden layer, sparse initialisation: `agent.streaming`); epsilon-greedy with epsilon linear
from `exploration_initial_eps` to `exploration_final_eps` over `exploration_fraction` of
`timesteps` (`streaming.epsilon`), an exploratory action being one whose random draw differs
from the greedy action. After the transition (x, a, r scaled, x'):

    delta = r + gamma (1 - terminal) max_a' Q(x', a') - Q(x, a)      (`streaming.q_td_error`)
    z = gamma lambda z + grad Q(x, a);  w = w + alpha / max(M, 1) delta z,
    M = alpha kappa max(|delta|, 1) ||z||_1                          (ObGD, `streaming.obgd`)

and z = 0 after an exploratory action (Watkins' Q(lambda)) and at the end of an episode.
The authors' defaults: alpha 1, gamma 0.99, lambda 0.8, kappa 2, two hidden layers of 32,
sparsity 0.9, epsilon 1 to 0.01 over 0.05 of 500 000 steps.
"""

import dataclasses

from lwrl.agent.arithmetic import Counts, mlp_parameters
from lwrl.agent.jax_population import jax_unavailable
from lwrl.agent.learner_contract import Learner
from lwrl.agent.stream_agents import (HYPER, SOURCE, StreamAgents, StreamSettings, network_forward,
                                      obgd_count, observation_counts, stream_memory, trained_pass)
from lwrl.settings import check_unit_interval, setting


@dataclasses.dataclass(frozen=True, kw_only=True)
class StreamQSettings(StreamSettings):
    """Stream Q(lambda)'s settings (the authors' defaults)."""

    exploration_fraction: float = setting(0.05, per_agent=True)
    """Fraction of `timesteps` over which epsilon falls from its initial to its final value."""
    exploration_initial_eps: float = setting(1.0, per_agent=True)
    """Epsilon at the start."""
    exploration_final_eps: float = setting(0.01, per_agent=True)
    """Epsilon after the exploration fraction."""

    def check(self, task) -> None:
        super().check(task)
        for name in ("exploration_fraction", "exploration_initial_eps", "exploration_final_eps"):
            check_unit_interval(name, getattr(self, name))

    def label(self) -> str:
        return (f"stream_q-{self.net_arch.replace(',', 'x')}-lr{self.learning_rate:g}"
                f"-l{self.lam:g}-t{self.timesteps}")

    def describe(self, dim: int) -> str:
        return (f"Stream Q(lambda), {self.describe_stream()}, epsilon "
                f"{self.exploration_initial_eps:g} -> {self.exploration_final_eps:g} over "
                f"{self.exploration_fraction:g}")


class StreamQAgents(StreamAgents):
    """B Stream Q(lambda) agents as one pytree (see the module)."""

    HYPER = HYPER + ("exploration_fraction", "exploration_initial_eps", "exploration_final_eps")
    """The per-agent settings the program takes as arrays: the streaming ones and the
    epsilon schedule's."""

    def networks(self, key):
        from lwrl.agent import streaming
        settings = self.settings[0]
        sizes = [self.dim, *settings.layers(), self.task.action.n]
        return streaming.sparse_network(key, sizes, settings.sparsity)

    def blank_extras(self) -> dict:
        jnp = self.jnp
        return {"action": jnp.zeros((), jnp.int32), "reset": jnp.zeros((), bool)}

    def choose(self, params, x, key, hyper, greedy, clock):
        """Epsilon-greedy on Q(x, .); `reset` where the random action is not the greedy one."""
        jax, jnp = self.jax, self.jnp
        from lwrl.agent import streaming
        q = streaming.forward(params, x)
        best = jnp.argmax(q).astype(jnp.int32)
        uniform_key, action_key = jax.random.split(key)
        rate = streaming.epsilon(clock + 1, hyper["exploration_initial_eps"],
                                 hyper["exploration_final_eps"],
                                 hyper["exploration_fraction"] * hyper["timesteps"])
        explore = (jax.random.uniform(uniform_key) < rate) & ~greedy
        other = jax.random.randint(action_key, (), 0, q.shape[-1], jnp.int32)
        action = jnp.where(explore, other, best)
        return action, {"action": action, "reset": explore & (other != best)}

    def learn(self, params, traces, transition, hyper):
        """Stream Q(lambda)'s update (see the module)."""
        jax, jnp = self.jax, self.jnp
        from lwrl.agent import streaming
        action = transition["extras"]["action"]
        q_t = streaming.forward(params, transition["next_x"])
        q_tm1, grad = jax.value_and_grad(
            lambda p: streaming.forward(p, transition["x"])[action])(params)
        discount = hyper["gamma"] * (1.0 - transition["terminated"].astype(jnp.float64))
        delta = streaming.q_td_error(q_tm1, transition["reward"], discount, q_t)
        return streaming.obgd(params, traces, grad, delta, hyper["learning_rate"],
                              hyper["gamma"], hyper["lam"], hyper["kappa"])

    def learner_form(self, b: int):
        """Agent b as C that goes on learning on a device (`agent.stream_q_c`)."""
        from lwrl.agent import stream_q_c
        return stream_q_c.learner_form(self, b)

    def q_values(self, tree, states):
        """Q(s, .) `(..., A)` of one agent's networks `tree` at states in task units, their
        observation normalised as in learning."""
        from lwrl.agent import streaming
        return streaming.forward(tree["params"], self.normalised_states(tree, states))

    def action_values(self, states, weights=None):
        """Q(s, .) at task-unit states, `(B, ..., A)` (or `(..., A)` for `weights`)."""
        return self.over_agents(states, weights, self.q_values)


def make(settings, task, seeds) -> StreamQAgents:
    """B Stream Q(lambda) agents trained as one JAX program, agent b with `settings[b]` and
    its random stream from `seeds[b]`."""
    return StreamQAgents(settings, task, seeds)


def load(document, arrays) -> StreamQAgents:
    """The agents `StreamQAgents.saved` wrote (a ValueError if the parts do not fit)."""
    return StreamQAgents.loaded(document, arrays, StreamQSettings)


def memory(settings, task) -> int:
    """Bytes of one agent: its Q network and traces, statistics and transition."""
    dim = len(task.state_names)
    return stream_memory(mlp_parameters([dim, *settings.layers(), task.action.n]), dim)


def arithmetic(settings, task, steps=None) -> Counts:
    """Its counted arithmetic (`Learner.arithmetic`): a greedy decision normalises the
    observation (where the settings say so) and runs Q's network
    (`stream_agents.network_forward`); an agent-step of learning adds the transition
    (`observation_counts`), Q(x') and a forward and backward pass at x, and ObGD over every
    parameter, the same at every step (square roots counted with the exponentials)."""
    del steps
    dim = len(task.state_names)
    sizes = [dim, *settings.layers(), task.action.n]
    normalised, transition = observation_counts(dim, settings.normalize_observations)
    decision = normalised + network_forward(sizes)
    update = (transition + network_forward(sizes) + trained_pass(sizes)
              + obgd_count(mlp_parameters(sizes)))
    return Counts(decision, decision + update, update,
                  f"Q {'-'.join(map(str, sizes))}, layer norm, leaky ReLU "
                  f"({mlp_parameters(sizes)} parameters) ({__name__}.arithmetic)")


LEARNER = Learner(
    name="stream_q", title="Stream Q(lambda): streaming deep Q-learning with ObGD, in JAX",
    source=SOURCE, settings=StreamQSettings, make=make, load=load, memory=memory,
    unavailable=jax_unavailable("stream_q"), population=True,
    arithmetic=arithmetic)
"""The `stream_q` learner as the registry holds it (`agent.LEARNERS`)."""
StreamQAgents.learner = LEARNER
