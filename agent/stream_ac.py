"""Stream AC(lambda) for continuous actions (Elsayed, Vasan & Mahmood 2024, "Streaming deep
reinforcement learning finally works", arXiv:2410.14606; the authors'
`stream_ac_continuous.py`), trained as a population in one jitted JAX program
(`agent.stream_agents`, `runners.population`): one transition per agent per step, no replay
buffer, no batch.

Per step of an agent, at the normalised observation x (`agent.stream_agents`): the actor,
an MLP of `net_arch` (layer normalisation without learned parameters and leaky ReLU after
each hidden layer, sparse initialisation: `agent.streaming`) with two outputs, the mean mu(x)
and sigma(x) = softplus of the other, samples u ~ N(mu, sigma); the task takes u clipped to
[-1, 1] (the authors' `ClipAction`), scaled to the actuator's range. After the transition
(x, u, r scaled, x'), with the critic V, an MLP of the same shape:

    delta = r + gamma (1 - terminal) V(x') - V(x)                    (`streaming.v_td_error`)
    z_w = gamma lambda z_w + grad V(x),
    z_theta = gamma lambda z_theta + grad (log pi(u|x) + c_e sign(delta) H(pi(.|x)))
                                                                     (`streaming.actor_objective`)

and each network takes its own ObGD step along its trace (`streaming.obgd`), the actor with
its bound `kappa_policy`, the critic with `kappa`; both traces are zeroed at the end of an
episode. A greedy action is mu(x), clipped. The authors' defaults: alpha 1, gamma 0.99,
lambda 0.8, kappa 2 (critic) and 3 (actor), c_e 0.01, two hidden layers of 128, sparsity 0.9.
"""

import dataclasses

from lwrl.agent.arithmetic import Count, Counts, mlp_parameters
from lwrl.agent.jax_population import jax_unavailable
from lwrl.agent.learner_contract import Learner
from lwrl.agent.off_policy import fits_continuous
from lwrl.agent.stream_agents import (HYPER, SOURCE, StreamAgents, StreamSettings, network_forward,
                                      obgd_count, observation_counts, stream_memory, trained_pass)
from lwrl.settings import check_non_negative, check_positive, setting


@dataclasses.dataclass(frozen=True, kw_only=True)
class ActorCriticSettings(StreamSettings):
    """What both stream-AC(lambda) learners take beside the streaming settings: the actor's
    bound and its entropy coefficient (the authors' defaults)."""

    kappa_policy: float = setting(3.0, per_agent=True)
    """The actor's ObGD bound."""
    ent_coef: float = setting(0.01, per_agent=True)
    """Entropy coefficient c_e of the actor's objective."""

    def check(self, task) -> None:
        super().check(task)
        check_positive("kappa_policy", self.kappa_policy)
        check_non_negative("ent_coef", self.ent_coef)

    def describe(self, dim: int) -> str:
        return (f"Stream AC(lambda), {self.describe_stream()}, actor kappa "
                f"{self.kappa_policy:g}, entropy {self.ent_coef:g}")


@dataclasses.dataclass(frozen=True, kw_only=True)
class StreamAcSettings(ActorCriticSettings):
    """Stream AC(lambda)'s settings (the authors' defaults for continuous actions)."""

    timesteps: int = setting(2_000_000, per_agent=True)
    """Environment steps of learning (the authors' `total_steps`); the agent then acts
    greedily."""
    net_arch: str = setting("128,128")
    """Hidden layers' widths of the actor and of the critic, comma-separated."""

    def label(self) -> str:
        return (f"stream_ac-{self.net_arch.replace(',', 'x')}-lr{self.learning_rate:g}"
                f"-l{self.lam:g}-t{self.timesteps}")


