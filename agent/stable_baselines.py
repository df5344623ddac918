"""What lwrl's Stable-Baselines3 learners (`agent.dqn`, `agent.ppo`, and through
`agent.off_policy` `agent.sac` and `agent.td3`) share: B independent SB3 models stepped by
lwrl's loop, one time step at a time, through SB3's own components.

Raffin et al. (2021), "Stable-Baselines3: reliable reinforcement learning implementations",
JMLR 22(268). PyTorch and Stable-Baselines3 are optional (the `baselines` extra: `pip install
'lwrl[baselines]'`); this module imports them only when agents are made, so the registry and
the settings (the command line's flags) are there without them, and a run says in one line
what to install.

Each of the B agents is an SB3 model of its own (`DQN`, `PPO`, `SAC`, `TD3`) built with the
agent's seed, as `DQN(..., seed=s)` builds it: SB3 seeds NumPy's global generator, PyTorch's
and the action space from s and draws the networks' initial weights from them. SB3 draws its
random numbers from those global generators (exploration, replay sampling, minibatch order, the
policy's samples), so every agent keeps its own copies (`RandomStates`) and they are swapped in
around each use: an agent's numbers depend on its own seed only, not on the batch it runs in.
The model is set up as `learn(total_timesteps=timesteps)` sets it up (`_setup_learn`: the
schedules' horizon, the logger); lwrl's loop then plays the part of SB3's `collect_rollouts`,
and SB3's own methods do the rest: the replay buffer and its `_store_transition`, `_on_step`
(the target network, the exploration schedule), the rollout buffer and its GAE, and `train()`.
The learner's test replays `learn()` to the bit on the same environment and seed.

One thing lwrl's loop does not say at the time: whether an observation with discount 1 is the
last of its episode (a truncation). It learns that at the next call, which starts an episode.
Then (as SB3's loop, which knows it at once, would have done) the agent gives back the random
draws it made choosing an action that is never taken, and marks the transition a time-out (DQN,
SAC, TD3: `timeouts` in the replay buffer, `handle_timeout_termination`; PPO: the reward takes
gamma V(s_T), SB3's bootstrapping from a truncated state). Every target or advantage SB3
computes before that mark is the same with or without it (a DQN target bootstraps from a
time-out as from a non-terminal state; a rollout's last advantage is r + gamma V(s_T) - V
either way), so the numbers are SB3's.

After `timesteps` steps of learning (SB3's `total_timesteps`, rounded up to a whole rollout as
`learn()` rounds it) an agent stops learning and acts greedily, as a model trained by
`learn()` and then run with `predict(deterministic=True)`.
"""

import collections
import contextlib
import dataclasses
import importlib.util
import random

import numpy as np

from lwrl.agent.arithmetic import mlp_parameters
from lwrl.agent.learner_contract import Agents, LearnerSettings
from lwrl.settings import check_count, check_positive, check_unit_interval, setting
from lwrl.spaces import Discrete, Space, spec_document, spec_of_document

ZOO = "DLR-RM/rl-baselines3-zoo, hyperparams/{dqn,ppo}.yml at commit 22e3ff2450fd92033f7f032915e1f64894a09584"
"""Where the learners' tuned sets (`Learner.tuned`) come from. The zoo's `n_timesteps` is a
learner's horizon (`timesteps`: the schedules', the exploration's); PPO's `n_envs` parallel
environments become one environment with a rollout of `n_envs x n_steps` transitions; the
zoo's `normalize: true` (VecNormalize, for PPO on MountainCar and Acrobot) has no
counterpart here and is left out."""
LIBRARIES = ("torch", "stable_baselines3")
"""The libraries the learners of Stable-Baselines3 need."""
EXTRA = "pip install 'lwrl[baselines]'"
"""How to install them, named where one is missing."""


def missing_libraries() -> list:
    """The libraries of the `baselines` extra that are not installed."""
    return [name for name in LIBRARIES if importlib.util.find_spec(name) is None]


