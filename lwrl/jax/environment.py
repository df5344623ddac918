"""A task of the suite as a gymnax-style JAX environment: pure `reset` and `step` that `jit`
and `vmap`, the physical parameters apart from the state.

As in gymnax (Lange 2022), an environment is an object without state of its own: the
episode's state (`EnvState`) and the domain's physical parameter values (`params`, the
vector `(P,)` of `Domain.parameters`, gymnax's `EnvParams`) travel as arrays, so that one
program can `vmap` over agents and over parameter values (randomised physics). Unlike gymnax
< 1.0 (and rejax on it), `step` returns `terminated` and `truncated` apart: a time limit is
not a terminal state, and a learner bootstraps from it.

Every function of the task is the suite's own (`lwrl.jax.translate`): the analytic plant's
step of `tasks/<domain>.py` with its Euler scheme and equations, the start distribution,
the observation, `outcome` (reward, termination, up-time) and `advance_episode` (the time
limit), traced by JAX instead of compiled by numba.
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
    """`(k,)`: the controls commanded and not yet applied (`action_delay` k; 0 at a start)."""


class StartDraws:
    """A NumPy Generator's `uniform` as a task's `initial_states(rng, count)` calls it, drawn
    from a JAX key: `low + (high - low) u`, u ~ U[0, 1), as NumPy computes it."""

    def __init__(self, key, dtype):
        self.key, self.dtype = key, dtype

    def uniform(self, low=0.0, high=1.0, size=None):
        self.key, key = jax.random.split(self.key)
        shape = () if size is None else tuple(np.atleast_1d(size))
        unit = jax.random.uniform(key, shape, dtype=self.dtype)
        low, high = jnp.asarray(low, self.dtype), jnp.asarray(high, self.dtype)
        return low + (high - low) * unit


@dataclasses.dataclass(frozen=True, eq=False)
class Environment:
    """`DOMAIN.TASK` on the analytic plant, in JAX (`lwrl.jax.make` builds it).

        obs, state = env.reset(key, params)
        obs, state, reward, terminated, truncated, info = env.step(key, state, action, params)

    `step` starts a new episode where one ended (gymnax's auto-reset): `obs` is then the new
    start's and `info["final_observation"]` the episode's last; `info` also holds the
    `discount` (0 at a terminal state), the ended episode's `steps` and `uptime`.
    `reset_env` and `step_env` are the same without the automatic reset. The action is an
    index into the task's discrete controls (`num_actions`); an index outside them takes
    the nearest end, as JAX's indexing does, unchecked inside a traced program.
    """

    name: str
    """DOMAIN.TASK."""
    definition: Any
    """The task's `TaskDefinition` (its options applied)."""
    dtype: Any
    """The floating-point type of states, observations and rewards."""
    semi_implicit: bool
    slips: bool
    observation_noise: tuple
    """Per state variable: the standard deviation of the observation's Gaussian noise."""
    action_delay: int
    """Control steps between a command and its application (0 applied before one arrives)."""
    action_noise: float
    """Standard deviation of the applied control's noise, clipped to the controls' range."""

    @property
    def num_actions(self) -> int:
        return self.definition.num_actions

    @property
    def observation_size(self) -> int:
        return len(self.definition.state_names)

    @property
    def default_params(self):
        """The task's physical parameter values `(P,)` (the paper's unless `params` was
        given to `make`)."""
        return jnp.asarray(self.definition.physical, dtype=self.dtype)

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

    def observe(self, key, physics):
        """The agent's observation of `physics`: the task's, plus the sensors' noise."""
        observation = as_jax(self.definition.observe, self.dtype)(physics)
        sigma = jnp.asarray(self.observation_noise, self.dtype)
        if any(self.observation_noise):
            observation = observation + sigma * jax.random.normal(key, observation.shape, self.dtype)
        return observation

    def reset_env(self, key, params=None):
        """`(observation, EnvState)` of a new episode from the task's start distribution."""
        self.check_params(self.default_params if params is None else params)
        start_key, noise_key = jax.random.split(key)
        draw = as_jax(self.definition.initial_states, self.dtype)
        return self.start(noise_key, draw(StartDraws(start_key, self.dtype), 1)[0])

    def start(self, key, physics):
        """`(observation, EnvState)` of an episode starting in the plant state `physics`
        `(d,)` (a start drawn elsewhere, e.g. the protocol's from each agent's seed)."""
        physics = jnp.asarray(physics, self.dtype)
        state = EnvState(physics=physics, steps=jnp.int32(0),
                         uptime=jnp.asarray(self.definition.initial_uptime, self.dtype),
                         transit=jnp.zeros(self.action_delay, self.dtype))
        return self.observe(key, physics), state

    reset = reset_env
    """`(observation, EnvState)` of a new episode: gymnax's `reset`."""

    def control(self, key, state: EnvState, action, params):
        """`(applied control, transit)`: the action's control, after the actuator's delay and
        noise."""
        controls = jnp.stack([jnp.broadcast_to(jnp.asarray(c, self.dtype), ()) for c in
                              as_jax(self.definition.controls_of, self.dtype)(params)])
        commanded = controls[action]
        transit = state.transit
        if self.action_delay:
            commanded, transit = transit[0], jnp.concatenate([transit[1:], commanded[None]])
        if self.action_noise > 0.0:
            noisy = commanded + self.action_noise * jax.random.normal(key, (), self.dtype)
            commanded = jnp.clip(noisy, controls.min(), controls.max())
        return commanded, transit

    def step_env(self, key, state: EnvState, action, params=None):
        """One control step without the automatic reset: `(observation, EnvState, reward,
        terminated, truncated, info)`."""
        params = self.check_params(self.default_params if params is None else params)
        actuator_key, sensor_key = jax.random.split(key)
        control, transit = self.control(actuator_key, state, action, params)
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
        return (self.observe(sensor_key, physics), state,
                jnp.asarray(reward, self.dtype), terminal, truncated, info)

    def step(self, key, state: EnvState, action, params=None):
        """One control step, then a new episode where this one ended (gymnax's auto-reset):
        `(observation, EnvState, reward, terminated, truncated, info)`, the ended episode's
        last observation in `info["final_observation"]`."""
        step_key, reset_key = jax.random.split(key)
        observation, state, reward, terminated, truncated, info = self.step_env(
            step_key, state, action, params)
        start_observation, start = self.reset_env(reset_key, params)
        ended = terminated | truncated
        info["final_observation"] = observation
        state = jax.tree.map(lambda new, old: jnp.where(ended, new, old), start, state)
        observation = jnp.where(ended, start_observation, observation)
        return observation, state, reward, terminated, truncated, info


def make(name: str, dtype=None, integrator: str = "semi_implicit", equations: str = "paper",
         observation_noise=None, action_delay: int = 0, action_noise: float = 0.0, **options):
    """`(Environment, params)`: the task `DOMAIN.TASK` (`lwrl.tasks.TASK_NAMES`) in JAX and
    its physical parameter values `(P,)`, gymnax's `make`.

    `options` are the task's (`time_limit`, `track_limit`, `params={name: value}`, ...), the
    analytic plant's `integrator` and `equations` as `lwrl train`'s; `dtype` is `float64`
    (the default where JAX runs in 64 bits, `jax.config.update("jax_enable_x64", True)`: the
    analytic plant's numbers) or `float32` (the default otherwise). `observation_noise`
    `{state variable: sigma}`, `action_delay` and `action_noise` are the environment options
    of `tasks.disturbances`, with the noise drawn from the step's JAX key. A one-line
    ValueError names what is allowed for an unknown task, option or value.
    """
    domain_name, task = tasks.split_name(name)
    definition = tasks.resolve(domain_name, task, "analytic", **options)[0]
    domain = tasks.domain(domain_name)
    semi_implicit = check_integrator(integrator) if domain.plants.euler else True
    slips = check_equations(equations) if domain.plants.euler else False
    x64 = jax.config.read("jax_enable_x64")
    dtype = jnp.dtype((jnp.float64 if x64 else jnp.float32) if dtype is None else dtype)
    if dtype not in (jnp.float32, jnp.float64):
        raise ValueError(f"dtype must be float32 or float64; got {dtype}")
    if dtype == jnp.float64 and not x64:
        raise ValueError("dtype float64 needs JAX in 64 bits: call jax.config.update("
                         "'jax_enable_x64', True) first, or pass dtype='float32'")
    noise = tasks.disturbances.Disturbances(definition.state_names, definition.controls,
                                            observation_noise=observation_noise,
                                            action_delay=action_delay, action_noise=action_noise)
    env = Environment(name=f"{domain_name}.{task}", definition=definition, dtype=dtype,
                      semi_implicit=semi_implicit, slips=slips,
                      observation_noise=tuple(noise.sigma_observation[0].tolist()),
                      action_delay=int(noise.delay[0]), action_noise=float(noise.sigma_action[0]))
    return env, env.default_params


