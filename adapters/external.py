"""lwrl's agents on other suites' environments: dm_control's suite (`dmc:DOMAIN.TASK`) and
Gymnasium (`gym:ID`), any with a Box observation of at most `MAX_DIMENSIONS` dimensions.

An adapter (`DmEnvAdapter`, `GymAdapter`) shows the agent an external environment as it sees
lwrl's own tasks: a dm_env environment with a flat float64 observation `(d,)` and actions
`0..A-1`.

- **Actions**: a discrete action space is used by index. A continuous one-dimensional action
  (dm_control's suite: a force or torque in [-1, 1]) is discretised into given values, e.g.
  `(-1, 0, 1)`, each checked against the action's bounds.
- **Episode ends**: a terminal state has discount 0, the agent bootstraps from anything else.
  dm_env's time steps pass as they are (dm_control's suite has no terminal states: its
  episodes end at the time limit with discount 1); Gymnasium's `terminated` is a terminal
  state and `truncated` (a time limit) is not.
- **Seeding**: the run's environment b gets the seed `seed + b`, as its agent: dm_control's
  task `random`, Gymnasium's first `reset(seed=...)`.
- **Observation box**: the NRBF normalises each dimension from `[low, high]` to `[0, 1]` with
  centroids inside; values outside are not an error, they weigh on the edge centroids
  (`agent.nrbf`). The box comes from the command line, the environment's preset
  (`EXTERNAL_PRESETS`) or the observation space's bounds where all are finite.

Gymnasium is optional: it is imported only for `gym:` names.
"""

import dataclasses
import json
import math
import warnings

import dm_env
import numpy as np
from dm_env import specs

from lwrl import agent as learners
from lwrl.agent.features import check_box
from lwrl.agent.learner_contract import Agents
from lwrl.runners.config import LearnerChoice, ProtocolSettings, compose
from lwrl.runners.run import EpisodeResults, run_batched
from lwrl.settings import check_choices, fill
from lwrl.spaces import Box, Discrete, TaskSpec
from lwrl.tasks.batched import SteppedEnvs, flatten_observation

MAX_DIMENSIONS = 6
"""Most observation dimensions accepted: the NRBF grid has n^d neurons (6^6 = 46,656)."""

EXTERNAL_PRESETS = {
    # Gymnasium's Mountain-Car is the paper's task but for its 200-step limit: the paper's
    # grid (the goal x = 0.5 ends the episode, so the box stops there), agent and protocol.
    "gym:MountainCar-v0": dict(
        low=(-1.2, -0.07), high=(0.5, 0.07), n=8, trace="replacing", alpha=3.9, lam=0.9,
        epsilon=0.0, gamma=1.0, episodes=100, agents=10),
    # x, x', theta, theta': the paper's cart-pole grid and agent (Gymnasium fails at 12 deg too).
    "gym:CartPole-v1": dict(
        low=(-2.4, -1.5, -math.radians(12), -5 * math.pi / 6),
        high=(2.4, 1.5, math.radians(12), 5 * math.pi / 6), n=6, trace="accumulating",
        alpha=0.5, lam=0.7, epsilon=0.1, gamma=1.0, episodes=300, agents=10),
    # x, cos, sin, x', theta' (theta = 0 up): balance starts within 2 deg of upright, so the
    # box covers the upper half of the circle finely; swing-up needs all of it.
    "dmc:cartpole.balance": dict(
        low=(-1.8, 0.7, -0.7, -3.0, -5.0), high=(1.8, 1.0, 0.7, 3.0, 5.0), actions=(-1.0, 0.0, 1.0),
        n=5, trace="replacing", alpha=1.0, lam=0.9, epsilon=0.05, gamma=0.99, episodes=200,
        agents=5),
    "dmc:cartpole.swingup": dict(
        low=(-1.8, -1.0, -1.0, -5.0, -10.0), high=(1.8, 1.0, 1.0, 5.0, 10.0),
        actions=(-1.0, 0.0, 1.0), n=5, trace="replacing", alpha=1.0, lam=0.9, epsilon=0.05,
        gamma=0.99, episodes=200, agents=5),
    # cos, sin, theta'.
    "dmc:pendulum.swingup": dict(
        low=(-1.0, -1.0, -8.0), high=(1.0, 1.0, 8.0), actions=(-1.0, 0.0, 1.0), n=10,
        trace="replacing", alpha=1.5, lam=0.9, epsilon=0.1, gamma=0.99, episodes=300, agents=10),
}
"""Per environment: the observation box, the action values (continuous actions), the NRBF
centroids per dimension, the agent and the protocol (episodes, agents)."""

