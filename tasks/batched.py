"""B copies of one task on one plant, stepped as arrays.

`BatchedEnv` follows dm_env's conventions with a leading batch axis: environment i has its
own seed and random start stream, and resets itself on the step after its episode ended
(that step ignores its action and returns a FIRST time step with reward 0 and discount 1),
as a dm_env environment does when stepped after LAST. Given the same seeds and actions, B
batched environments produce exactly the time steps of B single `tasks.load` environments.
The task's reward, termination and up-time are the same `TaskDefinition` functions the
single environments call. Each environment may have physical parameter values of its own
(`params={name: one value or B values}`), so that one batch spans a grid, values drawn
anew for each episode (`randomise={name: (low, high)}`, `tasks.randomisation`), and
sensor and actuator options of its own (`tasks.disturbances`). With `actions="continuous"`
each environment's action is its control, clipped to its actuator's range.
"""

from typing import NamedTuple, Sequence

import dm_env
import numpy as np

from lwrl import tasks
from lwrl.tasks.task_definition import (advance_episode, check_actions, check_finite_state,
                                   random_starts)
from lwrl.tasks.disturbances import Disturbances
from lwrl.tasks.randomisation import check_ranges, episode_values

FIRST, MID, LAST = (int(t) for t in (dm_env.StepType.FIRST, dm_env.StepType.MID, dm_env.StepType.LAST))


class BatchedTimeStep(NamedTuple):
    """A dm_env TimeStep with a batch axis: every field has leading shape `(B,)`."""

    step_type: np.ndarray
    """`dm_env.StepType` values (int8)."""
    reward: np.ndarray
    """Reward on entering the observed state; 0 on FIRST."""
    discount: np.ndarray
    """0 on a terminal step, else 1."""
    observation: np.ndarray
    """Observations `(B, d)` in the order of `state_names`."""

    def first(self) -> np.ndarray:
        """`(B,)` True where the step is an episode's first."""
        return self.step_type == FIRST

    def mid(self) -> np.ndarray:
        """`(B,)` True where the step is neither an episode's first nor its last."""
        return self.step_type == MID

    def last(self) -> np.ndarray:
        """`(B,)` True where the step ends an episode (terminal or truncated)."""
        return self.step_type == LAST


