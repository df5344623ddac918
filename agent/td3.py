"""TD3 (Fujimoto, van Hoof and Meger 2018, "Addressing function approximation error in
actor-critic methods", ICML, PMLR 80:1587-1596) as Stable-Baselines3 implements it
(`stable_baselines3.TD3`), one SB3 model per agent stepped by lwrl's loop
(`agent.off_policy`: how, and the contract's arrays; `agent.stable_baselines`: why the
numbers are SB3's).

A deterministic actor mu(s) (tanh output), explored with Gaussian action noise of standard
deviation `noise_std` (rl-baselines3-zoo's `noise_type: normal`), clipped to [-1, 1]. Each
gradient step, on a minibatch of `batch_size` transitions: the two critics toward
r + gamma (1 - done) min_i Q_target,i(s', a'), a' = clip(mu_target(s') + clip(e, -c, c),
-1, 1), e ~ N(0, `target_policy_noise`^2), c = `target_noise_clip` (their clipped double Q,
eq. 10, and target policy smoothing, eq. 14); every `policy_delay` gradient steps the actor
along the gradient of Q_1(s, mu(s)) (the deterministic policy gradient) and the target
networks' Polyak update by `tau` (delayed policy updates, section 5.2). A greedy action is
mu(s); its C controller (`lwrl export`, `mlp_policy`) is that forward pass.

Defaults: rl-baselines3-zoo's Pendulum-v1 set (hyperparams/td3.yml at commit
22e3ff2450fd92033f7f032915e1f64894a09584, `off_policy.ZOO`), SB3's own for what it does not set.
"""

import dataclasses

import numpy as np

from lwrl.agent.arithmetic import BACKWARD_MACS, Count, Counts
from lwrl.agent.dqn import mlp_form
from lwrl.agent.learner_contract import ControllerForm, Learner
from lwrl.agent.off_policy import (ADAM_MACS, CHECKED, OffPolicyAgents, OffPolicySettings, counted,
                                   fits_continuous, network_counts)
from lwrl.agent.off_policy import memory as off_policy_memory
from lwrl.agent.stable_baselines import sb3_unavailable
from lwrl.settings import check_count, check_non_negative, setting


@dataclasses.dataclass(frozen=True, kw_only=True)
class Td3Settings(OffPolicySettings):
    """SB3's TD3; defaults rl-baselines3-zoo's for Pendulum-v1 (`off_policy.ZOO`),
    else SB3's."""

    TITLE = "TD3"

    net_arch: str = setting("400,300")
    """Hidden layers' widths of the actor and of each critic, comma-separated (SB3's
    `net_arch`)."""
    gamma: float = setting(0.98, per_agent=True)
    """Discount factor gamma in [0, 1]."""
    buffer_size: int = setting(200_000)
    """Transitions the replay buffer holds."""
    learning_starts: int = setting(10_000, per_agent=True)
    """Steps of uniformly random actions before learning starts."""
    noise_std: float = setting(0.1, per_agent=True)
    """Standard deviation of the Gaussian action noise, in action units ([-1, 1] spans the
    actuator's range; rl-baselines3-zoo's `noise_std`, SB3's `NormalActionNoise`)."""
    policy_delay: int = setting(2, per_agent=True)
    """Critic updates per actor (and target) update."""
    target_policy_noise: float = setting(0.2, per_agent=True)
    """Standard deviation of the target policy's smoothing noise."""
    target_noise_clip: float = setting(0.5, per_agent=True)
    """The smoothing noise is clipped to +-this."""

    def check(self, task) -> None:
        super().check(task)
        check_count("policy_delay", self.policy_delay, 1)
        for name in ("noise_std", "target_policy_noise", "target_noise_clip"):
            check_non_negative(name, getattr(self, name))

    def exploration(self) -> str:
        return (f"action noise {self.noise_std:g}, policy delay {self.policy_delay}, target "
                f"noise {self.target_policy_noise:g} clipped to {self.target_noise_clip:g}")


