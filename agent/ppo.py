"""PPO (Schulman et al. 2017, "Proximal policy optimization algorithms", arXiv:1707.06347)
with GAE (Schulman et al. 2016, ICLR) as Stable-Baselines3 implements it
(`stable_baselines3.PPO`), one SB3 model per agent, stepped by lwrl's loop
(`agent.stable_baselines`: how, and why the numbers are SB3's).

Per time step, as SB3's `OnPolicyAlgorithm.collect_rollouts` does it: the policy samples the
action at the observation and keeps its value V(s) and log-probability; the transition's
reward goes into the rollout buffer with them (a truncated episode's last reward takes
gamma V(s_T), SB3's bootstrapping from a truncated state). Every `n_steps` transitions the
buffer computes GAE(lambda) advantages and lambda-returns (`compute_returns_and_advantage`,
bootstrapping from V of the latest observation) and `train()` runs `n_epochs` epochs of
minibatches of `batch_size` on the clipped surrogate objective with value and entropy terms.

In the contract's terms: `q` holds the policy's action log-probabilities at the latest
observation (the preferences it acts greedily on, its mode); `delta` the TD error
r + gamma d V(s') - V(s) of the latest transition (NaN where there is none); the state values
are the critic's; `weights` the policy's parameters (actor and critic), flattened; the greedy
controller is the actor as C (`mlp_policy` in `export/templates`).
"""

import dataclasses
import math

import numpy as np

from lwrl.agent.arithmetic import (BACKWARD_MACS, OPTIMISER_MACS, Count, Counts, mlp_forward,
                                   mlp_parameters)
from lwrl.agent.dqn import mlp_form
from lwrl.agent.learner_contract import ControllerForm, Learner
from lwrl.agent.stable_baselines import (ModelAgents, ModelSettings, buffer_bytes,
                                         load_arrays, network_bytes, sb3_unavailable,
                                         policy_features, saved_arrays, sequential_forward,
                                         td_error)
from lwrl.settings import check_count, check_positive, check_unit_interval, setting

BUFFER = ("observations", "actions", "rewards", "episode_starts", "values", "log_probs")
"""The rollout buffer's arrays a saved agent keeps (SB3's `RolloutBuffer`'s)."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class PpoSettings(ModelSettings):
    """SB3's PPO (one environment per agent); defaults SB3's (rl-baselines3-zoo's for a task it
    has not tuned)."""

    learning_rate: float = setting(3e-4, per_agent=True)
    """Adam's step size."""
    max_grad_norm: float = setting(0.5, per_agent=True)
    """Gradients are clipped to this norm."""
    n_steps: int = setting(2048)
    """Transitions per rollout (rl-baselines3-zoo's n_envs x n_steps, with one environment)."""
    batch_size: int = setting(64, per_agent=True)
    """Transitions per minibatch."""
    n_epochs: int = setting(10, per_agent=True)
    """Passes over each rollout."""
    gae_lambda: float = setting(0.95, per_agent=True)
    """GAE's lambda in [0, 1]."""
    clip_range: float = setting(0.2, per_agent=True)
    """Clipping of the probability ratio."""
    clip_range_schedule: str = setting("constant", choices=("constant", "linear"), per_agent=True)
    """`constant`, or `linear` to 0 over `timesteps` (rl-baselines3-zoo's `lin_`)."""
    ent_coef: float = setting(0.0, per_agent=True)
    """Weight of the entropy bonus."""
    vf_coef: float = setting(0.5, per_agent=True)
    """Weight of the value loss."""

    def check(self, task) -> None:
        super().check(task)
        for name in ("n_steps", "batch_size", "n_epochs"):
            check_count(name, getattr(self, name), 1)
        if self.n_steps < 2:
            raise ValueError(f"n_steps must be at least 2 (advantages are normalised over a "
                             f"rollout); got {self.n_steps}")
        check_unit_interval("gae_lambda", self.gae_lambda)
        check_positive("clip_range", self.clip_range)
        for name in ("ent_coef", "vf_coef"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and 0 <= value < float("inf")):
                raise ValueError(f"{name} must be a finite number >= 0; got {value!r}")

    def label(self) -> str:
        return f"ppo-{self.net_arch.replace(',', 'x')}-lr{self.learning_rate:g}-t{self.timesteps}"

    def describe(self, dim: int) -> str:
        return (f"PPO (Stable-Baselines3), MLP {self.net_arch}, lr {self.learning_rate:g} "
                f"({self.learning_rate_schedule}), gamma {self.gamma:g}, GAE lambda "
                f"{self.gae_lambda:g}, rollouts of {self.n_steps}, {self.n_epochs} epochs of "
                f"minibatches of {self.batch_size}, clip {self.clip_range:g} "
                f"({self.clip_range_schedule}), entropy {self.ent_coef:g}, {self.timesteps} steps")


