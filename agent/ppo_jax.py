"""PPO (Schulman et al. 2017, arXiv:1707.06347) with GAE (Schulman et al. 2016) as
Stable-Baselines3 computes it (`stable_baselines3.PPO`, `agent.ppo`), written in JAX and
trained as a whole population in one jitted program (`runners.population`,
`agent.jax_population`): the same settings as `ppo`, the same equations, PyTorch's Adam.

Per step (SB3's `OnPolicyAlgorithm.collect_rollouts`): the policy samples a ~ pi(.|s) and
keeps V(s) and log pi(a|s); the transition's reward goes into the rollout buffer with them,
a truncated episode's reward taking gamma V(s_T) of its last observation (SB3's
bootstrapping from a time limit: the task's `truncated`, apart from `terminated`). After
`n_steps` transitions, GAE(lambda) (`RolloutBuffer.compute_returns_and_advantage`):
delta_t = r_t + gamma V(s_t+1) (1 - start_t+1) - V(s_t), A_t = delta_t + gamma lambda
(1 - start_t+1) A_t+1, returns A + V; then `n_epochs` passes over the rollout in random
minibatches of `batch_size` (`PPO.train`): advantages normalised per minibatch, loss
-mean(min(A rho, A clip(rho, 1 - eps, 1 + eps))) + c_v mean((R - V)^2) - c_e mean(H),
gradients clipped to `max_grad_norm`, one Adam step (eps 1e-5, SB3's for its policies).
Networks (SB3's `MlpPolicy` for PPO): separate actor and critic MLPs of `net_arch`, tanh,
orthogonal weights with gain sqrt(2), 0.01 for the action logits and 1 for the value, zero
biases; float32, observations cast to float32 as SB3 casts them.

What differs from `ppo`, and why (docs/deep_baselines): the random streams (JAX's, not
PyTorch's and NumPy's), so one agent's numbers are not SB3's, only drawn from the same
distributions; and the rollout's minibatches must divide it (`n_steps` a multiple of
`batch_size`), so that every minibatch has one shape in the compiled program (SB3 ends an
epoch with a smaller one).
"""

import dataclasses

import numpy as np

from lwrl.agent.jax_population import (PopulationAgents, Program, adam, adam_init,
                                       clip_by_norm, jax_unavailable, hyper_arrays, masked, mlp,
                                       mlp_init)
from lwrl.agent.learner_contract import Learner
from lwrl.agent.observation_normalisation import ObservationNormalisation, counted
from lwrl.agent.ppo import CHECKED, ZOO_SETS, PpoSettings, arithmetic
from lwrl.agent.stable_baselines import network_bytes
from lwrl.settings import setting

HYPER = ("learning_rate", "gamma", "gae_lambda", "clip_range", "ent_coef", "vf_coef",
         "max_grad_norm")