DEFAULTS = dict(n=6, trace="replacing", alpha=0.5, lam=0.7, epsilon=0.1, gamma=0.99,
                episodes=100, agents=10)
"""Settings of environments without a preset. gamma < 1 because time limits are not terminal
states: with positive rewards an undiscounted value would grow without bound."""


def check_dimensions(name: str, dim: int) -> int:
    """The observation dimension `dim`, or a one-line error if the NRBF cannot take it."""
    if not 1 <= dim <= MAX_DIMENSIONS:
        raise ValueError(f"{name} has {dim} observation dimensions; the NRBF grid (n^d neurons) "
                         f"takes 1 to {MAX_DIMENSIONS}")
    return dim


def action_table(name: str, values, low, high, shape, dtype) -> np.ndarray:
    """The environment actions `(A, *shape)` of a continuous action discretised into `values`,
    or a one-line error (no values, a value outside `[low, high]`, a multi-dimensional action)."""
    low, high = float(np.min(low)), float(np.max(high))
    if int(np.prod(shape)) != 1:
        raise ValueError(f"{name} has a continuous action of shape {tuple(shape)}; only "
                         "one-dimensional actions can be discretised")
    if values is None or len(values) == 0:
        raise ValueError(f"{name} has a continuous action in [{low:g}, {high:g}]: give the "
                         f"values to use, e.g. --actions {low:g},0,{high:g}")
    values = np.asarray(values, dtype=np.float64)
    outside = values[~((values >= low) & (values <= high))]
    if len(outside):
        raise ValueError(f"{name}: action value {outside[0]:g} is outside the action's bounds "
                         f"[{low:g}, {high:g}]")
    return values.reshape((-1,) + tuple(shape)).astype(dtype)


class ExternalEnv(dm_env.Environment):
    """What the agent sees of an external environment: flat float64 observations `(d,)`
    (`low`, `high`: the observation space's bounds, +-inf where it has none) and actions
    `0..num_actions-1`, mapped by `env_action`."""

    def __init__(self, name: str, low, high):
        self.name = name
        self.low = np.asarray(low, dtype=np.float64)
        self.high = np.asarray(high, dtype=np.float64)
        self.dim = check_dimensions(name, len(self.low))
        self.num_actions = 0
        self._table, self._offset = None, 0

    def _use_discrete(self, count: int, values, offset: int = 0) -> None:
        """Actions by index: `offset + index` (no values may be given)."""
        if values is not None:
            raise ValueError(f"{self.name} has {count} discrete actions, used by index: action "
                             "values (--actions) apply to continuous actions only")
        self.num_actions, self._offset = count, offset

    def _use_values(self, values, low, high, shape, dtype) -> None:
        """A continuous action discretised into `values` (`action_table`)."""
        self._table = action_table(self.name, values, low, high, shape, dtype)
        self.num_actions = len(self._table)

    def env_action(self, index):
        """The environment's action for the agent's action `index`."""
        if not 0 <= index < self.num_actions:
            raise ValueError(f"{self.name}: action index must be in 0..{self.num_actions - 1}; "
                             f"got {index}")
        return self._offset + int(index) if self._table is None else self._table[index]

    def observation_spec(self):
        return specs.Array((self.dim,), np.float64, name="observation")

    def action_spec(self):
        return specs.DiscreteArray(self.num_actions, name="action")


class DmEnvAdapter(ExternalEnv):
    """A dm_env environment (dm_control's suite) with flattened observations and discrete
    actions; a continuous action spec is discretised into `actions`."""

    def __init__(self, env, name: str, actions=None):
        self.env = env
        observation_specs = env.observation_spec()
        if hasattr(observation_specs, "values"):
            observation_specs = list(observation_specs.values())
        else:
            observation_specs = [observation_specs]
        low, high = [], []
        for spec in observation_specs:
            bounded = isinstance(spec, specs.BoundedArray)
            low.append(np.broadcast_to(spec.minimum if bounded else -np.inf, spec.shape).ravel())
            high.append(np.broadcast_to(spec.maximum if bounded else np.inf, spec.shape).ravel())
        super().__init__(name, np.concatenate(low), np.concatenate(high))
        spec = env.action_spec()
        if isinstance(spec, specs.DiscreteArray):
            self._use_discrete(spec.num_values, actions)
        elif isinstance(spec, specs.BoundedArray):
            self._use_values(actions, spec.minimum, spec.maximum, spec.shape, spec.dtype)
        else:
            raise ValueError(f"{name}: the action spec has no bounds ({spec}); discrete or "
                             "bounded actions are supported")

    def reset(self):
        ts = self.env.reset()
        return ts._replace(observation=flatten_observation(ts.observation))

    def step(self, action):
        ts = self.env.step(self.env_action(action))
        return ts._replace(observation=flatten_observation(ts.observation))


