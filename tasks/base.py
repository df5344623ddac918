"""The one dm_control `Task` of the suite: it runs any `TaskDefinition` on either plant."""

import collections

import numpy as np
from dm_control.rl import control
from dm_env import specs

from lwrl.tasks.disturbances import Disturbances
from lwrl.tasks.parameters import Parameters
from lwrl.tasks.randomisation import check_ranges, episode_values
from lwrl.tasks.task_definition import TaskDefinition, check_actions, random_starts


class SuiteTask(control.Task):
    """Episode set-up, observation, reward and termination of a `TaskDefinition`.

    It calls the definition's array functions with a batch of one. It also counts the
    episode's steps (the time limit is a truncation with discount 1, decided here so that a
    terminal state on the last allowed step still ends with discount 0) and its up-time, and
    puts the sensors and the actuator (`disturbances`, `tasks.disturbances`) between the
    plant and the agent. The agent's action becomes a control here: the discrete action's
    control, or with continuous actions (`TaskDefinition.actions`) the action clipped to the
    actuator's range, as a motor saturates; the delay and the noise then act on either.
    """

    def __init__(self, definition: TaskDefinition, seed=None, disturbances: Disturbances = None,
                 parameters: Parameters = None, randomise=None):
        """`randomise={name: (low, high)}` draws those of the domain's `parameters` anew for
        each episode (`tasks.randomisation`), from a stream of `seed`."""
        self.definition = definition
        """The task's `TaskDefinition`."""
        self.random = random_starts(seed)
        """The stream the episodes' starts are drawn from (`seed`'s)."""
        self.disturbances = disturbances or Disturbances(definition.state_names,
                                                         definition.control_range)
        """The sensors and the actuator between the plant and the agent (one environment)."""
        self.disturbances.seed([seed])
        self._parameters = parameters
        self._ranges = check_ranges(parameters, randomise) if randomise else {}
        self._seed, self._episode = seed, -1
        self.physical = np.asarray(definition.physical, dtype=np.float64)
        """The parameter values of the current episode `(P,)`."""
        self._set_actuator()
        self._steps = 0
        self._uptime = 0.0

    @property
    def steps(self) -> int:
        """Steps taken in the current (or just finished) episode."""
        return self._steps

    @property
    def uptime(self) -> float:
        """Up-time in seconds of the current (or just finished) episode; NaN where the task
        has none."""
        return self._uptime

    def seed_disturbances(self, seed) -> None:
        """Key the sensors' and actuator's stream from `seed`, as `tasks.load(seed=seed)`
        does (Gymnasium's `reset(seed=...)`)."""
        self.disturbances.seed([seed])

    def initialize_episode(self, physics):
        """Start an episode: draw its parameter values where randomised, put the plant in a
        start drawn from `random`, and zero the step count and the up-time."""
        if self._ranges:
            self._episode += 1
            self.physical = episode_values(self._parameters, self._ranges,
                                           self.definition.physical, self._seed, self._episode)
            physics.set_physical(self.physical)
            self._set_actuator()
            self.disturbances.low[:], self.disturbances.high[:] = self._range
        physics.set_state_vector(self.definition.initial_states(self.random, 1)[0])
        self._steps = 0
        self._uptime = 0.0 if self.definition.has_uptime else float("nan")
        self.disturbances.start(0)

    def _set_actuator(self) -> None:
        """The actuator at the episode's parameter values: its range `(low, high)` and, for
        discrete actions, each action's control."""
        self._range = tuple(self.definition.control_range_at(self.physical).tolist())
        if not self.definition.continuous:
            self._controls = tuple(self.definition.controls_at(self.physical).tolist())

    def _command(self, action) -> float:
        """The control `action` commands: the discrete action's, or the continuous action (a
        number or an array of shape (1,)) clipped to the actuator's range. A one-line
        ValueError naming what is allowed otherwise."""
        definition = self.definition
        if definition.continuous:
            control = definition.saturate(action, self._range)
            if control.ndim > 1 or control.size != 1:
                raise ValueError(f"action must be one {definition.control_name}, a number or an "
                                 f"array of shape (1,); got shape {control.shape}")
            return float(control.reshape(()))
        index = check_actions(action, definition.num_actions)
        if index.ndim != 0:
            raise ValueError(f"action must be one integer index in 0..{definition.num_actions - 1}; "
                             f"got {action!r}")
        return self._controls[int(index)]

    def before_step(self, action, physics):
        """Set the plant's control for `action`, through the actuator's delay and noise."""
        control = self._command(action)
        if self.disturbances.active:
            control = float(self.disturbances.actuate([control], [0], [self._steps])[0])
        physics.set_control(control)

    def _outcome(self, physics) -> tuple:
        """`(reward, terminal, up)` of the plant's state at the episode's values."""
        reward, terminal, up = self.definition.outcomes(physics.state_vector()[None], self.physical)
        return float(reward[0]), bool(terminal[0]), bool(up[0])

    def after_step(self, physics):
        """Count the step, and its control timestep as up-time where the plant is up."""
        self._steps += 1
        if self.definition.has_uptime:
            self._uptime += self.definition.control_timestep * self._outcome(physics)[2]

    def action_spec(self, physics):
        """A `DiscreteArray` of the action indices, or for continuous actions a float64
        `BoundedArray` of shape (1,), the episode's actuator range, named after the control:
        the shape dm_control's tasks give their n actuators, (n,)."""
        if self.definition.continuous:
            low, high = self._range
            return specs.BoundedArray(shape=(1,), dtype=np.float64, minimum=[low],
                                      maximum=[high], name=self.definition.control_name)
        return specs.DiscreteArray(num_values=self.definition.num_actions, dtype=np.int64,
                                   name="action")

    def observation_spec(self, physics):
        """A float64 scalar `Array` per state variable, named after it, in order."""
        return collections.OrderedDict(
            (name, specs.Array(shape=(), dtype=np.float64, name=name))
            for name in self.definition.state_names)

    def get_observation(self, physics):
        """The plant's observed state through the sensors (noise, delay), by variable name."""
        observation = self.disturbances.observe(
            self.definition.observe(physics.state_vector()[None]), [0], [self._steps])[0]
        return collections.OrderedDict(
            (name, np.array(value)) for name, value in zip(self.definition.state_names, observation))

    def get_reward(self, physics):
        """The reward on entering the plant's state, at the episode's parameter values."""
        return self._outcome(physics)[0]

    def get_termination(self, physics):
        """The discount that ends the episode: 0 in a terminal state, 1 at the step limit
        (a truncation), None otherwise."""
        if self._outcome(physics)[1]:
            return 0.0
        if self._steps >= self.definition.step_limit:
            return 1.0
        return None
