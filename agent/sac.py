"""SAC (Haarnoja et al. 2018, "Soft Actor-Critic: off-policy maximum entropy deep reinforcement
learning with a stochastic actor", ICML, PMLR 80:1861-1870; the learned temperature of
Haarnoja et al. 2018b, arXiv:1812.05905, section 5) as Stable-Baselines3 implements it
(`stable_baselines3.SAC`), one SB3 model per agent stepped by lwrl's loop
(`agent.off_policy`: how, and the contract's arrays; `agent.stable_baselines`: why the
numbers are SB3's).

The actor is a Gaussian squashed by tanh, a = tanh(mu(s) + sigma(s) n), n ~ N(0, 1), its
log-probability corrected for the squashing (their appendix C, eq. 21). Each gradient step,
on a minibatch of `batch_size` transitions: the entropy coefficient alpha (learned where
`ent_coef_mode` is `auto`, on log alpha, to the target entropy -dim(A) = -1: their eq. 18);
the two critics toward r + gamma (1 - done) (min_i Q_target,i(s', a') - alpha log pi(a'|s')),
a' ~ pi(.|s') (eq. 5, with the clipped double Q of Fujimoto et al. 2018); the actor by
alpha log pi(a|s) - min_i Q_i(s, a) (eq. 7, reparameterised, eq. 11); the target critics'
Polyak update by `tau` every `target_update_interval` gradient steps. A greedy action is
tanh(mu(s)); its C controller (`lwrl export`, `mlp_policy`) is that forward pass.

Defaults: rl-baselines3-zoo's Pendulum-v1 set (20000 steps, learning rate 1e-3;
hyperparams/sac.yml at commit 22e3ff2450fd92033f7f032915e1f64894a09584, `off_policy.ZOO`),
SB3's own for what it does not set.
"""

import dataclasses

from lwrl.agent.arithmetic import BACKWARD_MACS, Count, Counts
from lwrl.agent.dqn import mlp_form
from lwrl.agent.learner_contract import ControllerForm, Learner
from lwrl.agent.off_policy import (ADAM_MACS, CHECKED, OffPolicyAgents, OffPolicySettings, counted,
                                   fits_continuous, network_counts)
from lwrl.agent.off_policy import memory as off_policy_memory
from lwrl.agent.stable_baselines import sb3_unavailable
from lwrl.settings import check_count, check_non_negative, check_positive, setting


@dataclasses.dataclass(frozen=True, kw_only=True)
class SacSettings(OffPolicySettings):
    """SB3's SAC; defaults rl-baselines3-zoo's for Pendulum-v1 (`off_policy.ZOO`),
    else SB3's."""

    TITLE = "SAC"

    ent_coef: float = setting(1.0, per_agent=True)
    """The entropy coefficient alpha: its initial value where learned (SB3's `auto_<value>`;
    `auto` starts at 1), else its fixed value."""
    ent_coef_mode: str = setting("auto", choices=("auto", "fixed"), per_agent=True)
    """`auto`: alpha is learned toward the target entropy (SB3's `ent_coef="auto"`);
    `fixed`: alpha stays `ent_coef`."""
    target_update_interval: int = setting(1, per_agent=True)
    """Gradient steps between the target critics' Polyak updates."""

    def check(self, task) -> None:
        super().check(task)
        check_count("target_update_interval", self.target_update_interval, 1)
        check = check_positive if self.ent_coef_mode == "auto" else check_non_negative
        check("ent_coef", self.ent_coef)

    def sb3_ent_coef(self):
        """`ent_coef` as SB3 takes it: `auto_<value>` (learned from it) or the float."""
        return f"auto_{self.ent_coef!r}" if self.ent_coef_mode == "auto" else float(self.ent_coef)

    def exploration(self) -> str:
        return f"entropy coefficient {self.ent_coef:g} ({self.ent_coef_mode})"