class GymAdapter(ExternalEnv):
    """A Gymnasium environment as a dm_env one: `terminated` is a terminal state (discount
    0), `truncated` ends the episode with discount 1; stepped after its end it resets. The
    first reset uses `seed`."""

    def __init__(self, env, name: str, seed: int, actions=None):
        spaces = _gymnasium().spaces
        self.env = env
        observations, action_space = env.observation_space, env.action_space
        if not isinstance(observations, spaces.Box):
            raise ValueError(f"{name} observes a {observations}; only Box observations of 1 to "
                             f"{MAX_DIMENSIONS} dimensions are supported")
        super().__init__(name, np.ravel(observations.low), np.ravel(observations.high))
        if isinstance(action_space, spaces.Discrete):
            self._use_discrete(int(action_space.n), actions, offset=int(action_space.start))
        elif isinstance(action_space, spaces.Box):
            self._use_values(actions, action_space.low, action_space.high, action_space.shape,
                             action_space.dtype)
        else:
            raise ValueError(f"{name} acts with a {action_space}; Discrete or one-dimensional "
                             "Box actions are supported")
        self._seed = seed
        self._ended = True

    def reset(self):
        observation, _ = self.env.reset(seed=self._seed)
        self._seed = None  # later resets continue the seeded generator
        self._ended = False
        return dm_env.restart(flatten_observation(observation))

    def step(self, action):
        if self._ended:
            return self.reset()
        observation, reward, terminated, truncated, _ = self.env.step(self.env_action(action))
        observation, reward = flatten_observation(observation), float(reward)
        self._ended = bool(terminated or truncated)
        if terminated:
            return dm_env.termination(reward, observation)
        if truncated:
            return dm_env.truncation(reward, observation)
        return dm_env.transition(reward, observation)


def _gymnasium():
    try:
        import gymnasium
    except ImportError:
        raise ValueError("gym: environments need gymnasium: pip install 'lwrl[gymnasium]'") from None
    return gymnasium


def load(name: str, seed: int, actions=None) -> ExternalEnv:
    """The environment `dmc:DOMAIN.TASK` (dm_control's suite, task seeded with `seed`) or
    `gym:ID` (Gymnasium, first reset seeded with `seed`), adapted; `actions`: the values of a
    continuous action."""
    prefix, colon, rest = name.partition(":")
    if colon and prefix == "dmc":
        domain, dot, task = rest.partition(".")
        if not (domain and dot and task):
            raise ValueError(f"dm_control environments are written dmc:DOMAIN.TASK, e.g. "
                             f"dmc:cartpole.balance; got {name!r}")
        with warnings.catch_warnings():  # GLFW's warning that there is no display: lwrl never renders
            warnings.simplefilter("ignore")
            from dm_control import suite
        try:
            env = suite.load(domain, task, task_kwargs={"random": seed})
        except ValueError as error:
            raise ValueError(f"{name}: {error}") from None
        return DmEnvAdapter(env, name, actions)
    if colon and prefix == "gym" and rest:
        gymnasium = _gymnasium()
        try:
            env = gymnasium.make(rest)
        except gymnasium.error.Error as error:
            raise ValueError(f"{name}: {error}") from None
        return GymAdapter(env, name, seed, actions)
    raise ValueError(f"external environments are written dmc:DOMAIN.TASK (dm_control's suite) "
                     f"or gym:ID (Gymnasium); got {name!r}")


def is_external(name: str) -> bool:
    """True for names of other suites' environments (`dmc:...`, `gym:...`)."""
    return name.partition(":")[0] in ("dmc", "gym") and ":" in name


@dataclasses.dataclass(frozen=True, kw_only=True)
class ExternalEnvironment:
    """Another suite's environment."""

    env: str = dataclasses.field(metadata={"cli": False})
    """`dmc:DOMAIN.TASK` (dm_control's suite) or `gym:ID` (Gymnasium)."""
    actions: tuple | None = None
    """The values a continuous action is discretised into, comma-separated (one per agent
    action; not for discrete actions)."""


