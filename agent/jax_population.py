"""What lwrl's JAX population learners (`agent.ppo_jax`, `agent.dqn_jax`, `agent.sac_jax`,
`agent.td3_jax`) share: B agents as one pytree of arrays with a leading axis B, trained by one
jitted program (`runners.population`), and the pieces of Stable-Baselines3's learners written
in JAX with PyTorch's arithmetic.

A population learner gives the runner a `Program`: pure per-agent functions that the runner
`vmap`s over the batch, in the style of PureJaxRL (Lu et al. 2022) and rejax:

- `act(state, observation, key, hyper, greedy, clock) -> (action, extras)` at the agent's
  step `clock` (its steps of learning so far): an index, or for a learner of continuous
  actions a float32 number in [-1, 1] that the runner scales to the actuator's range
  (`tasks.commands`); `extras` what `record` needs of the choice (e.g. PPO's V(s) and
  log-probability);
- `record(state, extras, observation, action, reward, terminated, truncated,
  final_observation, hyper, clock, write) -> state`: the transition just taken, written
  only where `write` (learning, and the agent still running);
- `update(state, next_observation, next_start, hyper, clock, due) -> state`: the update
  after the agent's step `clock`, taking effect only where `due` (`update_due(hyper,
  clock)`); the runner runs it where some agent of the batch is due, so it is not computed
  for every step and thrown away.

`record` and `update` mask what they change themselves, so that the runner never selects
between two copies of a whole state (a replay buffer of a million transitions).

`hyper` are the per-agent settings as arrays (`Program.hyper`); the others (the network's
shape, the rollout's length, the epochs) are the batch's and shape the program.

The networks, the initialisation, Adam and the gradient clipping are SB3's and PyTorch's
(`mlp`, `adam`, `clip_by_norm`): the same equations, drawn from JAX's random streams. The
off-policy learners (DQN, SAC, TD3) share SB3's replay buffer (`replay_buffer`,
`replay_add`, `replay_sample`), its training calls (`replay_hyper`, `replay_update`,
`replay_due`) and the target networks' Polyak update (`polyak`).
JAX is optional (the `jax` extra); nothing here is imported without it but this module's
names.
"""

import collections
import copy
import dataclasses
import importlib.util
import math
from typing import Any

import numpy as np

from lwrl.agent.learner_contract import CONTINUOUS_ACTIONS, Agents
from lwrl.spaces import spec_document, spec_of_document

EXTRA = "pip install 'lwrl[jax]'"
"""How to install JAX, named where a population learner needs it."""
PopulationArrays = collections.namedtuple("PopulationArrays", "delta diverged weights")
"""What the loops read of a population (`Agents.arrays`): `delta` is not kept per step (NaN)
and there are no action values at the observations (no `q`: `Agents.latest_values`),
`weights` what the agents have learned, flattened."""


def missing_jax() -> bool:
    """True where JAX is not installed (the population learners then cannot run)."""
    return importlib.util.find_spec("jax") is None


def jax_unavailable(name: str):
    """A population learner's `unavailable`: None once JAX is installed; else one line
    naming the extra."""
    def unavailable():
        return f"{name} needs JAX (not installed): {EXTRA}" if missing_jax() else None
    return unavailable


def jax_modules():
    """`(jax, jax.numpy)`, in 64 bits (the analytic plant's numbers; the networks stay float32),
    or a one-line error naming the extra."""
    if missing_jax():
        raise ValueError(f"the JAX population learners need JAX: {EXTRA}")
    import jax
    import jax.numpy as jnp
    jax.config.update("jax_enable_x64", True)
    return jax, jnp


def mlp_init(key, sizes, gains, orthogonal: bool):
    """`[(W (in, out), b (out,)), ...]` float32 for layer widths `sizes`: PyTorch's
    `nn.Linear` default (W and b ~ U(-1/sqrt(in), 1/sqrt(in)), Kaiming's uniform with a =
    sqrt(5)) or, `orthogonal`, SB3's `ActorCriticPolicy.init_weights` (W orthogonal with
    the layer's gain from `gains`, b = 0)."""
    jax, jnp = jax_modules()
    layers = []
    for (fan_in, fan_out), gain, layer_key in zip(zip(sizes[:-1], sizes[1:]), gains,
                                                  jax.random.split(key, len(sizes) - 1)):
        w_key, b_key = jax.random.split(layer_key)
        if orthogonal:
            w = jax.nn.initializers.orthogonal(scale=gain)(w_key, (fan_in, fan_out), jnp.float32)
            b = jnp.zeros(fan_out, jnp.float32)
        else:
            bound = 1.0 / math.sqrt(fan_in)
            w = jax.random.uniform(w_key, (fan_in, fan_out), jnp.float32, -bound, bound)
            b = jax.random.uniform(b_key, (fan_out,), jnp.float32, -bound, bound)
        layers.append((w, b))
    return layers


