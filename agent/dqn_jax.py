"""DQN (Mnih et al. 2015, Nature 518, 529-533) as Stable-Baselines3 computes it
(`stable_baselines3.DQN`, `agent.dqn`), written in JAX and trained as a whole population in
one jitted program (`runners.population`, `agent.jax_population`): the same settings as
`dqn`, the same equations, PyTorch's Adam.

Per step c of an agent (SB3's `OffPolicyAlgorithm.collect_rollouts` and `DQN._on_step`): the
action at the observation is uniform before `learning_starts`, then epsilon-greedy on Q with
epsilon from the linear schedule (initial to final over `exploration_fraction` of
`timesteps`) at the progress after the previous step; the transition goes into the replay
buffer as (s, a, r, s', terminal), s' the episode's last observation where it ended, a
time limit not terminal (SB3's `handle_timeout_termination`); every
`target_update_interval` steps the target network moves to tau q + (1 - tau) target. Every
`train_freq` steps past `learning_starts`, `gradient_steps` updates (`DQN.train`): a batch of
`batch_size` transitions drawn uniformly with replacement, Huber loss (delta 1) of Q(s, a)
against r + gamma (1 - terminal) max_a' Q_target(s', a'), gradients clipped to
`max_grad_norm`, one Adam step (PyTorch's defaults, eps 1e-8) at the learning rate of the
progress then. Network (SB3's `QNetwork`): an MLP of `net_arch`, ReLU, PyTorch's default
initialisation, float32.

What differs from `dqn`, and why (docs/deep_baselines): the random streams (JAX's), and the
replay buffer keeps float32 observations, the values SB3's network reads (SB3 keeps the
float64 observations and casts each batch).
"""

import dataclasses

import numpy as np

from lwrl.agent.dqn import CHECKED, ZOO_SETS, DqnSettings, arithmetic
from lwrl.agent.jax_population import (PopulationAgents, Program, adam, adam_init,
                                       clip_by_norm, jax_unavailable, mlp, mlp_init, polyak,
                                       replay_add, replay_buffer, replay_bytes, replay_capacity,
                                       replay_due, replay_gradient_steps, replay_hyper,
                                       replay_sample, replay_update)
from lwrl.agent.learner_contract import Learner
from lwrl.agent.observation_normalisation import ObservationNormalisation, counted
from lwrl.agent.stable_baselines import network_bytes
from lwrl.settings import setting

HYPER = ("learning_rate", "gamma", "max_grad_norm", "learning_starts", "tau", "train_freq",
         "target_update_interval", "exploration_fraction", "exploration_initial_eps",
         "exploration_final_eps")
