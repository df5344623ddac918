"""What a task is, once, over arrays with a batch dimension.

A `TaskDefinition` holds the functions of one task: its start distribution, its observation,
and its `outcome` (reward, termination and up-time), and the values of its domain's physical
parameters (`tasks.parameters`) that its plants have. The dm_env environment (`tasks.base`)
calls them with a batch of one; the batched stepper (`tasks.batched`) with a batch of B; and
the domain's `transition`, which compiled loops call, steps the analytic plant and then
calls the same `outcome` (through `arrive`, which compiled loops also call after a MuJoCo
step).
States are arrays of shape `(..., d)` in the order of `state_names`.

An action is discrete, an index into the task's `controls` (the paper's tasks), or with
`actions="continuous"` the control itself, a force, torque or thrust that the actuator clips
to its range (`control_range`, from the lowest to the highest of the discrete controls).
"""

import dataclasses
import functools
import math
import numbers
from typing import Callable

import numpy as np
from numba.extending import register_jitable

from lwrl.spaces import Box, Space

ACTIONS = ("discrete", "continuous")
"""The kinds of action of a task (the option `actions`): an index into the discrete
controls, or the control itself within the actuator's range."""


@dataclasses.dataclass(frozen=True)
class TaskDefinition:
    """One task of the suite, as array functions."""

    domain: str
    """Domain name, e.g. `cartpole`."""
    task: str
    """Task name, e.g. `balance`."""
    state_names: tuple
    """Names of the state variables, in the order of the last axis of a state array;
    they are also the observation keys."""
    controls_of: Callable
    """`controls_of(p)`: the force, torque or thrust of each discrete action, ascending, at
    the parameter values `p` `(P, ...)` (a tuple, one value or array per action): action i
    applies `controls_of(p)[i]`; `controls` at the definition's own values."""
    control_timestep: float
    """Seconds (or, for Mountain-Car, steps) per agent step."""
    step_limit: float
    """Steps after which an episode is truncated (discount 1); `inf` for none."""
    initial_states: Callable[[np.random.Generator, int], np.ndarray]
    """`initial_states(rng, count)` draws `count` start states `(count, d)`; the same
    generator gives the same starts whether drawn one at a time or all at once."""
    observe: Callable[[np.ndarray], np.ndarray]
    """Maps states `(..., d)` to observations `(..., d)` (e.g. wraps angles)."""
    outcome: Callable
    """`outcome(*state_columns, *params, p) -> (reward, terminal, up)` on entering a state,
    element-wise and numba-jitable: the task's reward, termination and up-time, once; `p`
    the physical parameters' values (`tasks.parameters`: a vector, or columns)."""
    transition: Callable
    """`transition(state, control, next_state, observation, dt, semi_implicit, slips,
    arguments)`: one analytic-plant step of one state `(d,)` for compiled loops, with the
    Euler scheme and the equations (`tasks.plants.EQUATIONS`) bound as flags and
    `arguments = (params, p)` (`loop_arguments`). It writes the next state and calls
    `arrive`."""
    arrive: Callable
    """`arrive(state, observation, arguments)`: on entering one state `(d,)` for compiled
    loops, writes its observation (as `observe`) and returns its `outcome`; what follows a
    step of any plant."""
    bounds: tuple
    """`(low, high)`, one value per state variable: every observation of an episode lies
    within them, the terminal one included (`inf` where a variable is unbounded)."""
    ranges: tuple
    """`(low, high)`, one finite value per state variable: each state variable's
    normalisation range, the box a learner's representation spans unless its settings say
    otherwise (`TaskSpec.ranges`; where `bounds` may be infinite, such as a speed, the range
    of the speeds an episode mostly has). A learner's settings on a task live beside the
    learner (`agent.paper_settings`), not here."""
    physical: tuple
    """The values of the domain's physical parameters (`Domain.parameters`, in its order)
    that the definition's plants have: the paper's unless the task's `params` option says
    otherwise."""
    angles: tuple = ()
    """The state variables that are angles (compared modulo 2 pi)."""
    params: tuple = ()
    """The task options that `outcome` and `transition` read (e.g. the track limit)."""
    has_uptime: bool = True
    """False where the task has no up-time (Mountain-Car: reported as NaN)."""
    control_name: str = "control"
    """What the actuator applies (`force`, `torque`, `thrust`): the name of a continuous
    action's spec and of its errors."""
    actions: str = "discrete"
    """`discrete`: an action is an index into `controls`; `continuous`: an action is the
    control itself, clipped to `control_range` (`with_actions`)."""

    @property
    def name(self) -> str:
        """DOMAIN.TASK."""
        return f"{self.domain}.{self.task}"

    @property
    def continuous(self) -> bool:
        """True where an action is the control itself (`actions="continuous"`)."""
        return self.actions == "continuous"

    def with_actions(self, actions) -> "TaskDefinition":
        """This task with `actions` (`ACTIONS`) its kind of action; a one-line ValueError
        naming the kinds otherwise."""
        if not (isinstance(actions, str) and actions in ACTIONS):
            raise ValueError(f"actions must be one of: {', '.join(ACTIONS)}; got {actions!r}")
        return dataclasses.replace(self, actions=actions)

    @functools.cached_property
    def controls(self) -> tuple:
        """Force, torque or thrust of each discrete action at the definition's parameter
        values, ascending: action i applies `controls[i]`."""
        return tuple(self.controls_at(self.physical).tolist())

    def controls_at(self, physical) -> np.ndarray:
        """`(..., A)`: each action's control at the parameter values `physical` `(..., P)`
        (one row per environment or agent). A one-line ValueError for a task with
        continuous actions, which has no discrete ones: where a learner of discrete actions
        meets such a task (`num_actions`, `check_fits`, the compiled loops)."""
        self.check_discrete()
        return self._every_control_at(physical)

    def check_discrete(self, source: str = "") -> None:
        """A one-line ValueError where the task's actions are continuous, naming what a
        learner of discrete actions (from `source`, where given) can run: the task with
        `actions='discrete'`."""
        if self.continuous:
            low, high = self.control_range
            raise ValueError(
                f"{source + ': ' if source else ''}{self.name} was made with "
                f"actions='continuous' (the {self.control_name} itself, in [{low:g}, {high:g}]): "
                f"it has no discrete actions for a learner to choose among; allowed for such "
                f"learners: actions='discrete'")

    def _every_control_at(self, physical) -> np.ndarray:
        """`controls_of` at the parameter values `physical` `(..., P)`, as an array
        `(..., A)`."""
        physical = np.asarray(physical, dtype=np.float64)
        return np.stack([np.broadcast_to(control, physical.shape[:-1]) for control in
                         self.controls_of(np.moveaxis(physical, -1, 0))], axis=-1)

    @functools.cached_property
    def control_range(self) -> tuple:
        """`(low, high)`: the actuator's range at the definition's parameter values."""
        return tuple(self.control_range_at(self.physical).tolist())

    def control_range_at(self, physical) -> np.ndarray:
        """`(..., 2)`: the actuator's range `[low, high]` at the parameter values `physical`
        `(..., P)`: the lowest and the highest discrete action's control, `controls_of(p)[0]`
        and `controls_of(p)[-1]` (ascending), so it moves with the parameters that set them
        (the pendulum's torque in [-tau_max, tau_max], the cart-pole's force in [-F, F],
        Mountain-Car's thrust in [-1, 1], the acrobot's elbow torque in [-tau_max,
        tau_max]). Where a continuous action is clipped, and the action noise
        (`tasks.disturbances`) in either kind."""
        return self._every_control_at(physical)[..., [0, -1]]

    def saturate(self, actions, control_range) -> np.ndarray:
        """The controls that continuous `actions` (a number or an array) command: each
        clipped to its actuator's range `control_range` `(..., 2)` (`control_range_at`,
        broadcast against the actions), as an actuator saturates; float64. A one-line
        ValueError unless every action is a finite real number (not NaN, an infinity, a
        bool or a string)."""
        values = np.asarray(actions)
        ranges = np.asarray(control_range, dtype=np.float64)
        if values.dtype.kind not in "iuf" or not np.all(np.isfinite(values)):
            given = actions.tolist() if isinstance(actions, np.ndarray) else actions  # one line
            raise ValueError(
                f"action must be a finite {self.control_name} (clipped to the actuator's range, "
                f"[{ranges[..., 0].min():g}, {ranges[..., 1].max():g}]); got {given!r}")
        return np.clip(values.astype(np.float64), ranges[..., 0], ranges[..., 1])

    @property
    def num_actions(self) -> int:
        """The number of discrete actions (a one-line ValueError for a task with continuous
        actions, `controls_at`)."""
        return len(self.controls)

    def nearest_action(self, control, physical=None):
        """The index of the action whose control (`controls`, or `controls_at(physical)`
        with rows `(..., P)`) is nearest to `control` (a number, or an array `(...)`: an
        int array then), the lower index on a tie: how a discrete task runs a continuous
        controller (the benchmark's classical controllers), bang-bang where the actions are the actuator's two
        limits. A one-line ValueError unless `control` is finite."""
        try:
            value = np.asarray(control, dtype=np.float64)
        except (TypeError, ValueError):
            value = np.asarray(np.nan)
        if not np.all(np.isfinite(value)):
            raise ValueError(f"control must be a finite number; got {control!r}")
        controls = (np.asarray(self.controls) if physical is None
                    else self.controls_at(physical))
        index = np.argmin(np.abs(controls - value[..., None]), axis=-1)  # the first on a tie
        return int(index) if index.ndim == 0 else index

    def loop_arguments(self) -> tuple:
        """What `transition` and `arrive` take as `arguments` in compiled loops: `(params,
        p)`, the task's options `(K,)` and the physical parameters' values `(P,)`, float64."""
        return (np.asarray(self.params, dtype=np.float64),
                np.asarray(self.physical, dtype=np.float64))

    def outcomes(self, state: np.ndarray, physical=None) -> tuple:
        """`(reward float64, terminal bool, up bool)` arrays on entering states `(..., d)`,
        at the definition's parameter values or at `physical`, one row `(..., P)` per
        state."""
        physical = self.physical if physical is None else physical
        p = np.moveaxis(np.asarray(physical, dtype=np.float64), -1, 0)
        reward, terminal, up = self.outcome(*np.moveaxis(state, -1, 0), *self.params, p)
        shape = np.shape(state)[:-1]
        return (np.broadcast_to(reward, shape).astype(np.float64),
                np.broadcast_to(terminal, shape).astype(bool), np.broadcast_to(up, shape).astype(bool))

    def reward(self, state: np.ndarray) -> np.ndarray:
        """Reward on entering states `(..., d)`."""
        return self.outcomes(state)[0]

    def terminal(self, state: np.ndarray) -> np.ndarray:
        """True where states `(..., d)` are terminal (the episode ends with discount 0)."""
        return self.outcomes(state)[1]

    def uptime_increment(self, state: np.ndarray) -> np.ndarray:
        """Seconds of up-time earned by entering states `(..., d)` (NaN without up-time)."""
        if not self.has_uptime:
            return np.full(np.shape(state)[:-1], np.nan)
        return self.control_timestep * self.outcomes(state)[2]

    def check_fits(self, dim: int, action_space: Space, source: str) -> None:
        """A one-line ValueError unless agents that observe `dim` variables and take actions
        of `action_space` (`Agents.action_space`: `Discrete(A)`, A actions to choose among,
        or a `Box`, continuous actions) can run this task: the check for agents read from
        `source`."""
        continuous = isinstance(action_space, Box)
        num_actions = None if continuous else action_space.n
        if not continuous:
            self.check_discrete(source)
        elif not self.continuous:
            raise ValueError(f"{source}: its agents take continuous actions; {self.name} was "
                             "made with actions='discrete': allowed for them: "
                             "actions='continuous'")
        fits = dim == len(self.state_names) and (continuous or num_actions == self.num_actions)
        if not fits:
            actions = ("act continuously" if continuous
                       else f"choose among {num_actions} actions")
            task_actions = ("continuous actions" if continuous
                            else f"{self.num_actions} actions")
            raise ValueError(
                f"{source}: its agents observe {dim} variables and {actions}, so they were not "
                f"trained on {self.name} ({len(self.state_names)} variables: "
                f"{', '.join(self.state_names)}; {task_actions})")

    @property
    def initial_uptime(self) -> float:
        """An episode's up-time before its first step: 0, or NaN where the task has none."""
        return 0.0 if self.has_uptime else math.nan