def mlp(layers, x, activation):
    """The MLP's output: `activation` after every layer but the last (SB3's `create_mlp`)."""
    for index, (w, b) in enumerate(layers):
        x = x @ w + b
        if index < len(layers) - 1:
            x = activation(x)
    return x


def clip_by_norm(grads, max_norm):
    """PyTorch's `clip_grad_norm_`: the gradients scaled by max_norm / (norm + 1e-6) where
    their global norm exceeds `max_norm`."""
    jax, jnp = jax_modules()
    leaves = jax.tree.leaves(grads)
    norm = jnp.sqrt(sum(jnp.sum(g * g) for g in leaves))
    scale = jnp.minimum(max_norm / (norm + 1e-6), 1.0).astype(jnp.float32)
    return jax.tree.map(lambda g: g * scale, grads)


def adam_init(params):
    """Adam's state `(m, v, count)` for `params`: zeros."""
    jax, jnp = jax_modules()
    zeros = jax.tree.map(jnp.zeros_like, params)
    return zeros, zeros, jnp.zeros((), jnp.int32)


def adam(params, grads, state, learning_rate, eps, beta1=0.9, beta2=0.999):
    """PyTorch's Adam step (Kingma and Ba 2015, Algorithm 1, as `torch.optim.Adam` computes
    it): m = b1 m + (1 - b1) g, v = b2 v + (1 - b2) g^2, w -= lr / (1 - b1^t) m /
    (sqrt(v) / sqrt(1 - b2^t) + eps). Returns `(params, state)`."""
    jax, jnp = jax_modules()
    m, v, count = state
    count = count + 1
    m = jax.tree.map(lambda m_, g: beta1 * m_ + (1.0 - beta1) * g, m, grads)
    v = jax.tree.map(lambda v_, g: beta2 * v_ + (1.0 - beta2) * g * g, v, grads)
    t = count.astype(jnp.float32)
    step = (learning_rate / (1.0 - beta1 ** t)).astype(jnp.float32)
    root = jnp.sqrt(1.0 - beta2 ** t).astype(jnp.float32)
    params = jax.tree.map(lambda p, m_, v_: p - step * m_ / (jnp.sqrt(v_) / root + eps),
                          params, m, v)
    return params, (m, v, count)


def polyak(params, target, tau, when):
    """The target networks moved toward `params` where `when`: tau params + (1 - tau)
    target (SB3's `polyak_update`), tau in float32."""
    jax, jnp = jax_modules()
    tau = tau.astype(jnp.float32)
    return jax.tree.map(lambda p, t: jnp.where(when, tau * p + (1.0 - tau) * t, t), params, target)


def masked(due, state, **new):
    """`state` with the entries `new` where `due`, its own elsewhere (an update's result,
    taking effect for the agents due only)."""
    jax, jnp = jax_modules()
    return {**state, **jax.tree.map(lambda new_, old: jnp.where(due, new_, old), new,
                                    {name: state[name] for name in new})}


def hyper_arrays(settings, names) -> dict:
    """`{setting: (B,) array}` of the agents' `settings` named (`Program.hyper`), and
    `linear_rate`, whether each agent's learning rate follows the linear schedule."""
    hyper = {name: np.array([getattr(s, name) for s in settings]) for name in names}
    hyper["linear_rate"] = np.array([s.learning_rate_schedule == "linear" for s in settings])
    return hyper


def batch_value(learner: str, what: str, values):
    """The one value of `values` (one per agent) where it shapes the program though the
    settings that give it are per agent (`PopulationAgents.shared`), or a one-line
    ValueError saying that the agents of a batch must `what`."""
    if len(set(values)) > 1:
        raise ValueError(f"{learner} agents of one batch must {what}; got {list(values)}")
    return values[0]