def sb3_unavailable(name: str):
    """A learner's `unavailable`: None once PyTorch and Stable-Baselines3 are installed;
    else one line naming the extra."""
    def unavailable():
        missing = missing_libraries()
        if missing:
            return (f"{name} needs PyTorch and Stable-Baselines3 ({', '.join(missing)} not "
                    f"installed): {EXTRA}")
        return None
    return unavailable


def check_layers(text) -> tuple:
    """`net_arch` as a tuple of positive layer widths, or a one-line error."""
    try:
        layers = tuple(int(part) for part in str(text).split(","))
    except ValueError:
        layers = ()
    if not layers or min(layers) < 1:
        raise ValueError(f"net_arch must be comma-separated positive integers (the hidden "
                         f"layers' widths, e.g. 64,64); got {text!r}")
    return layers


def check_network(settings) -> None:
    """A one-line ValueError for the first of a network learner's `timesteps`, `net_arch`,
    `learning_rate` and `gamma` out of its range (SB3's learners', the streaming learners')."""
    check_count("timesteps", settings.timesteps, 1)
    check_layers(settings.net_arch)
    check_positive("learning_rate", settings.learning_rate)
    check_unit_interval("gamma", settings.gamma)


@dataclasses.dataclass(frozen=True, kw_only=True)
class NetworkSettings(LearnerSettings):
    """What every SB3 learner takes: the learning horizon, the network and the optimiser's
    step size (SB3's names; defaults: SB3's, which rl-baselines3-zoo keeps for a task it
    has not tuned)."""

    timesteps: int = setting(1_000_000)
    """Environment steps of learning, SB3's `total_timesteps` (the schedules' horizon;
    rl-baselines3-zoo's default 1e6); the agent then acts greedily."""
    net_arch: str = setting("64,64")
    """Hidden layers' widths, comma-separated (SB3's `net_arch`)."""
    learning_rate: float = setting(1e-4, per_agent=True)
    """Adam's step size."""
    learning_rate_schedule: str = setting("constant", choices=("constant", "linear"), per_agent=True)
    """`constant`, or `linear` to 0 over `timesteps` (rl-baselines3-zoo's `lin_`)."""
    gamma: float = setting(0.99, per_agent=True)
    """Discount factor gamma in [0, 1]."""

    def layers(self) -> list:
        """The hidden layers' widths of `net_arch`, checked."""
        return list(check_layers(self.net_arch))

    def check(self, task) -> None:
        check_network(self)

    def schedule(self, value: float, schedules):
        """`value` as SB3 takes it: a float, or its linear schedule to 0."""
        if self.learning_rate_schedule == "linear":
            return schedules.LinearSchedule(value, 0.0, 1.0)
        return value


@dataclasses.dataclass(frozen=True, kw_only=True)
class ModelSettings(NetworkSettings):
    """What DQN and PPO take: `NetworkSettings` and the gradients' clipping (SAC and TD3
    clip none)."""

    max_grad_norm: float = setting(10.0, per_agent=True)
    """Gradients are clipped to this norm."""

    def check(self, task) -> None:
        super().check(task)
        check_positive("max_grad_norm", self.max_grad_norm)


def torch_modules():
    """`(torch, stable_baselines3)`, imported on demand; a one-line error without them."""
    missing = missing_libraries()
    if missing:
        raise ValueError(f"the Stable-Baselines3 learners need {', '.join(missing)}: {EXTRA}")
    import stable_baselines3
    import stable_baselines3.common.logger  # noqa: F401 (ModelAgents makes its logger)
    import torch
    torch.set_num_threads(1)  # one core per agent, as lwrl's kernels step one agent per thread
    return torch, stable_baselines3


def policy_features(sb3, policy, tensor):
    """`policy.extract_features(tensor)` of an SB3 policy with one features extractor, SB3's
    `FlattenExtractor` (an MLP policy's), op for op: `preprocess_obs` of a Box (a float32 cast),
    then `Flatten(start_dim=1)`; other extractors are called as SB3 calls them."""
    if type(policy.features_extractor) is sb3.common.torch_layers.FlattenExtractor and getattr(
            policy, "share_features_extractor", True):
        return tensor.float().flatten(1)
    return policy.extract_features(tensor)


