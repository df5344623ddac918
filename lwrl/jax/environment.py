"""A task of the suite as a gymnax-style JAX environment: pure `reset` and `step` that `jit`
and `vmap`, the physical parameters apart from the state.

As in gymnax (Lange 2022), an environment is an object without state of its own: the
episode's state (`EnvState`) and the domain's physical parameter values (`params`, the
vector `(P,)` of `Domain.parameters`, gymnax's `EnvParams`) travel as arrays, so that one
program can `vmap` over agents and over parameter values (randomised physics). Unlike gymnax
< 1.0 (and rejax on it), `step` returns `terminated` and `truncated` apart: a time limit is
not a terminal state, and a learner bootstraps from it.

An action is the task's (`make(..., actions=...)`, `tasks.task_definition.ACTIONS`): an index
into its discrete controls (the paper's tasks), or with `actions="continuous"` the control
itself, clipped to the actuator's range at the step's `params` (`Environment.action_range`),
as the NumPy environments clip it; the delay and the noise then act on either alike.

The sensors and the actuator (`Sensors`: observation noise, action delay and action noise,
`tasks.disturbances`) travel as arrays too, so that one program serves every noise level
and every delay up to the longest its transit buffer holds, and a batch's agents may each
have their own.

Every function of the task is the suite's own (`lwrl.jax.translate`): the analytic plant's
step of `tasks/<domain>.py` with its Euler scheme and equations, the start distribution,
the observation, `outcome` (reward, termination, up-time) and `advance_episode` (the time
limit), traced by JAX instead of compiled by numba. On the `mjx` plant (`make(...,
plant="mjx")`, `lwrl.jax.mjx`) the step is MuJoCo's model's, stepped by MJX, the rest alike.
"""

import dataclasses
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from lwrl import tasks
from lwrl.jax.translate import as_jax
from lwrl.tasks.integrators import check_integrator
from lwrl.tasks.plants import check_equations
from lwrl.spaces import Box, Discrete
from lwrl.tasks.task_definition import advance_episode


class EnvState(NamedTuple):
    """One environment's episode (a pytree: every field an array)."""

    physics: Any
    """The plant's state `(d,)` in the task's order (angles not wrapped)."""
    steps: Any
    """Steps taken in the episode (int32)."""
    uptime: Any
    """Seconds of up-time so far (NaN for a task without up-time)."""
    transit: Any
    """`(Sensors.max_delay,)`: the latest controls commanded, the newest first (0 at a
    start); those of the last `action_delay` steps are in transit, not yet applied."""


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Sensors:
    """An environment's sensors and actuator, the options of `tasks.disturbances`, as arrays
    (a pytree, traced as `params` is, so that one compiled program serves every value; a
    leading axis B for a batch whose environments each have their own). `Sensors.of` checks
    and builds them."""

    observation_noise: Any
    """`(d,)`: per state variable, the standard deviation of the observation's Gaussian noise."""
    action_delay: Any
    """Control steps between a command and its application (0 applied before one arrives;
    int32, at most `max_delay`)."""
    action_noise: Any
    """Standard deviation of the applied control's noise, clipped to the actuator's range
    (`Environment.action_range`)."""
    max_delay: int = dataclasses.field(default=0, metadata={"static": True})
    """The longest delay of the batch: the length of the transit buffer (`EnvState.transit`),
    which shapes the program (static), where the delays themselves are data."""

    @classmethod
    def of(cls, definition, dtype, batch_size=None, observation_noise=None, action_delay=0,
           action_noise=0.0) -> "Sensors":
        """The options as `tasks.disturbances.Disturbances` takes and checks them (a one-line
        ValueError names a bad one): one environment's, or with `batch_size` B arrays with a
        leading axis B, each option one value for every environment or B values."""
        noise = tasks.disturbances.Disturbances(
            definition.state_names, definition.control_range, batch_size,
            observation_noise=observation_noise, action_delay=action_delay,
            action_noise=action_noise)
        rows = slice(None) if batch_size is not None else 0
        return cls(observation_noise=jnp.asarray(noise.sigma_observation[rows], dtype),
                   action_delay=jnp.asarray(noise.delay[rows], jnp.int32),
                   action_noise=jnp.asarray(noise.sigma_action[rows], dtype),
                   max_delay=int(noise.delay.max()))