class PpoAgents(ModelAgents):
    """B independent SB3 PPO models (see the module)."""

    COUNTERS = ("num_timesteps", "_n_updates", "_current_progress_remaining")
    PENDING = "added"

    def _model(self, settings: PpoSettings, env, seed):
        from stable_baselines3.common import utils
        clip = (utils.LinearSchedule(settings.clip_range, 0.0, 1.0)
                if settings.clip_range_schedule == "linear" else settings.clip_range)
        return self.sb3.PPO(
            "MlpPolicy", env, learning_rate=settings.schedule(settings.learning_rate, utils),
            n_steps=settings.n_steps, batch_size=settings.batch_size, n_epochs=settings.n_epochs,
            gamma=settings.gamma, gae_lambda=settings.gae_lambda, clip_range=clip,
            ent_coef=settings.ent_coef, vf_coef=settings.vf_coef,
            max_grad_norm=settings.max_grad_norm, policy_kwargs={"net_arch": settings.layers()},
            seed=seed, device="cpu")

    @staticmethod
    def _networks(model):
        return [model.policy]

    def _fresh(self, b: int) -> dict:
        """The agent's place in the loop: learning, inside an episode (`open`), the latest
        step's observation, action, value, log-probability and start flag (its rollout entry
        once the reward is in), whether that went into the buffer, the draws to give back."""
        return {"learning": True, "open": False, "observation": np.zeros((1, self.dim)),
                "action": np.zeros((1, 1), dtype=np.int64), "value": None, "log_prob": None,
                "start": np.ones(1, dtype=bool), "added": False, "undo": None}

    def _forward(self, b: int, observation, deterministic: bool):
        """`ActorCriticPolicy.forward` on the observation, with the distribution's logits; the
        networks op for op (`sequential_forward`). A greedy step builds no distribution:
        `Categorical(logits=l)` keeps l - logsumexp(l), SB3's mode is the argmax of its
        softmax (`CategoricalDistribution.mode`), its log-probability the normalised logit of
        the action (`Categorical.log_prob`)."""
        torch, policy = self.torch, self.models[b].policy
        extractor = policy.mlp_extractor
        with torch.no_grad():
            features = policy_features(self.sb3, policy, self._tensor(observation))
            values = sequential_forward(torch, [*extractor.value_net, policy.value_net], features)
            latent_pi = sequential_forward(torch, extractor.policy_net, features)
            if deterministic:
                raw = sequential_forward(torch, [policy.action_net], latent_pi)
                logits = raw - raw.logsumexp(dim=-1, keepdim=True)
                actions = torch.argmax(torch.nn.functional.softmax(logits, dim=-1), dim=1)
                log_prob = logits.gather(-1, actions.unsqueeze(-1)).squeeze(-1)
            else:
                distribution = policy._get_action_dist_from_latent(latent_pi)
                actions = distribution.get_actions(deterministic=False)
                log_prob = distribution.log_prob(actions)
                logits = distribution.distribution.logits
        return actions.reshape((-1, *policy.action_space.shape)), values, log_prob, logits

    def _step_one(self, b, first, reward, discount, observation, learn, greedy) -> int:
        model, own, arrays = self.models[b], self.own[b], self.arrays
        previous = np.nan if own["value"] is None else float(own["value"][0, 0])  # V(s)
        if self._arrive(b, first, reward, discount, observation, learn, previous):
            return 0
        deterministic = self._acts_greedily(b, learn, greedy)
        if not deterministic:
            own["undo"] = self.states[b].torch_snapshot()
        actions, values, log_prob, logits = self._forward(b, observation, deterministic)
        arrays.q[b] = logits[0].numpy()
        if not first:
            arrays.delta[b] = td_error(reward, discount, model.gamma, float(values[0, 0]), previous)
        own.update(observation=observation, action=actions.cpu().numpy().reshape(-1, 1),
                   value=values, log_prob=log_prob, start=np.array([first]))
        return int(actions[0])

    def _record(self, b, reward, discount, observation) -> None:
        """SB3's step after `env.step`: the rollout entry; at a full rollout, the advantages
        (bootstrapped from V of this observation) and `train()`."""
        model, own = self.models[b], self.own[b]
        buffer = model.rollout_buffer
        buffer.add(own["observation"], own["action"], np.array([reward], dtype=np.float32),
                   own["start"], own["value"], own["log_prob"])
        own["added"] = discount > 0.0  # its reward bootstraps, should the episode end here
        model.num_timesteps += 1
        if not buffer.full:
            return
        with self.torch.no_grad():
            last = model.policy.predict_values(self._tensor(observation))
        buffer.compute_returns_and_advantage(last_values=last, dones=np.array([discount == 0.0]))
        model._update_current_progress_remaining(model.num_timesteps, model._total_timesteps)
        model.train()
        model.policy.set_training_mode(False)
        buffer.reset()
        own["added"] = False  # the rollout is spent: its last advantage is the same either way
        self._trained(b)
        self._horizon_reached(b)

    def _truncated(self, b) -> None:
        """As `ModelAgents._truncated`: the last reward takes gamma V(s_T)."""
        model, own = self.models[b], self.own[b]
        if own["undo"] is not None:
            self.states[b].restore(own["undo"])
        if own["added"]:
            rewards = model.rollout_buffer.rewards[model.rollout_buffer.pos - 1]
            rewards[0] += model.gamma * own["value"][0]
        own["added"] = False

    def action_values(self, states, weights=None) -> np.ndarray:
        """The policy's action log-probabilities, `(B, ..., A)` (or `(..., A)` for `weights`)."""
        def values(networks, flat):
            policy = networks[0]
            latent_pi = policy.mlp_extractor.forward_actor(policy.extract_features(self._tensor(flat)))
            return policy._get_action_dist_from_latent(latent_pi).distribution.logits.numpy().astype(np.float64)
        return self._over_agents(states, weights, values)

    def state_values(self, states, weights=None) -> np.ndarray:
        """The critic's V(s), `(B, ...)` (or `(...)` for `weights`)."""
        return self._over_agents(states, weights, lambda networks, flat: networks[0].predict_values(
            self._tensor(flat)).numpy().astype(np.float64))[..., 0]

    def controller(self, b: int) -> ControllerForm:
        """The greedy actor, the argmax of its logits, as a plain MLP forward pass in C
        (`mlp_policy`)."""
        import torch
        policy = self.models[b].policy
        actor = torch.nn.Sequential(*policy.mlp_extractor.policy_net, policy.action_net)
        return mlp_form(torch, actor, self.arrays.weights[b], self.task, "Tanh")

    def _buffer_saved(self, b: int, prefix: str) -> dict:
        return saved_arrays(self.models[b].rollout_buffer, prefix, BUFFER)

    def _buffer_loaded(self, b: int, prefix: str, arrays: dict) -> None:
        load_arrays(self.models[b].rollout_buffer, prefix, arrays, BUFFER)


