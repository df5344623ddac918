"""SAC (Haarnoja et al. 2018, "Soft Actor-Critic: off-policy maximum entropy deep reinforcement
learning with a stochastic actor", ICML, PMLR 80:1861-1870; the learned temperature of
Haarnoja et al. 2018b, arXiv:1812.05905, section 5) as Stable-Baselines3 computes it
(`stable_baselines3.SAC`, `agent.sac`), written in JAX and trained as a whole population in
one jitted program (`agent.off_policy_jax`: the loop, the buffer, the networks, what differs
from `sac`): the same settings as `sac` (`SacSettings`, and `normalize_observations`),
the same equations, PyTorch's Adam.

The actor is a Gaussian squashed by tanh (SB3's `SquashedDiagGaussianDistribution`): a =
tanh(u), u = mu(s) + sigma(s) n, n ~ N(0, 1), log sigma(s) clipped to [-20, 2], and
log pi(a|s) = log N(u; mu, sigma) - log(1 - a^2 + 1e-6) (their appendix C, eq. 21). Each
gradient step, on a minibatch, in SB3's order (`SAC.train`), with alpha the entropy
coefficient before this step's own update:

1. the temperature, where `ent_coef_mode` is `auto`: one Adam step on log alpha (SB3 learns
   its log, from log `ent_coef`) of the loss -mean(log alpha (log pi(a~|s) + H)), a~ ~
   pi(.|s), H = -dim(A) = -1 the target entropy (2018b, eq. 18);
2. the critics: one Adam step on 1/2 sum_i mean((Q_i(s, a) - y)^2), y = r + gamma
   (1 - terminal) (min_i Q_target,i(s', a') - alpha log pi(a'|s')), a' ~ pi(.|s') (eq. 5,
   its soft value eq. 3, with the clipped double Q of Fujimoto et al. 2018);
3. the actor: one Adam step on mean(alpha log pi(a~|s) - min_i Q_i(s, a~)), a~ the sample of
   step 1 reparameterised (eq. 7 with eq. 11), through the critics of step 2;
4. where the step's index within its training call is a multiple of
   `target_update_interval` (SB3's `gradient_step % target_update_interval`), the target
   critics' Polyak update, Q_target <- tau Q + (1 - tau) Q_target.

A greedy action is tanh(mu(s)). The warm-up's actions are uniform over [-1, 1], the actions
of learning the policy's samples.
"""

import dataclasses
import math

import numpy as np

from lwrl.agent.jax_population import adam, adam_init, jax_unavailable, masked, polyak
from lwrl.agent.learner_contract import Learner
from lwrl.agent.off_policy import CHECKED, fits_continuous
from lwrl.agent.off_policy_jax import ActorCriticAgents, shared
from lwrl.agent.observation_normalisation import ObservationNormalisation, counted
from lwrl.agent.off_policy_jax import memory as off_policy_memory
from lwrl.agent.sac import SacSettings, arithmetic