class BatchedEnv:
    """`len(seeds)` environments of `domain.task` on `plant`, stepped together.

    Options are those of `tasks.load`, where `params` (the physical parameters) and the
    sensor and actuator options may give one value per environment. `physical` `(B, P)`
    holds each environment's parameter values, `control_range` `(B, 2)` its actuator's range
    `[low, high]` and `controls` `(B, A)` its discrete actions' controls (None with
    continuous actions); `definition` is the task at the environments' values where they
    share them, else at the paper's. `uptime` and `steps` hold each environment's current
    (or just finished) episode's up-time in seconds and step count.
    """

    def __init__(self, domain: str, task: str, plant=None, seeds: Sequence[int] = (0,),
                 params=None, randomise=None, **options):
        if isinstance(seeds, (str, bytes)) or not hasattr(seeds, "__iter__"):
            raise ValueError(f"seeds must be a sequence of non-negative integers, one per "
                             f"environment; got {seeds!r}")
        seeds = list(seeds)
        if not seeds:
            raise ValueError("seeds must name at least one environment")
        self.batch_size = len(seeds)
        """B, the environments stepped together."""
        self._parameters = tasks.domain(domain).parameters
        self.physical = self._parameters.values(params, self.batch_size)
        """`(B, P)` each environment's physical parameter values."""
        self._ranges = check_ranges(self._parameters, randomise)
        self._base = self.physical.copy()
        self._episodes = np.full(self.batch_size, -1, dtype=np.int64)
        shared = bool(np.all(self.physical == self.physical[0])) and not self._ranges
        if shared and params:
            options["params"] = dict(zip(tasks.domain(domain).parameters.names, self.physical[0]))
        self.definition, self.plant_name, plant_options, sensing = tasks.resolve_environment(
            domain, task, plant, **options)
        self.plant = tasks.domain(domain).plants.batch(
            self.plant_name, self.batch_size, **plant_options, physical=self.definition.physical)
        """The batched plant that steps every environment's state (`plant_name`'s)."""
        self._rows = None if shared else self.physical
        if not (shared or self.plant.takes_rows):
            raise ValueError(f"the {self.plant_name} plant takes one set of parameter values for "
                             f"the whole batch; give every environment the same params")
        self.control_range = self.definition.control_range_at(self.physical)
        """`(B, 2)` each environment's actuator range `[low, high]`."""
        self.controls = (None if self.definition.continuous
                         else self.definition.controls_at(self.physical))
        """`(B, A)` each environment's discrete actions' controls; None with continuous
        actions."""
        self.disturbances = Disturbances(self.definition.state_names, self.control_range,
                                         self.batch_size, **sensing)
        """The sensor and actuator options per environment (observation noise, delay,
        action noise), with their streams and the commands in transit."""
        self.disturbances.seed(seeds)
        self.seeds = seeds
        """The environments' seeds, one each: their starts' and disturbances' streams."""
        self._rngs = [random_starts(seed) for seed in seeds]
        self.state = np.zeros((self.batch_size, len(self.definition.state_names)))
        """`(B, d)` each environment's current state."""
        self.steps = np.zeros(self.batch_size, dtype=np.int64)
        """`(B,)` each environment's current (or just finished) episode's steps."""
        self.uptime = np.zeros(self.batch_size)
        """`(B,)` each environment's current (or just finished) episode's up-time (s)."""
        self._needs_reset = np.ones(self.batch_size, dtype=bool)

    @property
    def num_actions(self) -> int:
        """The number of discrete actions (`TaskDefinition.num_actions`)."""
        return self.definition.num_actions

    def _start_episodes(self, which: np.ndarray) -> None:
        for i in np.flatnonzero(which):
            self.state[i] = self.definition.initial_states(self._rngs[i], 1)[0]
            if self._ranges:
                self._draw(i)
        self.steps[which] = 0
        self.uptime[which] = self.definition.initial_uptime
        self._needs_reset[which] = False
        self.disturbances.start(which)

    def _draw(self, i: int) -> None:
        """Environment i's parameter values for its next episode (`randomise`)."""
        self._episodes[i] += 1
        self.physical[i] = episode_values(self._parameters, self._ranges, self._base[i],
                                          self.seeds[i], self._episodes[i])
        self.control_range[i] = self.definition.control_range_at(self.physical[i])
        if self.controls is not None:
            self.controls[i] = self.definition.controls_at(self.physical[i])
        self.disturbances.low[i], self.disturbances.high[i] = self.control_range[i]

    def _observation(self) -> np.ndarray:
        """What the agents observe of the states, through their sensors: an array of its own
        (a task that observes its state as it is would otherwise hand out the state, which
        the next step overwrites)."""
        return self.disturbances.observe(self.definition.observe(self.state),
                                         np.arange(self.batch_size), self.steps)

    def set_state(self, state: np.ndarray) -> None:
        """Overwrite the plants' states `(B, d)` (episodes go on from there)."""
        state = check_finite_state(state, self.definition.state_names)
        if state.shape != self.state.shape:
            raise ValueError(f"state must have shape {self.state.shape}, one row per environment; "
                             f"got shape {state.shape}")
        self.state[:] = state

    def reset(self) -> BatchedTimeStep:
        """Start a new episode in every environment."""
        self._start_episodes(np.ones(self.batch_size, dtype=bool))
        ones = np.ones(self.batch_size)
        return BatchedTimeStep(np.full(self.batch_size, FIRST, dtype=np.int8), 0 * ones, ones,
                               self._observation())

    def _commands(self, actions) -> np.ndarray:
        """The controls `(B,)` that the environments command with `actions`, one per
        environment `(B,)` (continuous: also `(B, 1)`, Gymnasium's batched Box): each
        action's control, or the continuous action clipped to its environment's range. A
        one-line ValueError naming what is allowed otherwise."""
        definition, batch = self.definition, self.batch_size
        if self.controls is None:  # continuous actions
            if np.shape(actions) not in ((batch,), (batch, 1)):
                raise ValueError(f"actions must have shape ({batch},) or ({batch}, 1), one "
                                 f"{definition.control_name} per environment; got shape "
                                 f"{np.shape(actions)}")
            return definition.saturate(np.reshape(actions, batch), self.control_range)
        actions = check_actions(actions, self.num_actions)
        if actions.shape != (batch,):
            raise ValueError(f"actions must have shape ({batch},), one per environment; "
                             f"got shape {actions.shape}")
        return self.controls[np.arange(batch), actions]

    def step(self, actions) -> BatchedTimeStep:
        """Apply one action per environment (an index, or with continuous actions the
        control); environments whose episode ended reset."""
        commands = self._commands(actions)
        starting = self._needs_reset.copy()
        self._start_episodes(starting)
        moving = ~starting
        definition = self.definition
        rows = np.flatnonzero(moving)
        controls = self.disturbances.actuate(commands[moving], rows, self.steps[moving])
        physical = None if self._rows is None else self._rows[moving]
        moved = self.plant.step(self.state[moving], controls, physical)
        self.state[moving] = moved
        reward = np.zeros(self.batch_size)
        terminal, last = np.zeros((2, self.batch_size), dtype=bool)
        reward[moving], terminal[moving], up = definition.outcomes(moved, physical)
        self.steps[moving], self.uptime[moving], last[moving] = advance_episode(
            self.steps[moving], self.uptime[moving], up, terminal[moving],
            definition.control_timestep, definition.step_limit)
        self._needs_reset = last
        step_type = np.where(starting, FIRST, np.where(last, LAST, MID)).astype(np.int8)
        return BatchedTimeStep(step_type, reward, np.where(terminal, 0.0, 1.0),
                               self._observation())