"""The per-agent settings the program takes as arrays; the schedule as a 0/1 flag."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class DqnJaxSettings(ObservationNormalisation, DqnSettings):
    """`dqn`'s settings, field for field, and the observation normalisation
    (`agent.observation_normalisation`); a batch shares those that shape the program."""

    batch_size: int = setting(32)
    """Transitions per gradient step."""
    gradient_steps: int = setting(1)
    """Gradient steps per training call (-1: as many as steps collected, `train_freq`)."""

    def label(self) -> str:
        return "dqn_jax" + super().label().removeprefix("dqn")

    def describe(self, dim: int) -> str:
        return super().describe(dim).replace("(Stable-Baselines3)", "(JAX population)", 1)


class DqnJaxAgents(PopulationAgents):
    """B DQN agents as one pytree (see the module)."""

    def initial_state(self, key):
        jax, jnp = self.jax, self.jnp
        settings = self.settings[0]
        net_key, key = jax.random.split(key)
        sizes = [self.dim, *settings.layers(), self.task.action.n]
        params = mlp_init(net_key, sizes, [None] * (len(sizes) - 1), False)
        return {"params": params, "target": params, "adam": adam_init(params),
                "buffer": replay_buffer(self.state_shape()[0], self.dim, jnp.int32), "key": key}

    @staticmethod
    def weight_tree(state):
        return state["params"]

    def state_shape(self) -> tuple:
        """The replay buffer's capacity (`replay_capacity`)."""
        return (replay_capacity(self.settings),)

    def q_values(self, params, observation):
        """Q(s, .) `(..., A)` of the network `params` at observations `(..., d)` (float32)."""
        return mlp(params, observation.astype(self.jnp.float32), self.jax.nn.relu)

    def action_values(self, states, weights=None) -> np.ndarray:
        """Q(s, .) of the online network, `(B, ..., A)` (or `(..., A)` for `weights`)."""
        return self.over_agents(states, weights, self.q_values)

    def program(self) -> Program:
        jax, jnp = self.jax, self.jnp
        settings = self.settings[0]
        batch_size, horizon = settings.batch_size, settings.timesteps
        gradient_steps, = self.shared()
        q_values = self.q_values

        def epsilon(hyper, clock):
            """SB3's `LinearSchedule` of the exploration rate at the progress after step
            `clock - 1` (the rate `_on_step` set then)."""
            progress = clock / horizon
            start, end = hyper["exploration_initial_eps"], hyper["exploration_final_eps"]
            fraction = hyper["exploration_fraction"]
            return jnp.where(progress > fraction, end,
                             start + progress * (end - start) / jnp.maximum(fraction, 1e-300))

        def act(state, observation, key, hyper, greedy, clock):
            q = q_values(state["params"], observation)
            uniform_key, choice_key = jax.random.split(key)
            random_action = jax.random.randint(choice_key, (), 0, q.shape[-1], jnp.int32)
            explore = (clock < hyper["learning_starts"]) | (
                jax.random.uniform(uniform_key) < epsilon(hyper, clock))
            action = jnp.where(explore & ~greedy, random_action, jnp.argmax(q)).astype(jnp.int32)
            return action, {}

        def record(state, extras, observation, action, reward, terminated, truncated,
                   final_observation, hyper, clock, write):
            """The transition into the replay buffer, then `_on_step`'s target update."""
            buffer = replay_add(state["buffer"], write, observation, action, reward, terminated,
                                final_observation)
            due = write & ((clock + 1) % jnp.maximum(hyper["target_update_interval"], 1) == 0)
            target = polyak(state["params"], state["target"], hyper["tau"], due)
            return {**state, "buffer": buffer, "target": target}

        def loss(params, target, batch, gamma):
            next_q = q_values(target, batch["next_observations"]).max(axis=1)
            targets = batch["rewards"] + (1.0 - batch["terminals"]) * gamma * next_q
            q = jnp.take_along_axis(q_values(params, batch["observations"]),
                                    batch["actions"][:, None], axis=1)[:, 0]
            error = q - jax.lax.stop_gradient(targets)
            huber = jnp.where(jnp.abs(error) < 1.0, 0.5 * error * error, jnp.abs(error) - 0.5)
            return huber.mean()

        def gradient_step(learned, buffer, index, key, hyper, rate):
            """One of `DQN.train`'s gradient steps."""
            batch = replay_sample(buffer, key, batch_size)
            grads = jax.grad(loss)(learned["params"], learned["target"], batch,
                                   hyper["gamma"].astype(jnp.float32))
            grads = clip_by_norm(grads, hyper["max_grad_norm"])
            params, optimiser = adam(learned["params"], grads, learned["adam"], rate, 1e-8)
            return {**learned, "params": params, "adam": optimiser}

        return Program(act=act, record=record,
                       update=replay_update(gradient_step, gradient_steps, horizon),
                       update_due=replay_due, hyper=replay_hyper(self.settings, HYPER))


def make(settings, task, seeds) -> DqnJaxAgents:
    """B DQN agents trained as one JAX program, agent b with `settings[b]` and its random
    stream from `seeds[b]`."""
    return DqnJaxAgents(settings, task, seeds)


def load(document, arrays) -> DqnJaxAgents:
    """The agents `DqnJaxAgents.saved` wrote (a ValueError if the parts do not fit)."""
    return DqnJaxAgents.loaded(document, arrays, DqnJaxSettings)


def memory(settings, task) -> int:
    """Bytes of one agent: its replay buffer (float32 observations) and the online and target
    networks with Adam's two moments (four copies of the parameters)."""
    dim = len(task.state_names)
    return (replay_bytes(replay_capacity([settings]), dim)
            + network_bytes(dim, settings.layers(), task.action.n, 4))


LEARNER = Learner(
    name="dqn_jax", title="DQN in JAX, a population in one program: SB3's equations",
    source="Mnih et al. (2015), Nature 518; Raffin et al. (2021), JMLR 22(268): "
           "stable_baselines3.DQN, in JAX as PureJaxRL (Lu et al. 2022)",
    settings=DqnJaxSettings, make=make, load=load, memory=memory,
    unavailable=jax_unavailable("dqn_jax"), tuned=ZOO_SETS, checked=CHECKED, population=True,
    shared=lambda settings: (replay_gradient_steps("dqn_jax", settings),),
    arithmetic=counted(arithmetic))
"""The `dqn_jax` learner as the registry holds it (`agent.LEARNERS`)."""
DqnJaxAgents.learner = LEARNER