@register_jitable
def wrap_angle(angle):
    """The angle mapped to [-pi, pi] (+pi only through rounding, e.g. of -1e-20); element-wise,
    for the observations of angles that the state does not wrap (like MuJoCo's hinges)."""
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


@register_jitable
def advance_episode(steps, uptime, up, terminal, dt, step_limit):
    """An episode's bookkeeping after one step, element-wise, the same for every way of
    running a task (dm_env, batched, compiled): `(steps + 1, uptime + dt up, last)`, where
    `last` ends the episode at a terminal state or at the time limit (a truncation unless
    the state is terminal: a terminal state on the last allowed step still has discount 0).
    An up-time of NaN (a task without one) stays NaN."""
    steps = steps + 1
    return steps, uptime + dt * up, terminal | (steps >= step_limit)


def positive_number(name: str, value, what: str = "number") -> float:
    """`value` as a float if it is a real number above 0 (`inf` included), else a one-line
    error: `NAME must be a positive WHAT; got VALUE` (a bool, a string, NaN are refused)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not float(value) > 0:
        raise ValueError(f"{name} must be a positive {what}; got {value!r}")
    return float(value)


def step_limit(time_limit, timestep: float) -> float:
    """Steps in `time_limit` (an int), or `inf` for an unlimited episode; a one-line error
    unless `time_limit` is a positive whole number of control steps `timestep` (within
    round-off: 0.06 s is 3 steps of 0.02 s)."""
    time_limit = positive_number("time_limit", time_limit)
    if math.isinf(time_limit):
        return math.inf
    steps = time_limit / timestep
    if not math.isclose(steps, round(steps), rel_tol=1e-9) or round(steps) < 1:
        raise ValueError(f"time_limit must be a whole number of control steps of {timestep:g}; "
                         f"got {time_limit!r} ({steps:g} steps)")
    return round(steps)


def check_finite_state(state: np.ndarray, names: tuple) -> np.ndarray:
    """Return `state` as float64 of shape `(..., len(names))`, or raise a one-line error."""
    state = np.asarray(state, dtype=np.float64)
    if state.shape[-1:] != (len(names),):
        raise ValueError(f"state must have {len(names)} entries ({', '.join(names)}) "
                         f"in its last axis; got shape {state.shape}")
    if not np.all(np.isfinite(state)):
        raise ValueError(f"state must be finite; got {state.tolist()} for ({', '.join(names)})")
    return state


def random_starts(seed) -> np.random.Generator:
    """The generator of an environment's starts: `seed` a non-negative integer, None (fresh
    entropy) or a NumPy Generator; a one-line error naming `seed` otherwise."""
    if isinstance(seed, np.random.Generator) or seed is None:
        return np.random.default_rng(seed)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer; got {seed!r}")
    return np.random.default_rng(seed)


def check_actions(actions, num_actions: int) -> np.ndarray:
    """Return `actions` as an int array, or raise naming the allowed indices."""
    array = np.asarray(actions)
    if array.dtype.kind not in "iu" and not (
            array.dtype.kind == "f" and np.all(np.isfinite(array)) and np.all(array == np.round(array))):
        raise ValueError(f"action must be an integer index in 0..{num_actions - 1}; got {actions!r}")
    array = array.astype(np.int64)
    if np.any((array < 0) | (array >= num_actions)):
        raise ValueError(f"action must be an integer index in 0..{num_actions - 1}; got {actions!r}")
    return array