def replay_buffer(size: int, dim: int, action_dtype) -> dict:
    """An empty replay buffer of `size` transitions (SB3's `ReplayBuffer`): float32
    observations and next observations `(size, d)`, actions `(size,)` of `action_dtype`,
    float32 rewards and terminals, and `count`, the transitions added so far."""
    _, jnp = jax_modules()
    return {"observations": jnp.zeros((size, dim), jnp.float32),
            "next_observations": jnp.zeros((size, dim), jnp.float32),
            "actions": jnp.zeros(size, action_dtype), "rewards": jnp.zeros(size, jnp.float32),
            "terminals": jnp.zeros(size, jnp.float32), "count": jnp.zeros((), jnp.int32)}


def replay_capacity(settings) -> int:
    """The transitions a replay buffer of agents with `settings` (one batch's) is made to
    hold: `buffer_size`, or fewer where the agents cannot store that many, as an agent
    stores a transition only while it learns (`record`'s `write`), so at most
    `replay_hyper`'s `learning_steps` in its life. Then no slot is ever overwritten and no
    draw reaches past the transitions stored, in a buffer of either size: the same numbers,
    without carrying SB3's million empty slots (a million-transition buffer made each of
    SAC's steps four times dearer here)."""
    settings = list(settings)
    steps = max(-(-s.timesteps // s.train_freq) * s.train_freq for s in settings)
    return min(settings[0].buffer_size, steps)


def replay_bytes(size: int, dim: int) -> int:
    """Bytes of a `replay_buffer` of `size` transitions of `dim` state variables."""
    return 4 * size * (2 * dim + 3)


def replay_add(buffer, write, observation, action, reward, terminated, final_observation) -> dict:
    """The buffer with the transition (s, a, r, s', terminal) in its next slot, the oldest
    overwritten once it is full, where `write`: s' the episode's last observation where it
    ended, a time limit not terminal (SB3's `handle_timeout_termination`)."""
    _, jnp = jax_modules()
    slot = buffer["count"] % buffer["rewards"].shape[0]
    entry = {"observations": observation.astype(jnp.float32),
             "next_observations": final_observation.astype(jnp.float32),
             "actions": action, "rewards": reward.astype(jnp.float32),
             "terminals": terminated.astype(jnp.float32)}
    return {**{name: buffer[name].at[slot].set(
        jnp.where(write, entry[name], buffer[name][slot])) for name in entry},
        "count": buffer["count"] + write.astype(jnp.int32)}


def replay_sample(buffer, key, batch_size: int) -> dict:
    """`batch_size` transitions drawn uniformly, with replacement, among those the buffer
    holds (SB3's `ReplayBuffer.sample`)."""
    jax, jnp = jax_modules()
    filled = jnp.minimum(buffer["count"], buffer["rewards"].shape[0])
    indices = jax.random.randint(key, (batch_size,), 0, filled)
    return {name: buffer[name][indices] for name in buffer if name != "count"}


def replay_hyper(settings, names) -> dict:
    """An off-policy learner's `Program.hyper`: the settings named (`hyper_arrays`) and
    `learning_steps`, `timesteps` rounded up to a whole `train_freq`, as SB3's
    `OffPolicyAlgorithm.learn()` collects whole training periods."""
    hyper = hyper_arrays(settings, names)
    hyper["learning_steps"] = np.array([-(-s.timesteps // s.train_freq) * s.train_freq
                                        for s in settings])
    return hyper


def replay_gradient_steps(learner: str, settings) -> int:
    """The gradient steps of each training call (`gradient_steps`, or `train_freq` where it
    is -1, SB3's steps collected), which shape the program: one for the batch."""
    return batch_value(learner, "take as many gradient steps per training call "
                       "(gradient_steps, or train_freq where it is -1)",
                       [s.gradient_steps if s.gradient_steps >= 0 else s.train_freq
                        for s in settings])


def replay_due(hyper, clock):
    """True after the agent's step `clock` where SB3's off-policy `learn()` trains: every
    `train_freq` steps past `learning_starts`."""
    done = clock + 1
    return (done % hyper["train_freq"] == 0) & (done > hyper["learning_starts"])


def replay_update(gradient_step, gradient_steps: int, horizon: int):
    """An off-policy learner's `Program.update`, SB3's `train(gradient_steps, batch_size)`
    after the agent's step `clock`: the learning rate at the progress then (SB3's
    `_update_learning_rate`: the initial rate, or with the linear schedule that rate times
    the fraction of the `horizon` still to go), then `gradient_steps` calls of
    `gradient_step(learned, buffer, index, key, hyper, rate) -> learned`, `learned` the
    agent's state but its buffer and its key, `index` the gradient step's within the
    call, `key` its own; taking effect where `due`."""
    jax, jnp = jax_modules()

    def update(state, next_observation, next_start, hyper, clock, due):
        del next_observation, next_start
        remaining = 1.0 - (clock + 1) / horizon
        rate = hyper["learning_rate"] * jnp.where(hyper["linear_rate"], remaining, 1.0)
        key, steps_key = jax.random.split(state["key"])
        learned = {name: value for name, value in state.items() if name not in ("buffer", "key")}

        def step(carry, inputs):
            return gradient_step(carry, state["buffer"], *inputs, hyper, rate), None
        learned, _ = jax.lax.scan(step, learned, (jnp.arange(gradient_steps),
                                                  jax.random.split(steps_key, gradient_steps)))
        return masked(due, state, key=key, **learned)
    return update


def flat(tree) -> np.ndarray:
    """`(B, N)`: each agent's leaves of `tree` (leading axis B), flattened in order."""
    import jax
    leaves = [np.asarray(leaf) for leaf in jax.tree.leaves(tree)]
    return np.concatenate([leaf.reshape(len(leaf), -1).astype(np.float64) for leaf in leaves],
                          axis=1)


@dataclasses.dataclass(frozen=True)
class Program:
    """A population learner's pure functions and the batch's settings (see the module)."""

    act: Any
    """`act(state, observation, key, hyper, greedy, clock) -> (action, extras)`."""
    record: Any
    """`record(state, extras, observation, action, reward, terminated, truncated,
    final_observation, hyper, clock, write) -> state`: the transition just taken."""
    update: Any
    """`update(state, next_observation, next_start, hyper, clock, due) -> state`."""
    update_due: Any
    """`update_due(hyper, clock)`: True after the agent's step `clock` (its steps of
    learning, counted from 0) where an update follows, e.g. the step that fills a rollout."""
    hyper: Any
    """`{setting: (B,) array}`: the per-agent settings the functions take, and
    `learning_steps`, each agent's steps of learning (`timesteps`, rounded up to a whole
    rollout or training period as SB3's `learn()` rounds it), after which it acts greedily
    and learns no more."""
    mapped: bool = False
    """True: the runner computes the agents' actions and their updates (for the agents due
    only) one agent after another (`lax.map`), rather than `vmap`ped over the batch. Then an
    agent's step is one computation in a batch of any size: vmapped, XLA's CPU dot takes another algorithm for
    a batch of one agent than for several for some shapes (its sums in another order, e.g.
    a weight gradient over a minibatch of 256 into a layer of a few inputs or outputs, or
    an actor's output at one observation, jaxlib 0.10.2), so an agent alone would not give
    its numbers in a batch: for a continuous action, every bit of it reaches the plant."""
    unchanged: tuple = ()
    """The entries of the state that `update` reads and never changes and `act` never reads
    (a replay buffer): a mapped program does not carry them through, so that they are not
    copied."""


_INITIALISERS: dict = {}
"""The jitted initial state of each kind of batch (`initialiser`), made once per process."""


def initialiser(agents):
    """`key -> state`: `agents.agent_state` of one agent's key, jitted once per process for
    each `agents.initialiser_key()`, so that a new batch of the same kind, of any size,
    compiles nothing (a program made anew for every batch compiled for 1.5 s each time here,
    where JAX's disk cache did not hold it; one over the batch, for 2 s each size of batch).
    The program keeps a copy of `agents` made before its state exists, which holds the
    settings and the task only."""
    key = agents.initialiser_key()
    if key not in _INITIALISERS:
        _INITIALISERS[key] = agents.jax.jit(copy.copy(agents).agent_state)
    return _INITIALISERS[key]


def initial_states(agents, keys):
    """The batch's state, `(B, ...)` leaves: `initialiser(agents)` of each of `keys`
    `(B, 2)`, one agent after another. Not vmapped: the orthogonal initialisation's batched
    QR hangs XLA's CPU runtime in some processes (jaxlib 0.10.2: 5 of 6 fresh processes
    making 100 ppo_jax agents never returned); agent by agent gives the same bits. The leaves
    are stacked by NumPy and put on the device as they are: `jnp.stack` (and `jnp.asarray`)
    compiled a program for each leaf's shape and batch size, about 30 of them for a SAC
    batch (0.8 s)."""
    one, jax = initialiser(agents), agents.jax
    return jax.tree.map(lambda *leaves: jax.device_put(np.stack([np.asarray(leaf)
                                                                 for leaf in leaves])),
                        *[one(agent_key) for agent_key in keys])


class PopulationAgents(Agents):
    """B agents of a population learner: `state`, a pytree of arrays with a leading axis B
    (JAX arrays), and `clocks` `(B,)`, each agent's steps of learning so far. Subclasses build
    the state
    (`initial_state`) and the program (`program`), and say which leaves are the weights
    (`weight_tree`)."""

    def __init__(self, settings, task, seeds):
        self.jax, self.jnp = jax_modules()
        self.settings, self.task = tuple(settings), task
        self.seeds = [int(seed) for seed in seeds]
        """The agents' seeds, one each: their keys' and starts' streams."""
        if len(self.settings) != len(self.seeds):
            raise ValueError(f"{len(self.settings)} settings for {len(self.seeds)} seeds")
        self.check_batchable()
        self.dim = len(task.state_names)
        keys = self.jax.vmap(self.jax.random.PRNGKey)(self.jnp.asarray(self.seeds, self.jnp.uint32))
        self.state = initial_states(self, keys)
        """The agents' state: a pytree of JAX arrays with a leading axis B."""
        self.clocks = np.zeros(len(self.seeds), dtype=np.int64)
        """`(B,)` each agent's steps of learning so far."""
        self._greedy = None  # the jitted greedy act of `step`, made at its first call
        batch = len(self.seeds)
        self.arrays = PopulationArrays(delta=np.full(batch, np.nan),
                                       diverged=np.zeros(batch, dtype=bool),
                                       weights=flat(self.learned_tree(self.state)))

    @property
    def action_space(self):
        """The task's `Discrete` actions, or `CONTINUOUS_ACTIONS` (the agents keep no action
        values to read A off)."""
        return CONTINUOUS_ACTIONS if self.continuous else self.task.action

    def initialiser_key(self) -> tuple:
        """What `initial_state` depends on: the class, the first agent's settings (the
        batch's shapes are its), the task and `state_shape`."""
        return type(self), self.settings[0], self.task, self.state_shape()

    def state_shape(self) -> tuple:
        """What else shapes the state than the first agent's settings: () here; an
        off-policy learner's replay buffer's capacity (`replay_capacity`, from every
        agent's settings)."""
        return ()

    def check_batchable(self) -> None:
        """A one-line ValueError where the agents' settings differ in a field that shapes
        the program (one not marked `per_agent`) or in a value of `shared`."""
        first = self.settings[0]
        for settings in self.settings[1:]:
            for field in dataclasses.fields(first):
                if not field.metadata.get("per_agent") and getattr(settings, field.name) != \
                        getattr(first, field.name):
                    raise ValueError(
                        f"{self.learner.name} agents of one batch must share {field.name} (it "
                        f"shapes the program); got {getattr(first, field.name)!r} and "
                        f"{getattr(settings, field.name)!r}")
        self.shared()

    def shared(self) -> tuple:
        """What else shapes the program, beside the settings the batch shares: the values
        that per-agent settings give and the batch's agents must share (`Learner.shared`).
        The runner compiles a program for each."""
        return self.learner.shared(self.settings)

    def initial_state(self, key):
        """One agent's state, from its JAX `key`, as the learner makes it."""
        raise NotImplementedError

    def program(self) -> Program:
        """The learner's pure functions and the batch's settings (`Program`)."""
        raise NotImplementedError

    @staticmethod
    def weight_tree(state):
        """The leaves of `state` that are what the learner has learned (its weights)."""
        raise NotImplementedError

    def normalises_observations(self) -> bool:
        """True where the agents' settings turn on the observation normalisation of
        `agent.observation_normalisation` (the batch shares it)."""
        from lwrl.agent.observation_normalisation import ObservationNormalisation
        first = self.settings[0]
        return isinstance(first, ObservationNormalisation) and first.normalize_observations

    def agent_state(self, key):
        """One agent's state, from its JAX `key` (`initialiser` maps it over the batch): the
        learner's `initial_state`, and the observation statistics where the agents normalise
        their observations (`agent.observation_normalisation`)."""
        state = self.initial_state(key)
        if not self.normalises_observations():
            return state
        from lwrl.agent import observation_normalisation
        return {**state, observation_normalisation.STATE:
                observation_normalisation.initial_stats(self.dim)}

    def trained_program(self) -> Program:
        """The program the runner trains and acts with: the learner's `program`, reading
        its observations normalised where the agents normalise them
        (`observation_normalisation.normalising`)."""
        if not self.normalises_observations():
            return self.program()
        from lwrl.agent import observation_normalisation
        return observation_normalisation.normalising(self.program())

    def learned_tree(self, state):
        """What the agents have learned: the learner's `weight_tree`, and the observation
        statistics where the agents normalise their observations (a greedy decision needs
        both)."""
        if not self.normalises_observations():
            return self.weight_tree(state)
        from lwrl.agent import observation_normalisation
        return {"weights": self.weight_tree(state),
                "observations": state[observation_normalisation.STATE]}

    def snapshot(self) -> "PopulationAgents":
        """A copy of these agents whose `finished` leaves these as they are (the state's
        arrays are immutable, the host arrays copied): the agents at a run's checkpoint."""
        other = copy.copy(self)
        other.arrays = PopulationArrays(*(np.copy(values) for values in self.arrays))
        return other

    def part(self, start: int, stop: int) -> "PopulationAgents":
        """Agents `start` to `stop` of the batch as a batch of their own, with their settings,
        seeds, state, clocks and divergence: what a run of them alone would hold (an agent's
        numbers do not depend on the others of its batch), for runs trained as one population
        and kept apart (`runners.sweep.populations`)."""
        part = copy.copy(self)
        part.settings, part.seeds = self.settings[start:stop], self.seeds[start:stop]
        part.state = self.jax.tree.map(lambda leaf: leaf[start:stop], self.state)
        part.clocks = self.clocks[start:stop].copy()
        part._greedy = None
        part.arrays = PopulationArrays(*(np.array(values[start:stop]) for values in self.arrays))
        return part

    def finished(self, state, clocks) -> None:
        """After a run: the batch's new state and clocks, its weights and divergence."""
        self.state, self.clocks = state, np.asarray(clocks, dtype=np.int64)
        self.arrays = self.arrays._replace(weights=flat(self.learned_tree(state)))
        self.arrays.diverged[:] |= ~np.isfinite(self.arrays.weights).all(axis=1)

    def value_box(self) -> tuple:
        """The task's normalisation ranges (the networks read states in task units)."""
        return self.task.ranges.low, self.task.ranges.high

    def unflatten(self, weights):
        """One agent's `learned_tree` from its flattened `weights` (`arrays.weights[b]`)."""
        template = self.jax.tree.map(lambda leaf: leaf[0], self.learned_tree(self.state))
        leaves, structure = self.jax.tree.flatten(template)
        sizes = np.cumsum([leaf.size for leaf in leaves])[:-1]
        parts = np.split(np.asarray(weights, dtype=np.float64), sizes)
        return self.jax.tree.unflatten(structure, [
            self.jnp.asarray(part.reshape(leaf.shape), leaf.dtype) for part, leaf in zip(parts, leaves)])

    def over_agents(self, states, weights, values) -> np.ndarray:
        """`values(tree, states (n, d)) -> (n, ...)` at `states` `(..., d)`, for every agent
        `(B, ..., ...)` or for one agent's `weights`, as float64."""
        states = np.asarray(states, dtype=np.float64)
        flat_states = states.reshape(-1, states.shape[-1])

        def one(tree):
            observations = self.jnp.asarray(flat_states)
            if self.normalises_observations():
                from lwrl.agent import observation_normalisation
                tree, observations = tree["weights"], observation_normalisation.normalised(
                    observations, tree["observations"])
            result = np.asarray(values(tree, observations), dtype=np.float64)
            return result.reshape(states.shape[:-1] + result.shape[1:])
        if weights is not None:
            return one(self.unflatten(weights))
        return np.stack([one(self.unflatten(w)) for w in self.arrays.weights])

    def step(self, first, reward, discount, observation, active=None, learn=True,
             greedy=False) -> np.ndarray:
        """Greedy decisions without learning (`learn=False, greedy=True`), one jitted call of
        the program's `act` over the batch: what a study times and an exported controller
        does. The agents learn only as the whole program (`runners.population`), so anything
        else is a one-line ValueError."""
        if learn or not greedy:
            raise ValueError(f"{self.learner.name} trains as one JAX program "
                             "(runners.population): step by step it only acts greedily "
                             "(learn=False, greedy=True)")
        observation = self.check_observation(observation)
        if self._greedy is None:
            program, jax = self.trained_program(), self.jax
            key = jax.random.PRNGKey(0)  # unused: a greedy act draws nothing
            self._hyper = program.hyper
            self._greedy = jax.jit(jax.vmap(
                lambda state, obs, hyper, clock: program.act(state, obs, key, hyper, True,
                                                             clock)[0]))
        actions = np.asarray(self._greedy(self.state, observation, self._hyper,
                                          self.jnp.asarray(self.clocks)),
                             dtype=np.float64 if self.continuous else np.int64)
        active = np.ones(self.batch_size, dtype=bool) if active is None else np.asarray(active, bool)
        return np.where(active, actions, 0)

    def saved(self) -> tuple[dict, dict]:
        """Every leaf of the state, by position in the pytree, and the clocks."""
        leaves = self.jax.tree.leaves(self.state)
        arrays = {f"leaf{i}": np.asarray(leaf) for i, leaf in enumerate(leaves)}
        arrays["diverged"], arrays["clocks"] = self.arrays.diverged, self.clocks
        document = {"settings": [dataclasses.asdict(s) for s in self.settings],
                    "seeds": self.seeds, "task": spec_document(self.task)}
        return document, arrays

    @classmethod
    def loaded(cls, document, arrays, settings_class):
        """The agents `saved` wrote, their settings of `settings_class` (a ValueError if the
        parts do not fit)."""
        task = spec_of_document(document["task"])
        agents = cls([settings_class(**s) for s in document["settings"]], task, document["seeds"])
        leaves, structure = agents.jax.tree.flatten(agents.state)
        given = [np.asarray(arrays[f"leaf{i}"]) for i in range(len(leaves))]
        for leaf, value in zip(leaves, given):
            if value.shape != leaf.shape:
                raise ValueError(f"a saved array of shape {value.shape} where the learner "
                                 f"holds {leaf.shape}")
        agents.finished(agents.jax.tree.unflatten(
            structure, [agents.jnp.asarray(v, leaf.dtype) for v, leaf in zip(given, leaves)]),
            arrays["clocks"])
        return agents

    def take_weights(self, weights) -> None:
        """The state's leaves that `learned_tree` reads, the same arrays, replaced by
        `weights` `(B, W)` (`unflatten` of each row), the rest of the state (random streams,
        clocks, a rollout under way) kept."""
        jax, jnp = self.jax, self.jnp
        leaves, structure = jax.tree.flatten(self.state)
        position = {id(leaf): i for i, leaf in enumerate(leaves)}
        rows = [jax.tree.leaves(self.unflatten(row)) for row in np.asarray(weights)]
        for i, leaf in enumerate(jax.tree.leaves(self.learned_tree(self.state))):
            leaves[position[id(leaf)]] = jnp.stack([row[i] for row in rows])
        self.finished(jax.tree.unflatten(structure, leaves), self.clocks)

    def take_over(self, kept: "PopulationAgents") -> None:
        copies = self.copies_of(kept)
        self.finished(self.jax.tree.map(lambda x: self.jnp.concatenate([x] * copies), kept.state),
                      np.concatenate([kept.clocks] * copies))
        self.arrays.diverged[:] = np.concatenate([kept.arrays.diverged] * copies)