def sequential_forward(torch, modules, x):
    """The forward pass of `modules` (a `torch.nn.Sequential`, or a list of modules) op for op as
    its `Linear`, `ReLU` and `Tanh` layers compute it (`F.linear`, `torch.relu`, `torch.tanh`),
    the same numbers without each module call's overhead (some 5 us, most of a greedy step's
    forward pass); a module of another kind is called."""
    functional = torch.nn.functional
    for module in modules:
        kind = type(module)
        if kind is torch.nn.Linear:
            x = functional.linear(x, module.weight, module.bias)
        elif kind is torch.nn.ReLU and not module.inplace:
            x = torch.relu(x)
        elif kind is torch.nn.Tanh:
            x = torch.tanh(x)
        else:
            x = module(x)
    return x


def spaces_env(dim: int, action: Space):
    """A Gymnasium environment that only carries the spaces SB3 builds a model for: float64
    observations of `dim` variables (as `lwrl.gym` gives them; SB3's MLP reads them as
    float32) and the discrete actions of `action` (`Discrete`), or for a `Box` (continuous
    actions) one action in `Box(-1, 1)`, float32, the range of lwrl's continuous learners
    (`tasks.commands`), where SB3's own rescaling (`scale_action`, `unscale_action`)
    maps [-1, 1] onto itself. lwrl's loop steps the task itself."""
    import gymnasium
    from gymnasium import spaces

    class Spaces(gymnasium.Env):
        observation_space = spaces.Box(-np.inf, np.inf, (dim,), dtype=np.float64)
        action_space = (spaces.Discrete(action.n) if isinstance(action, Discrete)
                        else spaces.Box(-1.0, 1.0, (1,), dtype=np.float32))

        def reset(self, *, seed=None, options=None):
            super().reset(seed=seed)
            return np.zeros(dim), {}

        def step(self, action):
            raise RuntimeError("lwrl's loop steps the task; this environment only carries spaces")

    return Spaces()


class RandomStates:
    """One agent's copies of the generators SB3 draws from: NumPy's global `np.random`,
    PyTorch's default generator and the action space's own.

    Copying NumPy's state in and out costs more than many a step of a small network, so an
    agent's states stay in the global generators from its `used` to the next agent's (they
    are copied out then): a batch of one agent swaps nothing. lwrl itself draws nothing from
    the global generators; other code that does between an agent's steps draws from that
    agent's stream."""

    owner = None
    """The agent whose states the global generators hold now."""

    def __init__(self, torch, space):
        self.torch, self.space = torch, space
        self.numpy_state = np.random.get_state()
        """NumPy's global generator's state of this agent, while another owns the globals."""
        self.torch_state = torch.get_rng_state()
        """PyTorch's default generator's state of this agent, while another owns it."""

    def _take_over(self) -> None:
        owner = RandomStates.owner
        if owner is self:
            return
        if owner is not None:
            owner._sync()
        np.random.set_state(self.numpy_state)
        self.torch.set_rng_state(self.torch_state)
        RandomStates.owner = self

    def _sync(self) -> None:
        """Copy the global generators' states out into this agent's (it owns them)."""
        self.numpy_state = np.random.get_state()
        self.torch_state = self.torch.get_rng_state()
        RandomStates.owner = None

    @contextlib.contextmanager
    def used(self):
        """Within: the agent's generators are the global ones."""
        self._take_over()
        yield

    def snapshot(self) -> tuple:
        """The generators' states now (within `used`), to give draws back (`restore`)."""
        return np.random.get_state(), self.torch.get_rng_state(), self.space.np_random.bit_generator.state

    def torch_snapshot(self) -> tuple:
        """As `snapshot`, for draws from PyTorch's generator alone."""
        return None, self.torch.get_rng_state(), None

    def restore(self, snapshot) -> None:
        """Set the generators back to `snapshot`'s states (within `used`), giving back the
        draws made since."""
        numpy_state, torch_state, space_state = snapshot
        if numpy_state is not None:
            np.random.set_state(numpy_state)
        self.torch.set_rng_state(torch_state)
        if space_state is not None:
            self.space.np_random.bit_generator.state = space_state

    def saved(self, prefix: str) -> tuple[dict, dict]:
        """`(document, arrays)` of the states."""
        if RandomStates.owner is self:
            self._sync()
        return _rng_saved(prefix, (self.numpy_state, self.torch_state, self.space.np_random.bit_generator.state))

    def load(self, prefix: str, document: dict, arrays: dict) -> None:
        """Take the states `saved` wrote under `prefix`."""
        numpy_state, torch_state, space_state = _rng_loaded(self.torch, prefix, document, arrays)
        self.numpy_state, self.torch_state = numpy_state, torch_state
        self.space.np_random.bit_generator.state = space_state
        if RandomStates.owner is self:
            RandomStates.owner = None