class ActorCriticAgents(StreamAgents):
    """B stream-AC(lambda) agents as one pytree: an actor and a critic, the update both
    learners share (see the module). Subclasses give the policy: the actor's outputs
    (`actor_outputs`), the choice of an action (`choose`) and the log-probability and
    entropy the actor's trace takes (`objective`)."""

    HYPER = HYPER + ("kappa_policy", "ent_coef")
    """The per-agent settings the program takes as arrays: the streaming ones and the
    actor's bound and entropy coefficient."""

    def actor_outputs(self) -> int:
        """The actor's outputs."""
        raise NotImplementedError

    def objective(self, actor, x, action, entropy_coef, sign_delta):
        """`streaming.actor_objective` of the policy of `actor` at `x`, for `action`."""
        raise NotImplementedError

    def networks(self, key):
        from lwrl.agent import streaming
        settings = self.settings[0]
        actor_key, critic_key = self.jax.random.split(key)
        hidden = [self.dim, *settings.layers()]
        return {"actor": streaming.sparse_network(actor_key, hidden + [self.actor_outputs()],
                                                  settings.sparsity),
                "critic": streaming.sparse_network(critic_key, hidden + [1], settings.sparsity)}

    def learn(self, params, traces, transition, hyper):
        """Stream AC(lambda)'s update (see the module)."""
        jax, jnp = self.jax, self.jnp
        from lwrl.agent import streaming
        critic, actor = params["critic"], params["actor"]
        v_tm1, critic_grad = jax.value_and_grad(
            lambda p: streaming.forward(p, transition["x"])[0])(critic)
        v_t = streaming.forward(critic, transition["next_x"])[0]
        discount = hyper["gamma"] * (1.0 - transition["terminated"].astype(jnp.float64))
        delta = streaming.v_td_error(v_tm1, transition["reward"], discount, v_t)
        sign = jnp.sign(delta).astype(jnp.float32)
        coef = hyper["ent_coef"].astype(jnp.float32)
        actor_grad = jax.grad(lambda p: self.objective(
            p, transition["x"], transition["extras"]["action"], coef, sign))(actor)
        actor, actor_trace = streaming.obgd(actor, traces["actor"], actor_grad, delta,
                                            hyper["learning_rate"], hyper["gamma"], hyper["lam"],
                                            hyper["kappa_policy"])
        critic, critic_trace = streaming.obgd(critic, traces["critic"], critic_grad, delta,
                                              hyper["learning_rate"], hyper["gamma"],
                                              hyper["lam"], hyper["kappa"])
        return {"actor": actor, "critic": critic}, {"actor": actor_trace, "critic": critic_trace}

    def state_values(self, states, weights=None):
        """The critic's V(s), `(B, ...)` (or `(...)` for `weights`)."""
        from lwrl.agent import streaming
        return self.over_agents(states, weights, lambda tree, s: streaming.forward(
            tree["params"]["critic"], self.normalised_states(tree, s))[..., 0])


class StreamAcAgents(ActorCriticAgents):
    """B Stream AC(lambda) agents of continuous actions (see the module)."""

    def actor_outputs(self) -> int:
        """The mean and the spread's pre-activation."""
        return 2

    def blank_extras(self) -> dict:
        jnp = self.jnp
        return {"action": jnp.zeros((), jnp.float32), "reset": jnp.zeros((), bool)}

    def gaussian(self, actor, x):
        """`(mu, sigma)` `(...)` of the actor at normalised observations `(..., d)`."""
        from lwrl.agent import streaming
        output = streaming.forward(actor, x)
        return output[..., 0], self.jax.nn.softplus(output[..., 1])

    def choose(self, params, x, key, hyper, greedy, clock):
        """A sample of N(mu, sigma) (mu where greedy), clipped for the task; `extras` keeps
        the sample itself, whose log-probability the actor's trace takes."""
        jax, jnp = self.jax, self.jnp
        mean, std = self.gaussian(params["actor"], x)
        sample = jnp.where(greedy, mean, mean + std * jax.random.normal(key, (), jnp.float32))
        return jnp.clip(sample, -1.0, 1.0), {"action": sample, "reset": jnp.zeros((), bool)}

    def objective(self, actor, x, action, entropy_coef, sign_delta):
        from lwrl.agent import streaming
        mean, std = self.gaussian(actor, x)
        return streaming.actor_objective(streaming.gaussian_log_prob(mean, std, action),
                                         streaming.gaussian_entropy(std), entropy_coef,
                                         sign_delta)

    def greedy_actions(self, states, weights=None):
        """The actor's greedy action in [-1, 1], its clipped mean, `(B, ...)` (or `(...)`
        for `weights`)."""
        return self.over_agents(states, weights, lambda tree, s: self.jnp.clip(self.gaussian(
            tree["params"]["actor"], self.normalised_states(tree, s))[0], -1.0, 1.0))