class Td3Agents(OffPolicyAgents):
    """B independent SB3 TD3 models (`agent.off_policy`)."""

    def _model(self, settings: Td3Settings, env, seed):
        from stable_baselines3.common import noise, utils
        action_noise = noise.NormalActionNoise(mean=np.zeros(1), sigma=settings.noise_std * np.ones(1))
        return self.sb3.TD3("MlpPolicy", env, action_noise=action_noise,
                            policy_delay=settings.policy_delay,
                            target_policy_noise=settings.target_policy_noise,
                            target_noise_clip=settings.target_noise_clip, seed=seed,
                            **settings.common(utils))

    @staticmethod
    def _optimizers(model) -> dict:
        return {"actor_optimizer": model.actor.optimizer, "critic_optimizer": model.critic.optimizer}

    def controller(self, b: int) -> ControllerForm:
        """The deterministic actor mu(s), as a plain MLP forward pass in C (`mlp_policy`,
        whose continuous controller takes the last layer's tanh, the actor's own)."""
        return mlp_form(self.torch, self.models[b].actor.mu, self.arrays.weights[b], self.task,
                        "ReLU")


def make(settings, task, seeds) -> Td3Agents:
    """B TD3 agents, agent b an SB3 model with `settings[b]` seeded with `seeds[b]`."""
    return Td3Agents(settings, task, seeds)


def load(document, arrays) -> Td3Agents:
    """The agents `Td3Agents.saved` wrote (a ValueError if the parts do not fit)."""
    return Td3Agents.loaded(document, arrays, Td3Settings)


def memory(settings, task) -> int:
    """Bytes of one agent (`off_policy.memory`): the actor with its target, five copies."""
    return off_policy_memory(settings, task, 1, 5)


def arithmetic(settings, task, steps: int | None = None) -> Counts:
    """Its counted arithmetic (`Learner.arithmetic`): an actor MLP of `net_arch` with a tanh
    output and two critic MLPs of (s, a), ReLU. A greedy decision is the actor's forward
    pass (its tanh one exponential). An agent-step of learning is that forward pass with the
    action noise's Gaussian draw (a log and a cos) and its share of the updates: every
    `train_freq` steps past `learning_starts`, `gradient_steps` gradient steps, each over
    `batch_size` transitions the target actor at s' with its smoothing noise's draw and the
    two target critics there, the two critics forward and backward (`BACKWARD_MACS`), and
    the critics' optimiser step (`ADAM_MACS` per parameter); every `policy_delay` of them the
    actor forward and backward through the first critic over the minibatch, the actor's
    optimiser step and the target networks' Polyak update (2 per parameter). The warm-up's
    uniform actions are counted as the policy's."""
    actor, critic, actor_parameters, critic_parameters, networks = network_counts(settings, task, 1)
    actor = actor + Count(0, 1)  # the output's tanh
    critics = (settings.batch_size * (actor + Count(0, 2) + critic * (2 + 2 * (1 + BACKWARD_MACS)))
               + Count(ADAM_MACS * 2 * critic_parameters))
    policy = (settings.batch_size * (actor + critic) * (1 + BACKWARD_MACS)
              + Count((ADAM_MACS + 2) * actor_parameters + 2 * 2 * critic_parameters))
    return counted(settings, actor, actor + Count(0, 2), critics + policy * (1 / settings.policy_delay),
                   steps, f"{networks} ({__name__}.arithmetic)")


LEARNER = Learner(
    name="td3", title="TD3 (Stable-Baselines3): a deterministic actor, two critics, replay, delayed updates",
    source="Fujimoto et al. (2018), ICML, PMLR 80:1587-1596; Raffin et al. (2021), JMLR 22(268): "
           "stable_baselines3.TD3",
    settings=Td3Settings, make=make, load=load, memory=memory, fits=fits_continuous("td3"),
    unavailable=sb3_unavailable("td3"),
    checked=CHECKED,
    actions="continuous", arithmetic=arithmetic)
"""The `td3` learner as the registry holds it (`agent.LEARNERS`)."""
Td3Agents.learner = LEARNER