def make(settings, task, seeds) -> PpoAgents:
    """B PPO agents, agent b an SB3 model with `settings[b]` seeded with `seeds[b]`."""
    return PpoAgents(settings, task, seeds)


def load(document, arrays) -> PpoAgents:
    """The agents `PpoAgents.saved` wrote (a ValueError if the parts do not fit)."""
    return PpoAgents.loaded(document, arrays, PpoSettings)


def memory(settings, task) -> int:
    """Bytes of one agent: its rollout buffer, and the policy with Adam's two moments and
    its gradients (four copies of the parameters, the actor's and the critic's)."""
    dim = len(task.state_names)
    layers = settings.layers()
    return (buffer_bytes(settings.n_steps, dim, 1, 7)
            + network_bytes(dim, layers, task.action.n, 4) + network_bytes(dim, layers, 1, 4))


def arithmetic(settings, task, steps: int | None = None) -> Counts:
    """Its counted arithmetic (`Learner.arithmetic`; `ppo_jax`'s too): separate actor and
    critic MLPs of `net_arch`, tanh. A greedy decision is the actor's forward pass (the
    argmax of its logits). An agent-step of learning is the actor's and the critic's forward
    passes for the action (A exponentials for the log-softmax) and its share of the updates:
    each rollout of `n_steps` transitions is learned `n_epochs` times, each transition in an
    epoch a forward and a backward pass of both networks (3 forward passes' multiply-adds,
    `BACKWARD_MACS`) with their tanh, the log-softmax's and the entropy's A exponentials
    each and the probability ratio's one, and each minibatch of `batch_size` one gradient
    step of `OPTIMISER_MACS` per parameter. Amortised over `steps` steps of learning (the
    updates of whole rollouts in them), or per step of a long run where None. GAE's few
    operations per transition are left out."""
    dim, actions, layers = len(task.state_names), task.action.n, settings.layers()
    actor_sizes, critic_sizes = [dim, *layers, actions], [dim, *layers, 1]
    actor, critic = mlp_forward(actor_sizes, True), mlp_forward(critic_sizes, True)
    per_transition = Count((1 + BACKWARD_MACS) * (actor.macs + critic.macs),
                           actor.exps + critic.exps + 2 * actions + 1)
    minibatches = math.ceil(settings.n_steps / settings.batch_size)
    parameters = mlp_parameters(actor_sizes) + mlp_parameters(critic_sizes)
    rollout = settings.n_epochs * (settings.n_steps * per_transition
                                   + Count(minibatches * OPTIMISER_MACS * parameters))
    rollouts_per_step = (steps // settings.n_steps) / steps if steps else 1 / settings.n_steps
    update = rollout * rollouts_per_step
    return Counts(actor, actor + critic + Count(0, actions) + update, update,
                  f"actor {'-'.join(map(str, actor_sizes))} and critic "
                  f"{'-'.join(map(str, critic_sizes))} tanh ({parameters} parameters); "
                  f"{settings.n_epochs} epochs x {minibatches} minibatches of "
                  f"{settings.batch_size} per rollout of {settings.n_steps} "
                  f"({__name__}.arithmetic)")


ZOO_SETS = {
    "MountainCar-v0": dict(timesteps=1_000_000, n_steps=16 * 16, gae_lambda=0.98, gamma=0.99,
                           n_epochs=4, ent_coef=0.0),
    "CartPole-v1": dict(timesteps=100_000, n_steps=8 * 32, batch_size=256, gae_lambda=0.8,
                        gamma=0.98, n_epochs=20, ent_coef=0.0, learning_rate=1e-3,
                        learning_rate_schedule="linear", clip_range=0.2,
                        clip_range_schedule="linear"),
    "Acrobot-v1": dict(timesteps=1_000_000, n_steps=16 * 256, gae_lambda=0.94, gamma=0.99,
                       n_epochs=4, ent_coef=0.0),
}
"""rl-baselines3-zoo's PPO sets (policy MlpPolicy, n_steps = n_envs x n_steps;
`stable_baselines.ZOO`)."""
CHECKED = dict(net_arch="16,16", n_steps=32, batch_size=16, n_epochs=2)
"""What the contract's checks run PPO with (`Learner.checked`): small networks, and rollouts
of 32 steps, so that updates come within the checks' 120 steps."""

LEARNER = Learner(
    name="ppo", title="PPO (Stable-Baselines3): MLP actor and critic, clipped surrogate, GAE",
    source="Schulman et al. (2017), arXiv:1707.06347; Raffin et al. (2021), JMLR 22(268): "
           "stable_baselines3.PPO",
    settings=PpoSettings, make=make, load=load, memory=memory,
    unavailable=sb3_unavailable("ppo"),
    tuned=ZOO_SETS, checked=CHECKED, arithmetic=arithmetic)
"""The `ppo` learner as the registry holds it (`agent.LEARNERS`)."""
PpoAgents.learner = LEARNER