LOG_STD_RANGE = (-20.0, 2.0)
"""SB3's `LOG_STD_MIN`, `LOG_STD_MAX`: the actor's log standard deviation is clipped to it."""
TARGET_ENTROPY = -1.0
"""SB3's `target_entropy="auto"`: -dim(A), one action."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class SacJaxSettings(ObservationNormalisation, SacSettings):
    """`sac`'s settings, and the observation normalisation
    (`agent.observation_normalisation`)."""


class SacJaxAgents(ActorCriticAgents):
    """B SAC agents as one pytree (see the module): the actor's two heads, the temperature
    log alpha and its Adam beside the networks."""

    ACTOR_OUTPUTS = 2
    HYPER = ActorCriticAgents.HYPER + ("ent_coef", "target_update_interval")

    def __init__(self, settings, task, seeds):
        super().__init__(settings, task, seeds)
        jnp = self.jnp
        start = [s.ent_coef if s.ent_coef_mode == "auto" else 1.0 for s in self.settings]
        self.state = {**self.state, "log_alpha": jnp.log(jnp.asarray(start, jnp.float32))}

    def own_state(self, params) -> dict:
        """log alpha (its value per agent set once the batch is made: log `ent_coef` where
        learned, as SB3's `log(ones(1) * init_value)`, else 0, unused) and its Adam."""
        log_alpha = self.jnp.zeros((), self.jnp.float32)
        return {"log_alpha": log_alpha, "alpha_adam": adam_init(log_alpha)}

    def hyper(self) -> dict:
        hyper = super().hyper()
        hyper["learned_alpha"] = np.array([s.ent_coef_mode == "auto" for s in self.settings])
        return hyper

    def gaussian(self, actor, observation):
        """`(mu, log sigma)` `(...)` of the actor at observations `(..., d)`."""
        output = self.actor_output(actor, observation)
        return output[..., 0], self.jnp.clip(output[..., 1], *LOG_STD_RANGE)

    def greedy_action(self, actor, observation):
        return self.jnp.tanh(self.gaussian(actor, observation)[0])

    def sample(self, actor, observation, key):
        """`(a, log pi(a|s))` `(...)`: a sample of the squashed Gaussian at observations
        `(..., d)` and its log-probability (eq. 21, as torch's `Normal.log_prob`)."""
        jax, jnp = self.jax, self.jnp
        mean, log_std = self.gaussian(actor, observation)
        std = jnp.exp(log_std)
        gaussian = mean + std * jax.random.normal(key, mean.shape, jnp.float32)
        action = jnp.tanh(gaussian)
        log_prob = (-((gaussian - mean) ** 2) / (2 * std ** 2) - jnp.log(std)
                    - math.log(math.sqrt(2 * math.pi)))
        return action, log_prob - jnp.log(1 - action ** 2 + 1e-6)

    def explore(self, actor, observation, key, hyper, warm, uniform):
        return self.jnp.where(warm, uniform, self.sample(actor, observation, key)[0])

    def gradient_step(self, learned, batch, index, key, hyper, rate):
        jax, jnp = self.jax, self.jnp
        actor_key, next_key = jax.random.split(key)
        observations = batch["observations"]
        _, log_prob = self.sample(learned["params"]["actor"], observations, actor_key)
        alpha = jnp.where(hyper["learned_alpha"], jnp.exp(learned["log_alpha"]),
                          hyper["ent_coef"].astype(jnp.float32))

        def alpha_loss(log_alpha):  # eq. 18, on log alpha
            return -jnp.mean(log_alpha * (log_prob + TARGET_ENTROPY))
        log_alpha, alpha_adam = adam(learned["log_alpha"], jax.grad(alpha_loss)(learned["log_alpha"]),
                                     learned["alpha_adam"], rate, 1e-8)
        learned = masked(hyper["learned_alpha"], learned, log_alpha=log_alpha, alpha_adam=alpha_adam)

        next_actions, next_log_prob = self.sample(learned["params"]["actor"],
                                                  batch["next_observations"], next_key)
        learned = self.critic_step(
            learned, batch, self.next_values(learned, batch, next_actions) - alpha * next_log_prob,
            hyper, rate, 0.5)
        critics = learned["params"]["critics"]

        def actor_loss(actor):  # eq. 7, reparameterised
            actions, log_probs = self.sample(actor, observations, actor_key)
            return jnp.mean(alpha * log_probs
                            - self.critic_values(critics, observations, actions).min(axis=0))
        learned = self.adam_step(learned, "actor", actor_loss, rate)
        return {**learned, "critic_target": polyak(
            critics, learned["critic_target"], hyper["tau"],
            index % hyper["target_update_interval"] == 0)}


def make(settings, task, seeds) -> SacJaxAgents:
    """B SAC agents trained as one JAX program, agent b with `settings[b]` and its random
    stream from `seeds[b]`."""
    return SacJaxAgents(settings, task, seeds)


def load(document, arrays) -> SacJaxAgents:
    """The agents `SacJaxAgents.saved` wrote (a ValueError if the parts do not fit)."""
    return SacJaxAgents.loaded(document, arrays, SacJaxSettings)


def memory(settings, task) -> int:
    """Bytes of one agent (`off_policy_jax.memory`): the actor's two heads without a target,
    three copies."""
    return off_policy_memory(settings, task, 2, 3)


LEARNER = Learner(
    name="sac_jax", title="SAC in JAX, a population in one program: SB3's equations",
    source="Haarnoja et al. (2018), ICML, PMLR 80:1861-1870; Raffin et al. (2021), JMLR 22(268): "
           "stable_baselines3.SAC, in JAX as PureJaxRL (Lu et al. 2022)",
    settings=SacJaxSettings, make=make, load=load, memory=memory,
    fits=fits_continuous("sac_jax"), unavailable=jax_unavailable("sac_jax"),
    checked=CHECKED,
    actions="continuous",
    population=True, shared=shared("sac_jax"), arithmetic=counted(arithmetic))
"""The `sac_jax` learner as the registry holds it (`agent.LEARNERS`)."""
SacJaxAgents.learner = LEARNER