class StartDraws:
    """A NumPy Generator's `uniform` as a task's `initial_states(rng, count)` calls it, drawn
    from a JAX key: `low + (high - low) u`, u ~ U[0, 1), as NumPy computes it."""

    def __init__(self, key, dtype):
        self.key, self.dtype = key, dtype

    def uniform(self, low=0.0, high=1.0, size=None):
        """`low + (high - low) u` of shape `size` (a number where None), from the next key."""
        self.key, key = jax.random.split(self.key)
        shape = () if size is None else tuple(np.atleast_1d(size))
        unit = jax.random.uniform(key, shape, dtype=self.dtype)
        low, high = jnp.asarray(low, self.dtype), jnp.asarray(high, self.dtype)
        return low + (high - low) * unit


@dataclasses.dataclass(frozen=True, eq=False)
class Environment:
    """`DOMAIN.TASK` on the analytic plant, in JAX (`lwrl.jax.make` builds it; on the mjx
    plant, `lwrl.jax.mjx.MjxEnvironment`).

        obs, state = env.reset(key, params)
        obs, state, reward, terminated, truncated, info = env.step(key, state, action, params)

    `step` starts a new episode where one ended (gymnax's auto-reset): `obs` is then the new
    start's and `info["final_observation"]` the episode's last; `info` also holds the
    `discount` (0 at a terminal state), the ended episode's `steps` and `uptime`.
    `reset_env` and `step_env` are the same without the automatic reset. The action is an
    index into the task's discrete controls (`num_actions`); an index outside them takes
    the nearest end, as JAX's indexing does, unchecked inside a traced program. With
    `actions="continuous"` it is the control itself, a number or an array of shape (1,),
    clipped to `action_range(params)` (`command`); `num_actions` then raises the task's
    one-line ValueError.

    Each function also takes `sensors` (`Sensors`, from `env.sensors(...)`; None: those of
    `make`'s options, `default_sensors`); an episode keeps the sensors it started with, as
    its transit buffer is as long as their `max_delay`.
    """

    name: str
    """DOMAIN.TASK."""
    definition: Any
    """The task's `TaskDefinition` (its options applied)."""
    dtype: Any
    """The floating-point type of states, observations and rewards."""
    semi_implicit: bool
    """The integrator: semi-implicit Euler (True) or explicit Euler (False)."""
    slips: bool
    """The equations: kfnnet's, with the slips (True), or the paper's (False)."""
    default_sensors: Sensors
    """The sensors and actuator of `make`'s options, where a call is given none."""

    @property
    def num_actions(self) -> int:
        """The number of discrete actions (a one-line ValueError with continuous actions,
        `TaskDefinition.num_actions`)."""
        return self.definition.num_actions

    @property
    def observation_size(self) -> int:
        """The length of an observation: the task's state variables."""
        return len(self.definition.state_names)

    @property
    def default_params(self):
        """The task's physical parameter values `(P,)` (the paper's unless `params` was
        given to `make`)."""
        return jnp.asarray(self.definition.physical, dtype=self.dtype)

    def sensors(self, batch_size=None, observation_noise=None, action_delay=0,
                action_noise=0.0) -> Sensors:
        """The sensor and actuator options as the functions take them (`Sensors.of`): one
        environment's, or B environments' with `batch_size` B, each option one value or B
        values, for a `vmap` over the batch."""
        return Sensors.of(self.definition, self.dtype, batch_size, observation_noise,
                          action_delay, action_noise)

    def check_params(self, params):
        """`params` as an array of the environment's type, or a one-line ValueError unless
        its last axis holds one value per parameter (checked when traced: shapes are
        static)."""
        names = tasks.domain(self.definition.domain).parameters.names
        params = jnp.asarray(params, dtype=self.dtype)
        if params.shape[-1:] != (len(names),):
            raise ValueError(f"params must hold {len(names)} values ({', '.join(names)}) in its "
                             f"last axis; got shape {params.shape}")
        return params

    def action_range(self, params=None):
        """`(low, high)`: the actuator's range at the parameter values `params` `(P,)` (None:
        `default_params`), `TaskDefinition.control_range_at` traced (the lowest and the
        highest discrete control, so it moves with the parameters that set them). A
        continuous action is clipped to it, and the action noise in either kind
        (`action_space(params)` is the Box on it)."""
        controls = self._controls_at(self.check_params(
            self.default_params if params is None else params))
        return controls[0], controls[-1]

    def action_space(self, params=None):
        """gymnax's `action_space(params)` (`lwrl.spaces`): `Discrete(A)` of the task's
        action indices, or with continuous actions the `Box` of shape (1,) of the actuator's
        range at `params` (None: `default_params`; concrete values, outside `jit`: a space
        is a description, not an array)."""
        if not self.definition.continuous:
            return Discrete(self.num_actions)
        low, high = self.action_range(params)
        return Box((float(low),), (float(high),))

    def observation_space(self, params=None):
        """gymnax's `observation_space(params)` (`lwrl.spaces`): the `Box` of the task's
        bounds (`TaskDefinition.bounds`, the same at every `params`), unbounded in the
        variables `make`'s sensors add noise to."""
        noisy = np.asarray(self.default_sensors.observation_noise) > 0
        return tasks.spec_of(self.definition).observation.unbounded_where(noisy)

    def _controls_at(self, params):
        """`(A,)`: each discrete action's control at the parameter values `params` `(P,)`,
        ascending: the task's `controls_of`, traced by JAX (`as_jax`)."""
        return jnp.stack([jnp.broadcast_to(jnp.asarray(c, self.dtype), ()) for c in
                          as_jax(self.definition.controls_of, self.dtype)(params)])

    def plant(self, physics, control, params):
        """The analytic plant's next state `(d,)`: the domain's `step` with the Euler scheme
        and the equations bound, as `tasks.plants.DomainPlants.batch` binds it."""
        plants = tasks.domain(self.definition.domain).plants
        step = as_jax(plants.step, self.dtype)
        if plants.euler:
            columns = step(*physics, control, plants.timestep, self.semi_implicit, self.slips,
                           params)
        else:
            columns = step(*physics, control, params)
        return jnp.stack(columns).astype(self.dtype)

    def observe(self, key, physics, sensors: Sensors):
        """The agent's observation of `physics`: the task's, plus the sensors' noise sigma_j
        z_j where sigma_j > 0 (z ~ N(0, 1) drawn from `key` for every variable, so that the
        draws do not depend on the noise levels)."""
        observation = as_jax(self.definition.observe, self.dtype)(physics)
        sigma = jnp.asarray(sensors.observation_noise, self.dtype)
        noisy = observation + sigma * jax.random.normal(key, observation.shape, self.dtype)
        return jnp.where(sigma > 0.0, noisy, observation)

    def reset_env(self, key, params=None, sensors=None):
        """`(observation, EnvState)` of a new episode from the task's start distribution."""
        self.check_params(self.default_params if params is None else params)
        start_key, noise_key = jax.random.split(key)
        draw = as_jax(self.definition.initial_states, self.dtype)
        return self.start(noise_key, draw(StartDraws(start_key, self.dtype), 1)[0], sensors)

    def start(self, key, physics, sensors=None):
        """`(observation, EnvState)` of an episode starting in the plant state `physics`
        `(d,)` (a start drawn elsewhere, e.g. the protocol's from each agent's seed)."""
        sensors = self.default_sensors if sensors is None else sensors
        physics = jnp.asarray(physics, self.dtype)
        state = EnvState(physics=physics, steps=jnp.int32(0),
                         uptime=jnp.asarray(self.definition.initial_uptime, self.dtype),
                         transit=jnp.zeros(sensors.max_delay, self.dtype))
        return self.observe(key, physics, sensors), state

    reset = reset_env
    """`(observation, EnvState)` of a new episode: gymnax's `reset`."""

    def command(self, action, params):
        """The control that `action` commands at the parameter values `params`, before the
        actuator's delay and noise (`tasks.base.SuiteTask._command`): the discrete action's,
        or the continuous action (`continuous_action`) clipped to `action_range(params)`, as
        an actuator saturates."""
        if self.definition.continuous:
            return jnp.clip(self.continuous_action(action), *self.action_range(params))
        return self._controls_at(params)[action]

    def continuous_action(self, action):
        """A continuous `action` as the control it stands for, shape (), the environment's
        type; a one-line ValueError unless it is one real number (shape () or (1,)), and,
        where it is concrete (not traced by `jit` or `vmap`), a finite one, as
        `TaskDefinition.saturate` refuses. Inside a traced program its value cannot be
        refused: an infinity is clipped to the range's end and a NaN passes the clip and
        propagates into the state, as in gymnax."""
        traced = isinstance(action, jax.core.Tracer)
        values = action if traced else np.asarray(action)
        real = values.dtype.kind in "iuf" and values.shape in ((), (1,))
        if not (real and (traced or np.all(np.isfinite(values)))):
            given = f"a traced {values.dtype} of shape {values.shape}" if traced else repr(
                values.tolist())
            raise ValueError(f"action must be one finite {self.definition.control_name}, a "
                             f"number or an array of shape (1,) (clipped to the actuator's "
                             f"range, action_range(params)); got {given}")
        return jnp.asarray(action, self.dtype).reshape(())

    def control(self, key, state: EnvState, action, params, sensors: Sensors):
        """`(applied control, transit)`: the action's control (`command`), after the
        actuator's delay (the command of `action_delay` steps ago, 0 before it arrives) and
        noise (sigma z clipped to the actuator's range where sigma > 0), as
        `tasks.disturbances.applied_control`."""
        commanded = self.command(action, params)
        applied, transit = commanded, state.transit
        if transit.shape[0] != sensors.max_delay:
            raise ValueError(f"an episode whose transit buffer holds {transit.shape[0]} commands "
                             f"stepped with sensors of delays up to {sensors.max_delay}: start "
                             "the episode with the sensors it steps with")
        if sensors.max_delay:
            delay = sensors.action_delay
            applied = jnp.where(delay > 0, transit[jnp.maximum(delay, 1) - 1], commanded)
            transit = jnp.concatenate([commanded[None], transit[:-1]])
        sigma = jnp.asarray(sensors.action_noise, self.dtype)
        noisy = jnp.clip(applied + sigma * jax.random.normal(key, (), self.dtype),
                         *self.action_range(params))
        return jnp.where(sigma > 0.0, noisy, applied), transit

    def step_env(self, key, state: EnvState, action, params=None, sensors=None):
        """One control step without the automatic reset: `(observation, EnvState, reward,
        terminated, truncated, info)`."""
        params = self.check_params(self.default_params if params is None else params)
        sensors = self.default_sensors if sensors is None else sensors
        actuator_key, sensor_key = jax.random.split(key)
        control, transit = self.control(actuator_key, state, action, params, sensors)
        definition = self.definition
        physics = self.plant(state.physics, control, params)
        reward, terminal, up = as_jax(definition.outcome, self.dtype)(
            *physics, *definition.params, params)
        terminal = jnp.asarray(terminal, bool)
        steps, uptime, last = as_jax(advance_episode, self.dtype)(
            state.steps, state.uptime, jnp.asarray(up, self.dtype), terminal,
            definition.control_timestep, min(definition.step_limit, np.iinfo(np.int32).max))
        state = EnvState(physics=physics, steps=steps, uptime=uptime.astype(self.dtype),
                         transit=transit)
        truncated = last & ~terminal
        info = {"discount": jnp.where(terminal, 0.0, 1.0).astype(self.dtype),
                "steps": steps, "uptime": state.uptime}
        return (self.observe(sensor_key, physics, sensors), state,
                jnp.asarray(reward, self.dtype), terminal, truncated, info)

    def step(self, key, state: EnvState, action, params=None, sensors=None):
        """One control step, then a new episode where this one ended (gymnax's auto-reset):
        `(observation, EnvState, reward, terminated, truncated, info)`, the ended episode's
        last observation in `info["final_observation"]`."""
        step_key, reset_key = jax.random.split(key)
        observation, state, reward, terminated, truncated, info = self.step_env(
            step_key, state, action, params, sensors)
        start_observation, start = self.reset_env(reset_key, params, sensors)
        ended = terminated | truncated
        info["final_observation"] = observation
        state = jax.tree.map(lambda new, old: jnp.where(ended, new, old), start, state)
        observation = jnp.where(ended, start_observation, observation)
        return observation, state, reward, terminated, truncated, info


