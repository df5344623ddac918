"""TD3 (Fujimoto, van Hoof and Meger 2018, "Addressing function approximation error in
actor-critic methods", ICML, PMLR 80:1587-1596) as Stable-Baselines3 computes it
(`stable_baselines3.TD3`, `agent.td3`), written in JAX and trained as a whole population in
one jitted program (`agent.off_policy_jax`: the loop, the buffer, the networks, what differs
from `td3`): the same settings as `td3` (`Td3Settings`, and `normalize_observations`),
the same equations, PyTorch's Adam.

A deterministic actor mu(s) (a tanh output), explored with Gaussian action noise of standard
deviation `noise_std` (SB3's `NormalActionNoise`, added to the warm-up's uniform actions
too), clipped to [-1, 1]. Each gradient step, on a minibatch, in SB3's order (`TD3.train`),
the agent's gradient steps counted over its whole run (SB3's `_n_updates`):

1. the critics: one Adam step on sum_i mean((Q_i(s, a) - y)^2), y = r + gamma
   (1 - terminal) min_i Q_target,i(s', a') (clipped double Q, eq. 10), a' =
   clip(mu_target(s') + clip(e, -c, c), -1, 1), e ~ N(0, `target_policy_noise`^2), c =
   `target_noise_clip` (target policy smoothing, eq. 14);
2. where the count is a multiple of `policy_delay` (delayed policy updates, section 5.2):
   the actor, one Adam step on -mean(Q_1(s, mu(s))) through the critic of step 1 (the
   deterministic policy gradient), then the Polyak updates of the target critics and the
   target actor, theta_target <- tau theta + (1 - tau) theta_target.

A greedy action is mu(s).
"""

import dataclasses

from lwrl.agent.jax_population import jax_unavailable, masked, polyak
from lwrl.agent.learner_contract import Learner
from lwrl.agent.off_policy import CHECKED, fits_continuous
from lwrl.agent.off_policy_jax import ActorCriticAgents, shared
from lwrl.agent.observation_normalisation import ObservationNormalisation, counted
from lwrl.agent.off_policy_jax import memory as off_policy_memory
from lwrl.agent.td3 import Td3Settings, arithmetic


@dataclasses.dataclass(frozen=True, kw_only=True)
class Td3JaxSettings(ObservationNormalisation, Td3Settings):
    """`td3`'s settings, and the observation normalisation
    (`agent.observation_normalisation`)."""


class Td3JaxAgents(ActorCriticAgents):
    """B TD3 agents as one pytree (see the module): the target actor and the count of
    gradient steps beside the networks."""

    HYPER = ActorCriticAgents.HYPER + ("noise_std", "policy_delay", "target_policy_noise",
                                       "target_noise_clip")

    def own_state(self, params) -> dict:
        """The target actor (a copy of the actor to start with) and the gradient steps so far."""
        return {"actor_target": params["actor"], "updates": self.jnp.zeros((), self.jnp.int32)}

    def greedy_action(self, actor, observation):
        return self.jnp.tanh(self.actor_output(actor, observation)[..., 0])

    def explore(self, actor, observation, key, hyper, warm, uniform):
        jax, jnp = self.jax, self.jnp
        noise = hyper["noise_std"].astype(jnp.float32) * jax.random.normal(key, (), jnp.float32)
        chosen = jnp.where(warm, uniform, self.greedy_action(actor, observation))
        return jnp.clip(chosen + noise, -1.0, 1.0)

    def gradient_step(self, learned, batch, index, key, hyper, rate):
        jax, jnp = self.jax, self.jnp
        updates = learned["updates"] + 1
        observations = batch["observations"]
        clip = hyper["target_noise_clip"].astype(jnp.float32)
        noise = jnp.clip(hyper["target_policy_noise"].astype(jnp.float32) * jax.random.normal(
            key, batch["rewards"].shape, jnp.float32), -clip, clip)
        next_actions = jnp.clip(self.greedy_action(learned["actor_target"],
                                                   batch["next_observations"]) + noise, -1.0, 1.0)
        learned = self.critic_step(learned, batch, self.next_values(learned, batch, next_actions),
                                   hyper, rate, 1.0)
        critics = learned["params"]["critics"]

        def actor_loss(actor):  # the deterministic policy gradient through Q_1
            actions = self.greedy_action(actor, observations)
            return -jnp.mean(self.critic_values(self.first_critic(critics), observations,
                                                actions)[0])
        stepped = self.adam_step(learned, "actor", actor_loss, rate)
        delayed = updates % hyper["policy_delay"] == 0
        return {**masked(delayed, learned, params=stepped["params"], adam=stepped["adam"]),
                "critic_target": polyak(critics, learned["critic_target"], hyper["tau"], delayed),
                "actor_target": polyak(stepped["params"]["actor"], learned["actor_target"],
                                       hyper["tau"], delayed),
                "updates": updates}


def make(settings, task, seeds) -> Td3JaxAgents:
    """B TD3 agents trained as one JAX program, agent b with `settings[b]` and its random
    stream from `seeds[b]`."""
    return Td3JaxAgents(settings, task, seeds)


def load(document, arrays) -> Td3JaxAgents:
    """The agents `Td3JaxAgents.saved` wrote (a ValueError if the parts do not fit)."""
    return Td3JaxAgents.loaded(document, arrays, Td3JaxSettings)


def memory(settings, task) -> int:
    """Bytes of one agent (`off_policy_jax.memory`): the actor with its target, four copies."""
    return off_policy_memory(settings, task, 1, 4)


LEARNER = Learner(
    name="td3_jax", title="TD3 in JAX, a population in one program: SB3's equations",
    source="Fujimoto et al. (2018), ICML, PMLR 80:1587-1596; Raffin et al. (2021), JMLR 22(268): "
           "stable_baselines3.TD3, in JAX as PureJaxRL (Lu et al. 2022)",
    settings=Td3JaxSettings, make=make, load=load, memory=memory,
    fits=fits_continuous("td3_jax"), unavailable=jax_unavailable("td3_jax"),
    checked=CHECKED,
    actions="continuous",
    population=True, shared=shared("td3_jax"), arithmetic=counted(arithmetic))
"""The `td3_jax` learner as the registry holds it (`agent.LEARNERS`)."""
Td3JaxAgents.learner = LEARNER