def flatten_observation(observation) -> np.ndarray:
    """A dm_env observation as one float64 vector `(d,)`: an array raveled, or a mapping of
    scalars and arrays concatenated in key order."""
    if hasattr(observation, "values"):
        parts = [np.ravel(np.asarray(value, dtype=np.float64)) for value in observation.values()]
        return np.concatenate(parts) if parts else np.zeros(0)
    return np.ravel(np.asarray(observation, dtype=np.float64))


class SteppedEnvs:
    """B dm_env environments of any kind, each stepped on its own, behind `BatchedEnv`'s
    interface (`batch_size`, `reset`, `step`, `steps`, `uptime`).

    Environment b takes action `actions[b]` as given. Observations are flattened
    (`flatten_observation`); a FIRST time step has reward 0 and discount 1. As in
    `BatchedEnv`, an environment whose episode ended is reset on the next step, which
    ignores its action. `uptime(env)` reads an environment's up-time so far in seconds
    (without it, `uptime` is NaN).
    """

    def __init__(self, envs, uptime=None):
        self.envs = list(envs)
        """The B environments, in order."""
        if not self.envs:
            raise ValueError("envs must hold at least one environment")
        self.batch_size = len(self.envs)
        """B, the environments."""
        self.steps = np.zeros(self.batch_size, dtype=np.int64)
        """`(B,)` each environment's current (or just finished) episode's steps."""
        self._read_uptime = uptime
        self._ended = np.zeros(self.batch_size, dtype=bool)

    @property
    def control_range(self) -> np.ndarray:
        """`(B, 2)` each environment's bounds of a continuous action (its action spec's
        minimum and maximum: the actuator's range of the suite's continuous tasks)."""
        specs = [env.action_spec() for env in self.envs]
        return np.array([[np.min(spec.minimum), np.max(spec.maximum)] for spec in specs],
                        dtype=np.float64)

    @property
    def uptime(self) -> np.ndarray:
        """`(B,)` each environment's up-time so far in seconds (NaN without `uptime`)."""
        if self._read_uptime is None:
            return np.full(self.batch_size, np.nan)
        return np.array([self._read_uptime(env) for env in self.envs], dtype=np.float64)

    def reset(self) -> BatchedTimeStep:
        """Start a new episode in every environment."""
        self.steps[:] = 0
        return self._batch([env.reset() for env in self.envs])

    def step(self, actions) -> BatchedTimeStep:
        """Step each environment with its action; those whose episode ended reset."""
        timesteps = []
        for b, env in enumerate(self.envs):
            if self._ended[b]:
                self.steps[b] = 0
                timesteps.append(env.reset())
            else:
                self.steps[b] += 1
                timesteps.append(env.step(actions[b]))
        return self._batch(timesteps)

    def _batch(self, timesteps) -> BatchedTimeStep:
        first = np.array([ts.first() for ts in timesteps])
        self._ended = np.array([ts.last() for ts in timesteps])
        return BatchedTimeStep(
            np.array([int(ts.step_type) for ts in timesteps], dtype=np.int8),
            np.array([0.0 if f else ts.reward for f, ts in zip(first, timesteps)], dtype=np.float64),
            np.array([1.0 if f else ts.discount for f, ts in zip(first, timesteps)], dtype=np.float64),
            np.stack([flatten_observation(ts.observation) for ts in timesteps]))