def make(settings, task, seeds) -> StreamAcAgents:
    """B Stream AC(lambda) agents trained as one JAX program, agent b with `settings[b]` and
    its random stream from `seeds[b]`."""
    return StreamAcAgents(settings, task, seeds)


def load(document, arrays) -> StreamAcAgents:
    """The agents `StreamAcAgents.saved` wrote (a ValueError if the parts do not fit)."""
    return StreamAcAgents.loaded(document, arrays, StreamAcSettings)


def network_sizes(settings, task, outputs: int) -> tuple:
    """The layer widths of the actor, of `outputs` outputs, and of the critic."""
    dim, layers = len(task.state_names), settings.layers()
    return [dim, *layers, outputs], [dim, *layers, 1]


def actor_critic_memory(settings, task, outputs: int) -> int:
    """Bytes of one agent whose actor has `outputs` outputs: its actor and critic and their
    traces, statistics and transition."""
    actor, critic = network_sizes(settings, task, outputs)
    return stream_memory(mlp_parameters(actor) + mlp_parameters(critic), len(task.state_names))


def actor_critic_counts(settings, task, outputs: int, sample: Count, policy: Count,
                        source: str) -> Counts:
    """The counted arithmetic of a stream-AC(lambda) learner whose actor has `outputs`
    outputs: a greedy decision normalises the observation (where the settings say so) and
    runs the actor (`stream_agents.network_forward`); an agent-step of learning adds the
    `sample` of an action, the transition (`observation_counts`), V(x'), a forward and
    backward pass of both networks at x with the `policy`'s log-probability and entropy,
    and ObGD over every parameter, the same at every step (square roots counted with the
    exponentials); `source` names the learner's `arithmetic`."""
    actor, critic = network_sizes(settings, task, outputs)
    normalised, transition = observation_counts(len(task.state_names),
                                                settings.normalize_observations)
    decision = normalised + network_forward(actor)
    update = (transition + network_forward(critic) + trained_pass(critic) + trained_pass(actor)
              + policy + obgd_count(mlp_parameters(actor) + mlp_parameters(critic)))
    return Counts(decision, decision + sample + update, update,
                  f"actor {'-'.join(map(str, actor))}, critic {'-'.join(map(str, critic))}, "
                  f"layer norm, leaky ReLU ({source})")


def memory(settings, task) -> int:
    """Bytes of one agent (`actor_critic_memory`, the actor's two outputs)."""
    return actor_critic_memory(settings, task, 2)


def arithmetic(settings, task, steps=None) -> Counts:
    """Its counted arithmetic (`Learner.arithmetic`, `actor_critic_counts`): the sample's
    softplus, an exponential and a logarithm; the log-probability and entropy, 6
    multiply-adds and log sigma."""
    del steps
    return actor_critic_counts(settings, task, 2, Count(1, 2), Count(6, 1),
                               f"{__name__}.arithmetic")


LEARNER = Learner(
    name="stream_ac", title="Stream AC(lambda) for continuous actions: streaming actor-critic "
                            "with ObGD, in JAX",
    source=SOURCE, settings=StreamAcSettings, make=make, load=load, memory=memory,
    fits=fits_continuous("stream_ac"), unavailable=jax_unavailable("stream_ac"),
    actions="continuous",
    population=True, arithmetic=arithmetic)
"""The `stream_ac` learner as the registry holds it (`agent.LEARNERS`)."""
StreamAcAgents.learner = LEARNER