class SacAgents(OffPolicyAgents):
    """B independent SB3 SAC models (`agent.off_policy`)."""

    def _model(self, settings: SacSettings, env, seed):
        from stable_baselines3.common import utils
        return self.sb3.SAC("MlpPolicy", env, ent_coef=settings.sb3_ent_coef(),
                            target_update_interval=settings.target_update_interval, seed=seed,
                            **settings.common(utils))

    @staticmethod
    def _optimizers(model) -> dict:
        optimizers = {"actor_optimizer": model.actor.optimizer,
                      "critic_optimizer": model.critic.optimizer}
        if model.ent_coef_optimizer is not None:
            optimizers["ent_coef_optimizer"] = model.ent_coef_optimizer
        return optimizers

    @staticmethod
    def _tensors(model) -> dict:
        return {} if model.log_ent_coef is None else {"log_ent_coef": model.log_ent_coef}

    def controller(self, b: int) -> ControllerForm:
        """The greedy actor, tanh(mu(s)) (the mean's layers, the log standard deviation's
        head left out), as a plain MLP forward pass in C (`mlp_policy`, whose continuous
        controller takes the last layer's tanh)."""
        actor = self.models[b].actor
        return mlp_form(self.torch, self.torch.nn.Sequential(*actor.latent_pi, actor.mu),
                        self.arrays.weights[b], self.task, "ReLU")


def make(settings, task, seeds) -> SacAgents:
    """B SAC agents, agent b an SB3 model with `settings[b]` seeded with `seeds[b]`."""
    return SacAgents(settings, task, seeds)


def load(document, arrays) -> SacAgents:
    """The agents `SacAgents.saved` wrote (a ValueError if the parts do not fit)."""
    return SacAgents.loaded(document, arrays, SacSettings)


def memory(settings, task) -> int:
    """Bytes of one agent (`off_policy.memory`): the actor's two heads (mean and log standard
    deviation) without a target, four copies."""
    return off_policy_memory(settings, task, 2, 4)


def arithmetic(settings, task, steps: int | None = None) -> Counts:
    """Its counted arithmetic (`Learner.arithmetic`): an actor MLP of `net_arch` with two
    heads (mean and log standard deviation) and two critic MLPs of (s, a), ReLU. A greedy
    decision is the actor's forward pass and a tanh. An agent-step of learning is that
    forward pass with a sample (exp of the log standard deviation, a Gaussian draw's log and
    cos, the tanh: 4 exponentials) and its share of the updates: every `train_freq` steps
    past `learning_starts`, `gradient_steps` gradient steps, each over `batch_size`
    transitions the actor's sample at s' with its log-probability (5 exponentials, the
    squashing's log among them) and the two target critics there, the two critics forward
    and backward (`BACKWARD_MACS`), the actor's sample at s forward and backward through
    both critics, and the optimiser's `ADAM_MACS` per parameter (the entropy coefficient's
    one among them, with its exp), and the target critics' Polyak update (2 per parameter)
    every `target_update_interval` gradient steps. The warm-up's uniform actions are counted
    as the policy's."""
    actor, critic, actor_parameters, critic_parameters, networks = network_counts(settings, task, 2)
    transition = (actor * (2 + BACKWARD_MACS) + critic * (2 + 4 * (1 + BACKWARD_MACS))
                  + Count(0, 10))
    gradient_step = (settings.batch_size * transition
                     + Count(ADAM_MACS * (actor_parameters + 2 * critic_parameters + 1), 1)
                     + Count(2 * 2 * critic_parameters / settings.target_update_interval))
    return counted(settings, actor + Count(0, 1), actor + Count(0, 4), gradient_step, steps,
                   f"{networks} ({__name__}.arithmetic)")


LEARNER = Learner(
    name="sac",
    title="SAC (Stable-Baselines3): a squashed Gaussian actor, two critics, replay, learned entropy",
    source="Haarnoja et al. (2018), ICML, PMLR 80:1861-1870; Raffin et al. (2021), JMLR 22(268): "
           "stable_baselines3.SAC",
    settings=SacSettings, make=make, load=load, memory=memory, fits=fits_continuous("sac"),
    unavailable=sb3_unavailable("sac"),
    checked=CHECKED,
    actions="continuous", arithmetic=arithmetic)
"""The `sac` learner as the registry holds it (`agent.LEARNERS`)."""
SacAgents.learner = LEARNER