PLANTS = ("analytic", "mjx")
"""The plants a JAX environment steps: the paper's equations, traced (`Environment`), and
MuJoCo's model, stepped by MJX (`lwrl.jax.mjx`); MuJoCo's C engine cannot be stepped inside
a JAX program."""


def make(name: str, dtype=None, integrator: str = "semi_implicit", equations: str = "paper",
         observation_noise=None, action_delay: int = 0, action_noise: float = 0.0,
         plant: str = "analytic", **options):
    """`(Environment, params)`: the task `DOMAIN.TASK` (`lwrl.tasks.TASK_NAMES`) in JAX and
    its physical parameter values `(P,)`, gymnax's `make`.

    `plant` is `analytic` (the domain's equations) or `mjx` (its MuJoCo model stepped by
    MJX, for the domains that have one: `lwrl.jax.mjx.MjxEnvironment`, which steps the one
    model compiled at `params`, in float64, and has no `integrator` or `equations`).

    `options` are the task's (`time_limit`, `track_limit`, `params={name: value}`, ...),
    `actions` (`"discrete"`, the default, or `"continuous"`: the control itself, clipped to
    `env.action_range(params)`), the analytic plant's `integrator` and `equations` as `lwrl
    train`'s; `dtype` is `float64`
    (the default where JAX runs in 64 bits, `jax.config.update("jax_enable_x64", True)`: the
    analytic plant's numbers) or `float32` (the default otherwise). `observation_noise`
    `{state variable: sigma}`, `action_delay` and `action_noise` are the environment options
    of `tasks.disturbances` (`default_sensors`), with the noise drawn from the step's JAX
    key; `env.sensors(...)` gives others, per environment of a batch. A one-line
    ValueError names what is allowed for an unknown task, option or value.

    Example: one random-action episode step by step, then 16 agents' steps in one program.

    >>> import jax
    >>> jax.config.update("jax_enable_x64", True)  # before any array: the plant's float64
    >>> import lwrl.jax
    >>> env, params = lwrl.jax.make("cartpole.balance")
    >>> env.action_space(params), env.observation_space(params).shape
    (Discrete(n=2), (4,))
    >>> key = jax.random.key(0)
    >>> obs, state = env.reset(key, params)
    >>> obs, state, reward, terminated, truncated, info = env.step(key, state, 1, params)
    >>> keys = jax.random.split(key, 16)
    >>> obs, states = jax.vmap(env.reset, in_axes=(0, None))(keys, params)
    >>> actions = jax.numpy.zeros(16, dtype=int)
    >>> step = jax.jit(jax.vmap(env.step, in_axes=(0, 0, 0, None)))
    >>> obs, states, reward, terminated, truncated, info = step(keys, states, actions, params)
    >>> obs.shape
    (16, 4)
    """
    domain_name, task = tasks.split_name(name)
    domain = tasks.domain(domain_name)
    if plant not in PLANTS:
        raise ValueError(f"plant must be one of: {', '.join(PLANTS)} (lwrl.jax steps no C "
                         f"engine); got {plant!r}")
    if plant not in domain.plants.names:
        having = [other for other, plants in tasks.PLANTS.items() if plant in plants]
        raise ValueError(f"the {plant} plant steps a domain's MuJoCo model; {domain_name} has "
                         f"none (the domains with one: {', '.join(having)})")
    definition = tasks.resolve(domain_name, task, plant, **options)[0]
    analytic = plant == "analytic"
    if not analytic and (integrator, equations) != ("semi_implicit", "paper"):
        raise ValueError(f"integrator and equations are options of the analytic plant; the "
                         f"{plant} plant steps MuJoCo's model and has none")
    semi_implicit = check_integrator(integrator) if analytic and domain.plants.euler else True
    slips = check_equations(equations) if analytic and domain.plants.euler else False
    x64 = jax.config.read("jax_enable_x64")
    dtype = jnp.dtype((jnp.float64 if x64 else jnp.float32) if dtype is None else dtype)
    if dtype not in (jnp.float32, jnp.float64):
        raise ValueError(f"dtype must be float32 or float64; got {dtype}")
    if dtype == jnp.float64 and not x64:
        raise ValueError("dtype float64 needs JAX in 64 bits: call jax.config.update("
                         "'jax_enable_x64', True) first, or pass dtype='float32'")
    if not analytic and dtype != jnp.float64:
        raise ValueError(f"the {plant} plant steps MuJoCo's model in float64: call "
                         "jax.config.update('jax_enable_x64', True) first, and leave dtype float64")
    sensors = Sensors.of(definition, dtype, observation_noise=observation_noise,
                         action_delay=action_delay, action_noise=action_noise)
    if analytic:
        kind = Environment
    else:
        from lwrl.jax.mjx import MjxEnvironment  # here: it imports this module
        kind = MjxEnvironment
    env = kind(name=f"{domain_name}.{task}", definition=definition, dtype=dtype,
               semi_implicit=semi_implicit, slips=slips, default_sensors=sensors)
    return env, env.default_params


