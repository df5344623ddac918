"""What lwrl's JAX population learners of continuous actions (`agent.sac_jax`,
`agent.td3_jax`) share, as `agent.off_policy` is what `agent.sac` and `agent.td3` share: an
off-policy actor-critic of Stable-Baselines3 (Raffin et al. 2021, JMLR 22(268)) per agent,
written in JAX and trained as a whole population in one jitted program
(`runners.population`, `agent.jax_population`).

Per step c of an agent (SB3's `OffPolicyAlgorithm.collect_rollouts` and `_sample_action`):
the action at the observation is uniform over [-1, 1] before `learning_starts`, then the
policy's (SAC's sample, TD3's actor), the learner's action noise added and clipped to
[-1, 1] (TD3's Gaussian, also over the uniform warm-up actions, as SB3 adds it); greedy,
the policy's deterministic action. The runner scales the action to the actuator's range
(`tasks.commands`), as SB3 unscales its `Box(-1, 1)` action. The transition goes into the
replay buffer as (s, a, r, s', terminal), s' the episode's last observation where it ended,
a time limit not terminal (SB3's `handle_timeout_termination`: the target bootstraps from a
truncation). Every `train_freq` steps past `learning_starts`, `gradient_steps` gradient
steps (the learner's `gradient_step`), each on a minibatch of `batch_size` transitions drawn
uniformly with replacement, each network's Adam (PyTorch's, eps 1e-8: SB3's default for
these policies, no gradient clipping) at the learning rate of the progress then
(`jax_population.replay_update`).

Networks (SB3's `ContinuousCritic` and the learners' actors, `net_arch` ReLU MLPs,
PyTorch's default initialisation, float32): the actor from the observation (SAC's two
heads, the mean and the log standard deviation; TD3's one, through a tanh), and two critics
Q_1, Q_2 from the observation and the action; the target critics start as copies. Both
learners move the critics toward r + gamma (1 - terminal) y(s'), y the smaller of the two
target critics' values at s' (the clipped double Q of Fujimoto et al. 2018, eq. 10) with the
learner's own terms (`critic_step`).

In the contract's terms: `actions` is `continuous`; no action values at the observations
(no `q`) and `delta` not kept per step (NaN, `jax_population.PopulationArrays`); `weights` the actor's and the
critics' parameters, flattened (not the targets'); action values are the actor's greedy
action, state values the first critic's Q_1 of it.

What differs from `sac` and `td3`, and why: the random streams (JAX's); the replay buffer
keeps float32 observations, the values SB3's networks read; a batch's agents take minibatches
of one size and as many gradient steps per training call (`shared`, one compiled program),
which SB3's settings let differ per agent.
"""

import numpy as np

from lwrl.agent.jax_population import (PopulationAgents, Program, adam, adam_init,
                                       batch_value, masked, mlp, mlp_init, replay_add,
                                       replay_buffer, replay_bytes, replay_capacity, replay_due,
                                       replay_gradient_steps, replay_hyper, replay_sample,
                                       replay_update)
from lwrl.agent.stable_baselines import network_bytes