"""The per-agent settings the program takes as arrays; the schedules as 0/1 flags."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class PpoJaxSettings(ObservationNormalisation, PpoSettings):
    """`ppo`'s settings, field for field, and the observation normalisation
    (`agent.observation_normalisation`); a batch shares those that shape the program."""

    batch_size: int = setting(64)
    """Transitions per minibatch (a divisor of `n_steps`)."""
    n_epochs: int = setting(10)
    """Passes over each rollout."""

    def check(self, task) -> None:
        super().check(task)
        if self.n_steps % self.batch_size:
            raise ValueError(f"n_steps must be a multiple of batch_size for ppo_jax (one "
                             f"minibatch shape); got n_steps {self.n_steps}, batch_size "
                             f"{self.batch_size}")

    def label(self) -> str:
        return "ppo_jax" + super().label().removeprefix("ppo")

    def describe(self, dim: int) -> str:
        return super().describe(dim).replace("(Stable-Baselines3)", "(JAX population)", 1)


class PpoJaxAgents(PopulationAgents):
    """B PPO agents as one pytree (see the module)."""

    def _sizes(self):
        layers = self.settings[0].layers()
        return [self.dim, *layers]

    def initial_state(self, key):
        jax, jnp = self.jax, self.jnp
        settings, sizes = self.settings[0], self._sizes()
        actor_key, critic_key, key = jax.random.split(key, 3)
        gains = [np.sqrt(2.0)] * (len(sizes) - 1)
        params = {"actor": mlp_init(actor_key, sizes + [self.task.action.n], gains + [0.01], True),
                  "critic": mlp_init(critic_key, sizes + [1], gains + [1.0], True)}
        n, dim = settings.n_steps, self.dim
        buffer = {"observations": jnp.zeros((n, dim), jnp.float32),
                  "actions": jnp.zeros(n, jnp.int32), "rewards": jnp.zeros(n, jnp.float32),
                  "starts": jnp.zeros(n, jnp.float32), "values": jnp.zeros(n, jnp.float32),
                  "log_probs": jnp.zeros(n, jnp.float32)}
        return {"params": params, "adam": adam_init(params), "buffer": buffer,
                "start": jnp.ones((), jnp.float32), "key": key}

    @staticmethod
    def weight_tree(state):
        return state["params"]

    def forward(self, params, observation):
        """`(log pi(.|s) (..., A), V(s) (...))` of the actor and the critic `params` at
        observations `(..., d)`, in float32 (SB3's `ActorCriticPolicy.forward`)."""
        jax, jnp = self.jax, self.jnp
        x = observation.astype(jnp.float32)
        logits = mlp(params["actor"], x, jnp.tanh)
        return jax.nn.log_softmax(logits), mlp(params["critic"], x, jnp.tanh)[..., 0]

    def action_values(self, states, weights=None) -> np.ndarray:
        """The policy's action log-probabilities, `(B, ..., A)` (or `(..., A)` for `weights`)."""
        return self.over_agents(states, weights, lambda params, x: self.forward(params, x)[0])

    def state_values(self, states, weights=None) -> np.ndarray:
        """The critic's V(s), `(B, ...)` (or `(...)` for `weights`)."""
        return self.over_agents(states, weights, lambda params, x: self.forward(params, x)[1])

    def program(self) -> Program:
        jax, jnp = self.jax, self.jnp
        settings = self.settings[0]
        n_steps, batch_size, epochs = settings.n_steps, settings.batch_size, settings.n_epochs
        hyper = hyper_arrays(self.settings, HYPER)
        hyper["learning_steps"] = np.full(len(self.settings), -(-settings.timesteps // n_steps) * n_steps)
        hyper["linear_clip"] = np.array([s.clip_range_schedule == "linear" for s in self.settings])

        forward = self.forward

        def act(state, observation, key, hyper, greedy, clock):
            log_probs, value = forward(state["params"], observation)
            action = jnp.where(greedy, jnp.argmax(log_probs),
                               jax.random.categorical(key, log_probs)).astype(jnp.int32)
            return action, {"value": value, "log_prob": log_probs[action]}

        def record(state, extras, observation, action, reward, terminated, truncated,
                   final_observation, hyper, clock, write):
            """The transition into the rollout buffer at the agent's place in it."""
            _, final_value = forward(state["params"], final_observation)
            reward = reward.astype(jnp.float32) + jnp.where(
                truncated, hyper["gamma"] * final_value, 0.0).astype(jnp.float32)
            slot = clock % n_steps
            entry = {"observations": observation.astype(jnp.float32), "actions": action,
                     "rewards": reward, "starts": state["start"], "values": extras["value"],
                     "log_probs": extras["log_prob"]}
            buffer = {name: state["buffer"][name].at[slot].set(
                jnp.where(write, entry[name], state["buffer"][name][slot])) for name in entry}
            ended = (terminated | truncated).astype(jnp.float32)
            return {**state, "buffer": buffer, "start": jnp.where(write, ended, state["start"])}

        def advantages(buffer, last_value, last_start, hyper):
            """GAE(lambda) backwards over the rollout (`compute_returns_and_advantage`)."""
            gamma, lam = hyper["gamma"].astype(jnp.float32), hyper["gae_lambda"].astype(jnp.float32)
            next_values = jnp.append(buffer["values"][1:], last_value)
            next_non_terminal = 1.0 - jnp.append(buffer["starts"][1:], last_start)
            deltas = buffer["rewards"] + gamma * next_values * next_non_terminal - buffer["values"]

            def backwards(gae, inputs):
                delta, non_terminal = inputs
                gae = delta + gamma * lam * non_terminal * gae
                return gae, gae
            _, result = jax.lax.scan(backwards, jnp.zeros((), jnp.float32),
                                     (deltas, next_non_terminal), reverse=True)
            return result

        def loss(params, batch, clip, hyper):
            log_probs, values = forward(params, batch["observations"])
            log_prob = jnp.take_along_axis(log_probs, batch["actions"][:, None], axis=1)[:, 0]
            entropy = -jnp.sum(jnp.exp(log_probs) * log_probs, axis=1)
            advantage = batch["advantages"]
            advantage = (advantage - advantage.mean()) / (jnp.std(advantage, ddof=1) + 1e-8)
            ratio = jnp.exp(log_prob - batch["log_probs"])
            policy_loss = -jnp.minimum(advantage * ratio,
                                       advantage * jnp.clip(ratio, 1.0 - clip, 1.0 + clip)).mean()
            value_loss = jnp.mean((batch["returns"] - values) ** 2)
            return (policy_loss - hyper["ent_coef"] * jnp.mean(entropy)
                    + hyper["vf_coef"] * value_loss)

        def update(state, next_observation, next_start, hyper, clock, due):
            """`PPO.train` after the rollout that ended at step `clock`."""
            buffer = state["buffer"]
            _, last_value = forward(state["params"], next_observation)
            advantage = advantages(buffer, last_value, next_start, hyper)
            data = {**buffer, "advantages": advantage, "returns": advantage + buffer["values"]}
            remaining = 1.0 - (clock + 1) / settings.timesteps  # SB3's progress remaining
            rate = hyper["learning_rate"] * jnp.where(hyper["linear_rate"], remaining, 1.0)
            clip = hyper["clip_range"] * jnp.where(hyper["linear_clip"], remaining, 1.0)

            def minibatch(carry, indices):
                params, optimiser = carry
                batch = jax.tree.map(lambda x: x[indices], data)
                grads = jax.grad(loss)(params, batch, clip, hyper)
                grads = clip_by_norm(grads, hyper["max_grad_norm"])
                return adam(params, grads, optimiser, rate, 1e-5), None

            def epoch(carry, epoch_key):
                order = jax.random.permutation(epoch_key, n_steps).reshape(-1, batch_size)
                return jax.lax.scan(minibatch, carry, order)[0], None

            key, epochs_key = jax.random.split(state["key"])
            (params, optimiser), _ = jax.lax.scan(
                epoch, (state["params"], state["adam"]), jax.random.split(epochs_key, epochs))
            return masked(due, state, params=params, adam=optimiser, key=key)

        return Program(act=act, record=record, update=update,
                       update_due=lambda hyper, clock: (clock + 1) % n_steps == 0, hyper=hyper)


def make(settings, task, seeds) -> PpoJaxAgents:
    """B PPO agents trained as one JAX program, agent b with `settings[b]` and its random
    stream from `seeds[b]`."""
    return PpoJaxAgents(settings, task, seeds)


def load(document, arrays) -> PpoJaxAgents:
    """The agents `PpoJaxAgents.saved` wrote (a ValueError if the parts do not fit)."""
    return PpoJaxAgents.loaded(document, arrays, PpoJaxSettings)


def memory(settings, task) -> int:
    """Bytes of one agent: its rollout buffer (float32) and the actor and critic with Adam's
    two moments (three copies of the parameters)."""
    dim, layers = len(task.state_names), settings.layers()
    return (4 * settings.n_steps * (dim + 5) + network_bytes(dim, layers, task.action.n, 3)
            + network_bytes(dim, layers, 1, 3))


LEARNER = Learner(
    name="ppo_jax", title="PPO in JAX, a population in one program: SB3's equations",
    source="Schulman et al. (2017), arXiv:1707.06347; Raffin et al. (2021), JMLR 22(268): "
           "stable_baselines3.PPO, in JAX as PureJaxRL (Lu et al. 2022)",
    settings=PpoJaxSettings, make=make, load=load, memory=memory,
    unavailable=jax_unavailable("ppo_jax"), tuned=ZOO_SETS, checked=CHECKED, population=True,
    arithmetic=counted(arithmetic))
"""The `ppo_jax` learner as the registry holds it (`agent.LEARNERS`)."""
PpoJaxAgents.learner = LEARNER
