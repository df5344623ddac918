"""Stream AC(lambda) for discrete actions (Elsayed, Vasan & Mahmood 2024, "Streaming deep
reinforcement learning finally works", arXiv:2410.14606; the authors'
`stream_ac_discrete.py`): `agent.stream_ac`'s update with a softmax policy, trained as a
population in one jitted JAX program (`agent.stream_agents`, `runners.population`).

Per step of an agent, at the normalised observation x: the actor, an MLP of `net_arch`
(layer normalisation without learned parameters and leaky ReLU after each hidden layer,
sparse initialisation: `agent.streaming`) with one preference h(x, a) per action, samples a
from pi(.|x) = softmax(h(x, .)) (the authors' `Categorical(probs)`); a greedy action is the
argmax of h. After the transition (x, a, r scaled, x'), with the critic V, an MLP of the same
shape, `agent.stream_ac`'s update with log pi(a|x) = log softmax(h(x, .))_a and
H(pi(.|x)) = -sum_a pi(a|x) log pi(a|x) (`streaming.categorical_log_prob`,
`streaming.categorical_entropy`). The authors' defaults: alpha 1, gamma 0.99, lambda 0.8,
kappa 2 (critic) and 3 (actor), c_e 0.01, two hidden layers of 32 (their `StreamAC`'s
`hidden_size`), sparsity 0.9, 500 000 steps.
"""

import dataclasses

from lwrl.agent.arithmetic import Count, Counts
from lwrl.agent.jax_population import jax_unavailable
from lwrl.agent.learner_contract import Learner
from lwrl.agent.stream_agents import SOURCE
from lwrl.agent.stream_ac import (ActorCriticAgents, ActorCriticSettings, actor_critic_counts,
                                  actor_critic_memory)


@dataclasses.dataclass(frozen=True, kw_only=True)
class StreamAcDiscreteSettings(ActorCriticSettings):
    """Stream AC(lambda)'s settings for discrete actions (the authors' defaults)."""

    def label(self) -> str:
        return (f"stream_ac_discrete-{self.net_arch.replace(',', 'x')}-lr{self.learning_rate:g}"
                f"-l{self.lam:g}-t{self.timesteps}")


class StreamAcDiscreteAgents(ActorCriticAgents):
    """B Stream AC(lambda) agents of discrete actions (see the module)."""

    def actor_outputs(self) -> int:
        """One preference per action."""
        return self.task.action.n

    def blank_extras(self) -> dict:
        jnp = self.jnp
        return {"action": jnp.zeros((), jnp.int32), "reset": jnp.zeros((), bool)}

    def choose(self, params, x, key, hyper, greedy, clock):
        """A sample of softmax(h(x, .)) (the argmax of h where greedy)."""
        jax, jnp = self.jax, self.jnp
        from lwrl.agent import streaming
        preferences = streaming.forward(params["actor"], x)
        action = jnp.where(greedy, jnp.argmax(preferences),
                           jax.random.categorical(key, preferences)).astype(jnp.int32)
        return action, {"action": action, "reset": jnp.zeros((), bool)}

    def preferences(self, states, weights=None):
        """The actor's preferences h(s, .) at task-unit states, `(B, ..., A)` (or `(..., A)`
        for `weights`): what the greedy controller takes the argmax of (no action values:
        `action_values` says so)."""
        from lwrl.agent import streaming
        return self.over_agents(states, weights, lambda tree, s: streaming.forward(
            tree["params"]["actor"], self.normalised_states(tree, s)))

    def objective(self, actor, x, action, entropy_coef, sign_delta):
        from lwrl.agent import streaming
        preferences = streaming.forward(actor, x)
        return streaming.actor_objective(streaming.categorical_log_prob(preferences, action),
                                         streaming.categorical_entropy(preferences),
                                         entropy_coef, sign_delta)


def make(settings, task, seeds) -> StreamAcDiscreteAgents:
    """B Stream AC(lambda) agents of discrete actions trained as one JAX program, agent b with
    `settings[b]` and its random stream from `seeds[b]`."""
    return StreamAcDiscreteAgents(settings, task, seeds)


def load(document, arrays) -> StreamAcDiscreteAgents:
    """The agents `StreamAcDiscreteAgents.saved` wrote (a ValueError if the parts do not
    fit)."""
    return StreamAcDiscreteAgents.loaded(document, arrays, StreamAcDiscreteSettings)


def memory(settings, task) -> int:
    """Bytes of one agent (`stream_ac.actor_critic_memory`, the actor's A outputs)."""
    return actor_critic_memory(settings, task, task.action.n)


def arithmetic(settings, task, steps=None) -> Counts:
    """Its counted arithmetic (`Learner.arithmetic`, `stream_ac.actor_critic_counts`), its
    greedy argmax free: the sample, a softmax and a draw from it, A exponentials and A
    multiply-adds; the log-softmax and the entropy, 2 A exponentials and a logarithm, 2 A
    multiply-adds."""
    del steps
    actions = task.action.n
    return actor_critic_counts(settings, task, actions, Count(actions, actions),
                               Count(2 * actions, 2 * actions + 1), f"{__name__}.arithmetic")


LEARNER = Learner(
    name="stream_ac_discrete", title="Stream AC(lambda) for discrete actions: streaming "
                                     "actor-critic with ObGD, in JAX",
    source=SOURCE, settings=StreamAcDiscreteSettings, make=make, load=load, memory=memory,
    unavailable=jax_unavailable("stream_ac_discrete"), population=True,
    arithmetic=arithmetic)
"""The `stream_ac_discrete` learner as the registry holds it (`agent.LEARNERS`)."""
StreamAcDiscreteAgents.learner = LEARNER