class ActorCriticAgents(PopulationAgents):
    """B off-policy actor-critics as one pytree (see the module). Subclasses give the
    actor's outputs (`ACTOR_OUTPUTS`), their own per-agent settings (`HYPER`) and state
    (`own_state`), the greedy action (`greedy_action`), the exploration (`explore`) and a
    gradient step (`gradient_step`)."""

    ACTOR_OUTPUTS = 1
    """The actor MLP's outputs."""
    HYPER: tuple = ("learning_rate", "gamma", "learning_starts", "tau", "train_freq")
    """The per-agent settings the program takes as arrays (`hyper`)."""

    def initial_state(self, key):
        jax, jnp = self.jax, self.jnp
        settings = self.settings[0]
        actor_key, critic_key, key = jax.random.split(key, 3)
        layers = settings.layers()
        linear = [None] * (len(layers) + 1)  # PyTorch's default initialisation
        actor = mlp_init(actor_key, [self.dim, *layers, self.ACTOR_OUTPUTS], linear, False)
        critics = jax.vmap(lambda k: mlp_init(k, [self.dim + 1, *layers, 1], linear, False))(
            jax.random.split(critic_key))
        params = {"actor": actor, "critics": critics}
        return {"params": params, "critic_target": critics,
                "adam": {name: adam_init(network) for name, network in params.items()},
                "buffer": replay_buffer(self.state_shape()[0], self.dim, jnp.float32), "key": key,
                **self.own_state(params)}

    def own_state(self, params) -> dict:
        """What the learner keeps beside the networks, the critics' targets, the optimisers,
        the buffer and the key."""
        return {}

    @staticmethod
    def weight_tree(state):
        return state["params"]

    def actor_output(self, actor, observation):
        """The actor MLP's outputs `(..., ACTOR_OUTPUTS)` at observations `(..., d)`."""
        return mlp(actor, observation.astype(self.jnp.float32), self.jax.nn.relu)

    def greedy_action(self, actor, observation):
        """The deterministic action in [-1, 1] `(...)` at observations `(..., d)`."""
        raise NotImplementedError

    def explore(self, actor, observation, key, hyper, warm, uniform):
        """The action of a step of learning at one observation `(d,)`: the policy's, or
        `uniform` where `warm` (before `learning_starts`), with the learner's noise."""
        raise NotImplementedError

    def gradient_step(self, learned, batch, index, key, hyper, rate):
        """`learned` after one gradient step on the minibatch `batch`, the `index`-th of its
        training call (`jax_population.replay_update`)."""
        raise NotImplementedError

    def critic_values(self, critics, observation, action):
        """`(C, ...)`: Q_i(s, a) of each of the C critics `critics` (a leading axis C) at
        observations `(..., d)` and actions `(...)`, float32."""
        jax, jnp = self.jax, self.jnp
        x = jnp.concatenate([observation.astype(jnp.float32),
                             action.astype(jnp.float32)[..., None]], axis=-1)
        return jax.vmap(lambda critic: mlp(critic, x, jax.nn.relu)[..., 0])(critics)

    def first_critic(self, critics):
        """Q_1 alone, the critics' first (SB3's `q1_forward`)."""
        return self.jax.tree.map(lambda leaf: leaf[:1], critics)

    def greedy_actions(self, states, weights=None) -> np.ndarray:
        """The actor's greedy action in [-1, 1], `(B, ...)` (or `(...)` for `weights`)."""
        return self.over_agents(states, weights, lambda params, x: self.greedy_action(
            params["actor"], x))

    def state_values(self, states, weights=None) -> np.ndarray:
        """The first critic's Q_1(s, greedy action), `(B, ...)` (or `(...)` for `weights`)."""
        def values(params, x):
            greedy = self.greedy_action(params["actor"], x)
            return self.critic_values(self.first_critic(params["critics"]), x, greedy)[0]
        return self.over_agents(states, weights, values)

    def adam_step(self, learned, name: str, loss, rate):
        """`learned` with the network `name` (`actor`, `critics`) after one Adam step on
        `loss(network)`."""
        network, optimiser = adam(learned["params"][name],
                                  self.jax.grad(loss)(learned["params"][name]),
                                  learned["adam"][name], rate, 1e-8)
        return {**learned, "params": {**learned["params"], name: network},
                "adam": {**learned["adam"], name: optimiser}}

    def next_values(self, learned, batch, next_actions):
        """min_i Q_target,i(s', a') over the minibatch, the smaller of the target critics'
        values at the next observations and the actions `next_actions` (clipped double Q,
        Fujimoto et al. 2018, eq. 10)."""
        return self.critic_values(learned["critic_target"], batch["next_observations"],
                                  next_actions).min(axis=0)

    def critic_step(self, learned, batch, next_values, hyper, rate, scale: float):
        """`learned` after the critics' Adam step on `scale` sum_i mean((Q_i(s, a) - y)^2),
        y = r + gamma (1 - terminal) `next_values`, held fixed (SB3's `critic_loss`:
        `scale` 0.5 for SAC, 1 for TD3)."""
        jnp = self.jnp
        targets = batch["rewards"] + (1.0 - batch["terminals"]) * hyper["gamma"].astype(
            jnp.float32) * next_values

        def loss(critics):
            values = self.critic_values(critics, batch["observations"], batch["actions"])
            return scale * jnp.sum(jnp.mean((values - targets) ** 2, axis=1))
        return self.adam_step(learned, "critics", loss, rate)

    def hyper(self) -> dict:
        """The program's `hyper` (`jax_population.replay_hyper`)."""
        return replay_hyper(self.settings, self.HYPER)

    def state_shape(self) -> tuple:
        """The replay buffer's capacity (`replay_capacity`)."""
        return (replay_capacity(self.settings),)

    def program(self) -> Program:
        jax, jnp = self.jax, self.jnp
        batch_size, gradient_steps = self.shared()

        def act(state, observation, key, hyper, greedy, clock):
            """SB3's `_sample_action` (`predict(deterministic=True)` where `greedy`)."""
            uniform_key, policy_key = jax.random.split(key)
            actor = state["params"]["actor"]
            uniform = jax.random.uniform(uniform_key, (), jnp.float32, -1.0, 1.0)
            explored = self.explore(actor, observation, policy_key, hyper,
                                    clock < hyper["learning_starts"], uniform)
            return jnp.where(greedy, self.greedy_action(actor, observation), explored), {}

        def record(state, extras, observation, action, reward, terminated, truncated,
                   final_observation, hyper, clock, write):
            """The transition into the replay buffer (SB3's `_store_transition`)."""
            return {**state, "buffer": replay_add(state["buffer"], write, observation, action,
                                                  reward, terminated, final_observation)}

        def gradient_step(learned, buffer, index, key, hyper, rate):
            sample_key, step_key = jax.random.split(key)
            return self.gradient_step(learned, replay_sample(buffer, sample_key, batch_size),
                                      index, step_key, hyper, rate)

        return Program(act=act, record=record,
                       update=replay_update(gradient_step, gradient_steps,
                                            self.settings[0].timesteps),
                       update_due=replay_due, hyper=self.hyper(), mapped=True,
                       unchanged=("buffer",))


def shared(learner: str):
    """The learner's `Learner.shared`: the minibatches' size and the gradient steps of a
    training call."""
    def values(settings) -> tuple:
        return (batch_value(learner, "share batch_size (it shapes the program)",
                            [s.batch_size for s in settings]),
                replay_gradient_steps(learner, settings))
    return values


def memory(settings, task, actor_outputs: int, actor_copies: int) -> int:
    """Bytes of one agent: its replay buffer (`jax_population.replay_bytes`), the actor
    (`actor_outputs` outputs) in `actor_copies` float32 copies (parameters, Adam's two
    moments, a target) and two critics with their targets and Adam's moments (four copies)."""
    dim, layers = len(task.state_names), settings.layers()
    return (replay_bytes(replay_capacity([settings]), dim)
            + network_bytes(dim, layers, actor_outputs, actor_copies)
            + 2 * network_bytes(dim + 1, layers, 1, 4))