def _rng_saved(prefix: str, states) -> tuple[dict, dict]:
    """Generators' states (NumPy's may be None: not kept) as `(document, arrays)`."""
    numpy_state, torch_state, space_state = states
    arrays = {f"{prefix}torch": torch_state.numpy().copy()}
    document = {"numpy": None, "space": space_state}
    if numpy_state is not None:
        name, keys, position, has_gauss, gauss = numpy_state
        document["numpy"] = [name, int(position), int(has_gauss), float(gauss)]
        arrays[f"{prefix}numpy"] = np.asarray(keys)
    return document, arrays


def _rng_loaded(torch, prefix: str, document: dict, arrays: dict) -> tuple:
    numpy_state = None
    if document["numpy"] is not None:
        name, position, has_gauss, gauss = document["numpy"]
        numpy_state = (name, np.asarray(arrays[f"{prefix}numpy"], dtype=np.uint32), position,
                       has_gauss, gauss)
    torch_state = torch.from_numpy(np.asarray(arrays[f"{prefix}torch"], dtype=np.uint8).copy())
    return numpy_state, torch_state, document["space"]


@contextlib.contextmanager
def global_generators_kept(torch):
    """The caller's global generators (Python's, NumPy's, PyTorch's) as they were, whatever
    SB3 seeds or draws within."""
    states = random.getstate(), np.random.get_state(), torch.get_rng_state()
    try:
        yield
    finally:
        random.setstate(states[0])
        np.random.set_state(states[1])
        torch.set_rng_state(states[2])


def module_state(prefix: str, module) -> dict:
    """A module's state dict as NumPy arrays, keyed `prefix + name`."""
    return {prefix + name: value.detach().cpu().numpy().copy() for name, value in module.state_dict().items()}


def load_module_state(torch, prefix: str, module, arrays: dict) -> None:
    """Load `module_state`'s arrays, keyed `prefix + name`, into `module` (a ValueError
    naming the first that is missing)."""
    names = module.state_dict().keys()
    missing = [name for name in names if prefix + name not in arrays]
    if missing:
        raise ValueError(f"no array {prefix + missing[0]} for the network")
    module.load_state_dict({name: torch.from_numpy(np.array(arrays[prefix + name])) for name in names})


def optimizer_state(prefix: str, optimizer) -> tuple[dict, dict]:
    """An optimiser's state dict as `(param_groups, arrays)` (Adam's moments and steps)."""
    state = optimizer.state_dict()
    arrays = {f"{prefix}{index}.{key}": value.detach().cpu().numpy().copy()
              for index, values in state["state"].items() for key, value in values.items()}
    return state["param_groups"], arrays


def load_optimizer_state(torch, prefix: str, optimizer, groups, arrays: dict) -> None:
    """Load `optimizer_state`'s `(groups, arrays)`, keyed from `prefix`, into `optimizer`."""
    state = {}
    for name, value in arrays.items():
        if name.startswith(prefix):
            index, key = name[len(prefix):].split(".", 1)
            state.setdefault(int(index), {})[key] = torch.from_numpy(np.array(value))
    for group in groups:
        if "betas" in group:
            group["betas"] = tuple(group["betas"])
    optimizer.load_state_dict({"state": state, "param_groups": groups})