@dataclasses.dataclass(frozen=True, kw_only=True, init=False)
class ExternalConfig(LearnerChoice, ProtocolSettings, ExternalEnvironment):
    """One run: B agents, each on its own copy of an external environment (agent b and its
    environment seeded with `seed + b`). `ExternalConfig(env=..., learner=..., **settings)`
    as `RunConfig`. Fields left None take the environment's preset (`EXTERNAL_PRESETS`),
    then `DEFAULTS`, each where the learner has that setting; the observation box (`low`,
    `high`: one value per observation dimension, the learner's normalisation ranges), then
    the observation space's finite bounds (`prepare`). The learner must take a box (a
    linear learner's `low` and `high`)."""

    def __init__(self, **values):
        preset = {**DEFAULTS, **EXTERNAL_PRESETS.get(values.get("env"), {})}
        if values.get("low") is not None or values.get("high") is not None:
            preset.pop("low", None)  # an explicit box replaces the preset's
            preset.pop("high", None)
        compose(self, values, preset)
        check_choices(self)
        names = {field.name for field in dataclasses.fields(self.settings)}
        if not {"low", "high"} <= names:
            raise ValueError(f"{self.learner} takes no observation box (low, high): other "
                             "suites' environments run learners that do")
        if self.low is not None or self.high is not None:
            fill(self, settings=dataclasses.replace(self.settings, **dict(zip(
                ("low", "high"), check_box(self.low, self.high)))))
        if self.actions is not None:
            fill(self, actions=tuple(float(value) for value in self.actions))
        self.check_protocol()

    @property
    def low(self):
        """The observation box's lower ends (the learner's `low`), or None."""
        return self.settings.low

    @property
    def high(self):
        """The observation box's upper ends (the learner's `high`), or None."""
        return self.settings.high

    def task_spec(self, env) -> TaskSpec:
        """What the learner may know of the environment `env` (an `ExternalEnv`): its
        observation bounds and discrete actions, the run's observation box as its ranges;
        its timestep and step limit are the environment's own, unknown here (NaN, inf)."""
        ranges = None if self.low is None else Box(self.low, self.high)
        return TaskSpec(self.env, Box(env.low, env.high), Discrete(env.num_actions),
                        tuple(f"observation[{j}]" for j in range(env.dim)), math.nan,
                        math.inf, {}, ranges)

    def describe(self) -> str:
        return self.settings.describe(len(self.low))

    def to_json(self) -> str:
        return json.dumps(dataclasses.asdict(self), indent=2)


def observation_box(config: ExternalConfig, env: ExternalEnv) -> tuple[tuple, tuple]:
    """The run's NRBF box: the config's, one range per observation dimension, or else the
    observation space's bounds if all are finite; a one-line error otherwise."""
    if config.low is None:
        unbounded = np.flatnonzero(~(np.isfinite(env.low) & np.isfinite(env.high)))
        if len(unbounded):
            raise ValueError(f"{config.env}: observation dimensions "
                             f"{', '.join(map(str, unbounded))} have no finite bounds: give "
                             f"--low and --high with one value for each of its {env.dim} dimensions")
        return check_box(env.low, env.high)
    if len(config.low) != env.dim:
        raise ValueError(f"{config.env} has {env.dim} observation dimensions; got "
                         f"{len(config.low)} ranges (--low, --high: one value per dimension)")
    return config.low, config.high


def prepare(config: ExternalConfig) -> tuple[ExternalConfig, Agents, SteppedEnvs]:
    """The run's environments (b seeded with `seed + b`), its config with the observation box
    checked against them, and its untrained agents."""
    envs = [load(config.env, seed, config.actions) for seed in config.seeds]
    low, high = observation_box(config, envs[0])
    config = dataclasses.replace(config, settings=dataclasses.replace(config.settings, low=low, high=high))
    info = config.task_spec(envs[0])
    learner = learners.learner(config.learner)
    reason = learner.fits(info)
    if reason is not None:
        raise ValueError(reason)
    learner.check_installed()
    config.settings.check(info)
    agent = learner.make([config.settings] * config.agents, info, config.seeds)
    return config, agent, SteppedEnvs(envs)


def run_external(config: ExternalConfig, progress=None,
                 ) -> tuple[ExternalConfig, Agents, EpisodeResults]:
    """Train a config's agents (`run_batched`): the config with its observation box, the
    agents and their results (up-time NaN; Ctrl-C keeps the finished episodes)."""
    config, agent, envs = prepare(config)
    return config, agent, run_batched(envs, agent, config.episodes, progress=progress)