def parameter_count(torch, modules) -> int:
    """The number of the modules' parameters."""
    return sum(p.numel() for module in modules for p in module.parameters())


def flat_parameters(torch, modules) -> np.ndarray:
    """The modules' parameters in order, flattened, as float32."""
    return torch.nn.utils.parameters_to_vector(
        [p for module in modules for p in module.parameters()]).detach().cpu().numpy()


def buffer_bytes(entries: int, dim: int, observations: int, scalars: int) -> int:
    """Bytes of a buffer of `entries` transitions: `observations` float64 observation
    vectors, one int64 action and `scalars` float32 numbers each."""
    return entries * (observations * 8 * dim + 8 + 4 * scalars)


def network_bytes(dim: int, layers, outputs: int, copies: int) -> int:
    """Bytes of `copies` float32 copies of an MLP's parameters (the network, its target,
    Adam's two moments, ...)."""
    return copies * 4 * mlp_parameters([dim, *layers, outputs])


class ModelAgents(Agents):
    """B SB3 models, one per agent (see the module). Subclasses build a model (`_model`),
    name its networks (`_networks`, what `arrays.weights` flattens) and take one time step
    of one agent (`_step_one`)."""

    Arrays = collections.namedtuple("Arrays", "q delta diverged weights")
    """What the loops read (`Agents.arrays`), each with a leading axis B; the models hold
    the rest. `q` `(B, A)`: the action values (or preferences) at the latest observation of
    a learner of discrete actions (`value_arrays`)."""
    COUNTERS: tuple = ()
    """The model's counters `saved` keeps (SB3's `num_timesteps`, ...)."""
    PENDING: str = ""
    """The key of `own[b]` saying that the latest recorded transition is one a truncation,
    seen at the next episode's start, must still mark (DQN: `stored`, PPO: `added`)."""

    def _model(self, settings, env, seed):
        """The SB3 model of one agent, built as SB3 builds it with `seed`."""
        raise NotImplementedError

    @staticmethod
    def _networks(model) -> list:
        """The model's networks whose parameters are `arrays.weights`."""
        raise NotImplementedError

    def _fresh(self, b: int) -> dict:
        """Agent b's place in lwrl's loop before its first step (`own[b]`)."""
        raise NotImplementedError

    def _step_one(self, b, first, reward, discount, observation, learn, greedy):
        """One time step of agent b (`Agents.step`'s arguments for it); its action (an
        index, or a number in [-1, 1] for continuous actions)."""
        raise NotImplementedError

    def _record(self, b, reward, discount, observation) -> None:
        """SB3's step after `env.step` for agent b's transition into `observation`."""
        raise NotImplementedError

    def _truncated(self, b) -> None:
        """The episode ended at the latest observation without a terminal state, as SB3
        would have seen at once: give back the draws of the action chosen there and mark
        the transition recorded last (`PENDING`)."""
        raise NotImplementedError

    def _arrive(self, b, first, reward, discount, observation, learn, previous) -> bool:
        """Agent b's part of a time step before it acts: a new episode closes a cut one
        (`_truncated`), a transition is recorded where the agent learns (`_record`). True at
        a terminal state, where it takes no action (its TD error taken against `previous`,
        its value of the transition's state)."""
        own, arrays = self.own[b], self.arrays
        if first:
            if own["open"]:  # the last episode was cut: a truncation, as SB3 would have seen it
                self._truncated(b)
            arrays.delta[b] = np.nan
        else:
            own[self.PENDING] = False
            if self._learning(b, learn):
                self._record(b, reward, discount, observation)
        own["undo"], own["open"] = None, True
        if not first and discount == 0.0:  # a terminal state: no action
            arrays.delta[b] = reward - previous
            own["open"] = False
            return True
        return False

    def _buffer_saved(self, b: int, prefix: str) -> dict:
        raise NotImplementedError

    def _buffer_loaded(self, b: int, prefix: str, arrays: dict) -> None:
        raise NotImplementedError

    @staticmethod
    def _optimizers(model) -> dict:
        """`{name: optimiser}` of the model, which `saved` keeps under each name: the
        policy's one (DQN, PPO)."""
        return {"optimizer": model.policy.optimizer}

    @staticmethod
    def _tensors(model) -> dict:
        """`{name: tensor}`: what the model learns outside its policy (SAC's entropy
        coefficient), which `saved` keeps too."""
        return {}

    def __init__(self, settings, task, seeds):
        self.torch, self.sb3 = torch_modules()
        self.settings = tuple(settings)
        self.task = task
        """The spec of the task the agents learn (`TaskSpec`)."""
        self.dim = len(task.state_names)
        self.seeds = [int(seed) for seed in seeds]
        """The agents' seeds, one each: SB3's `seed` of each model."""
        if len(self.settings) != len(self.seeds):
            raise ValueError(f"{len(self.settings)} settings for {len(self.seeds)} seeds")
        self.models, self.states = [], []
        with global_generators_kept(self.torch):
            for setting_b, seed in zip(self.settings, self.seeds):
                model = self._model(setting_b, spaces_env(self.dim, task.action), seed)
                # SB3's default logger makes a directory under /tmp per model; this one
                # keeps what `train()` records in memory only (`learn()`'s numbers are the same)
                model.set_logger(self.sb3.common.logger.Logger(folder=None, output_formats=[]))
                model._setup_learn(total_timesteps=setting_b.timesteps)
                self.models.append(model)
                self.states.append(RandomStates(self.torch, model.action_space))
        batch = len(self.models)
        weights = np.stack([self._weights(b) for b in range(batch)])
        self.arrays = self.Arrays(**self.value_arrays(batch), delta=np.full(batch, np.nan),
                                  diverged=np.zeros(batch, dtype=bool), weights=weights)
        self.own = [self._fresh(b) for b in range(batch)]
        """Each agent's place in lwrl's loop (`_fresh`): what its next step needs."""

    def value_arrays(self, batch: int) -> dict:
        """`{field: zeros}` of `Arrays` beside `delta`, `diverged` and `weights`: `q`
        `(B, A)` here."""
        return {"q": np.zeros((batch, self.task.action.n))}

    @staticmethod
    def value_arrays_loaded(arrays: dict) -> dict:
        """The saved `arrays` with the fields of `value_arrays` in this layout (a learner
        whose layout changed reads its older files here)."""
        return arrays

    def _weights(self, b: int) -> np.ndarray:
        return flat_parameters(self.torch, self._networks(self.models[b]))

    def _trained(self, b: int) -> None:
        """After `train()`: the flattened weights, and the divergence flag where they are
        not finite (the agent then learns no more)."""
        weights = self._weights(b)
        self.arrays.weights[b] = weights
        if not np.all(np.isfinite(weights)):
            self.arrays.diverged[b] = True

    def _learning(self, b: int, learn: bool) -> bool:
        return learn and self.own[b]["learning"] and not self.arrays.diverged[b]

    def _horizon_reached(self, b: int) -> None:
        """After a whole rollout: past `timesteps`, learning ends (as `learn()` returns)."""
        model = self.models[b]
        if model.num_timesteps >= model._total_timesteps:
            self.own[b]["learning"] = False

    def step(self, first, reward, discount, observation, active=None, learn=True,
             greedy=False) -> np.ndarray:
        observation = self.check_observation(observation)
        batch = self.batch_size
        active = np.ones(batch, dtype=bool) if active is None else np.asarray(active, dtype=bool)
        first, reward = np.asarray(first, dtype=bool), np.asarray(reward, dtype=np.float64)
        discount = np.asarray(discount, dtype=np.float64)
        actions = np.zeros(batch, dtype=np.float64 if self.continuous else np.int64)
        for b in np.flatnonzero(active):
            with self.states[b].used() if self._draws(b, learn, greedy) else contextlib.nullcontext():
                actions[b] = self._step_one(b, bool(first[b]), float(reward[b]),
                                            float(discount[b]), observation[b:b + 1].copy(),
                                            bool(learn), bool(greedy))
        return actions

    def _acts_greedily(self, b: int, learn: bool, greedy: bool) -> bool:
        """Agent b's action is greedy (`predict(deterministic=True)`): where asked, once its
        learning is over (as a model trained by `learn()`), or once it diverged."""
        return greedy or (learn and not self.own[b]["learning"]) or bool(self.arrays.diverged[b])

    def _draws(self, b: int, learn: bool, greedy: bool) -> bool:
        """Whether agent b's step may draw from its generators or give draws back: not a
        step that neither learns nor explores (an evaluation, or past the horizon), unless
        draws of an earlier step are still to be given back. Swapping the generators in
        costs more than such a step's forward pass, so those steps swap none."""
        return (self._learning(b, learn) or not self._acts_greedily(b, learn, greedy)
                or self.own[b]["undo"] is not None)

    def _tensor(self, states):
        return self.torch.as_tensor(np.asarray(states, dtype=np.float64))

    def value_box(self) -> tuple:
        """The task's normalisation ranges (the networks read states in task units)."""
        return self.task.ranges.low, self.task.ranges.high

    def _scratch(self, weights):
        """A copy of agent 0's networks holding `weights` (one agent's `arrays.weights[b]`)."""
        import copy
        networks = [copy.deepcopy(network) for network in self._networks(self.models[0])]
        self.torch.nn.utils.vector_to_parameters(
            self.torch.as_tensor(np.asarray(weights, dtype=np.float32)),
            [p for network in networks for p in network.parameters()])
        return networks

    def _over_agents(self, states, weights, values) -> np.ndarray:
        """`values(networks, states)` for every agent `(B, ..., k)`, or for `weights`."""
        states = np.asarray(states, dtype=np.float64)
        flat = states.reshape(-1, self.dim)
        with self.torch.no_grad():
            if weights is not None:
                result = values(self._scratch(weights), flat)
                return result.reshape(states.shape[:-1] + result.shape[1:])
            results = [values(self._networks(model), flat) for model in self.models]
        return np.stack(results).reshape((len(self.models),) + states.shape[:-1] + results[0].shape[1:])

    def saved(self) -> tuple[dict, dict]:
        document = {"settings": [dataclasses.asdict(s) for s in self.settings], "seeds": self.seeds,
                    "task": spec_document(self.task), "agents": []}
        arrays = self.arrays._asdict()
        for b, model in enumerate(self.models):
            prefix = f"agent{b}."
            entry = {}
            for name, optimizer in self._optimizers(model).items():
                entry[name], optimiser = optimizer_state(f"{prefix}{name}.", optimizer)
                arrays.update(optimiser)
            rng_document, rng_arrays = self.states[b].saved(prefix + "rng.")
            own_document, own_arrays = self._own_saved(b, prefix + "own.")
            document["agents"].append({
                **entry, "rng": rng_document, "own": own_document,
                "model": {name: getattr(model, name) for name in self.COUNTERS}})
            arrays.update(module_state(prefix + "policy.", model.policy), **rng_arrays,
                          **own_arrays, **self._buffer_saved(b, prefix + "buffer."),
                          **{f"{prefix}tensor.{name}": tensor.detach().cpu().numpy().copy()
                             for name, tensor in self._tensors(model).items()})
        return document, arrays

    @classmethod
    def loaded(cls, document: dict, arrays: dict, settings_class):
        """The agents `saved` wrote; a ValueError where the parts do not fit."""
        task = spec_of_document(document["task"])
        settings = [settings_class(**values) for values in document["settings"]]
        agents = cls(settings, task, document["seeds"])
        if len(document["agents"]) != agents.batch_size:
            raise ValueError(f"{len(document['agents'])} agents' states for {agents.batch_size} agents")
        for b in range(agents.batch_size):
            agents._load_agent(b, b, document, arrays)
        arrays = agents.value_arrays_loaded(arrays)
        for name in agents.arrays._fields:
            if name == "diverged":
                continue
            if arrays[name].shape != getattr(agents.arrays, name).shape:
                raise ValueError(f"{name} of shape {arrays[name].shape}; these agents have "
                                 f"{getattr(agents.arrays, name).shape}")
            getattr(agents.arrays, name)[:] = arrays[name]
        return agents

    def _load_agent(self, b: int, source: int, document: dict, arrays: dict) -> None:
        """Agent b becomes agent `source` of what `saved` wrote (`document`, `arrays`): its
        networks, optimiser, generators, counters, buffer and place in the loop."""
        kept, prefix, model = document["agents"][source], f"agent{source}.", self.models[b]
        load_module_state(self.torch, prefix + "policy.", model.policy, arrays)
        for name, optimizer in self._optimizers(model).items():
            load_optimizer_state(self.torch, f"{prefix}{name}.", optimizer, kept[name], arrays)
        with self.torch.no_grad():
            for name, tensor in self._tensors(model).items():
                tensor.copy_(self.torch.from_numpy(np.array(arrays[f"{prefix}tensor.{name}"])))
        self.states[b].load(prefix + "rng.", kept["rng"], arrays)
        for counter, value in kept["model"].items():
            setattr(model, counter, value)
        self._buffer_loaded(b, prefix + "buffer.", arrays)
        self.own[b] = self._own_loaded(b, prefix + "own.", kept["own"], arrays)

    def take_over(self, kept: "ModelAgents") -> None:
        """As `Agents.take_over`: each model loads its kept model's state (`_load_agent`)."""
        copies = self.copies_of(kept)
        document, arrays = kept.saved()
        for b in range(self.batch_size):
            self._load_agent(b, b % kept.batch_size, document, arrays)
        for name, values in kept.arrays._asdict().items():
            getattr(self.arrays, name)[:] = np.concatenate([values] * copies)

    def _own_saved(self, b: int, prefix: str) -> tuple[dict, dict]:
        """`(document, arrays)` of the agent's place in lwrl's loop (`own[b]`): flags and
        numbers in the document, arrays and tensors as arrays, a snapshot of the generators
        as its parts."""
        document, arrays = {}, {}
        for key, value in self.own[b].items():
            if key == "undo" and value is not None:
                document[key], undo_arrays = _rng_saved(prefix + "undo.", value)
                arrays.update(undo_arrays)
            elif isinstance(value, np.ndarray):
                arrays[prefix + key] = value
                document[key] = "array"
            elif hasattr(value, "detach"):
                arrays[prefix + key] = value.detach().cpu().numpy().copy()
                document[key] = "tensor"
            else:
                document[key] = value.item() if isinstance(value, np.generic) else value
        return document, arrays

    def _own_loaded(self, b: int, prefix: str, document: dict, arrays: dict) -> dict:
        own = {}
        for key, value in document.items():
            if key == "undo" and value is not None:
                own[key] = _rng_loaded(self.torch, prefix + "undo.", value, arrays)
            elif value == "array":
                own[key] = np.array(arrays[prefix + key])
            elif value == "tensor":
                own[key] = self.torch.from_numpy(np.array(arrays[prefix + key]))
            else:
                own[key] = value
        return own


def load_arrays(buffer, prefix: str, arrays: dict, names) -> None:
    """Fill a buffer's arrays from `arrays` (its first `len(saved)` entries) and its place."""
    for name in names:
        saved = arrays[prefix + name]
        getattr(buffer, name)[:len(saved)] = saved
    buffer.pos = int(arrays[prefix + "pos"])
    buffer.full = bool(arrays[prefix + "full"])


def saved_arrays(buffer, prefix: str, names) -> dict:
    """A buffer's filled entries and its place, as arrays."""
    used = buffer.buffer_size if buffer.full else buffer.pos
    found = {prefix + name: getattr(buffer, name)[:used].copy() for name in names}
    return {**found, prefix + "pos": np.array(buffer.pos), prefix + "full": np.array(buffer.full)}


def td_error(reward: float, discount: float, gamma: float, next_value: float, value: float) -> float:
    """r + gamma d V(s') - V(s), the one-step TD error the loops record (d = 0: terminal)."""
    return reward + (gamma * discount * next_value if discount > 0.0 else 0.0) - value


