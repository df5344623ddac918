"""What a task is, once, over arrays with a batch dimension.

A `TaskDefinition` holds the array functions of one task: its start distribution, its
observation, reward, termination and up-time. The dm_env environment (`tasks.base`) calls
them with a batch of one; the batched stepper (`tasks.batched`) with a batch of B.
States are arrays of shape `(..., d)` in the order of `state_names`.
"""

import dataclasses
import math
from typing import Callable, Optional

import numpy as np


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
    controls: tuple
    """Force, torque or thrust of each discrete action, ascending: action i applies
    `controls[i]`."""
    control_timestep: float
    """Seconds (or, for Mountain-Car, steps) per agent step."""
    step_limit: float
    """Steps after which an episode is truncated (discount 1); `inf` for none."""
    initial_state: Callable[[np.random.Generator], np.ndarray]
    """Draws one start state, shape `(d,)`, from a generator."""
    observe: Callable[[np.ndarray], np.ndarray]
    """Maps states `(..., d)` to observations `(..., d)` (e.g. wraps angles)."""
    reward: Callable[[np.ndarray], np.ndarray]
    """Reward on entering states `(..., d)`."""
    terminal: Callable[[np.ndarray], np.ndarray]
    """True where states `(..., d)` are terminal (the episode ends with discount 0)."""
    is_up: Optional[Callable[[np.ndarray], np.ndarray]] = None
    """True where states `(..., d)` count toward the up-time; None where the task has no
    up-time (Mountain-Car)."""

    @property
    def name(self) -> str:
        return f"{self.domain}.{self.task}"

    @property
    def num_actions(self) -> int:
        return len(self.controls)

    def uptime_increment(self, state: np.ndarray) -> np.ndarray:
        """Seconds of up-time earned by entering `state` (NaN where there is no up-time)."""
        if self.is_up is None:
            return np.full(np.shape(state)[:-1], np.nan)
        return self.control_timestep * self.is_up(state)


def step_limit(time_limit: float, timestep: float) -> float:
    """Steps in `time_limit` (an int), or `inf` for an unlimited episode."""
    return math.inf if math.isinf(time_limit) else round(time_limit / timestep)


def check_finite_state(state: np.ndarray, names: tuple) -> np.ndarray:
    """Return `state` as float64 of shape `(..., len(names))`, or raise a one-line error."""
    state = np.asarray(state, dtype=np.float64)
    if state.shape[-1:] != (len(names),):
        raise ValueError(f"state must have {len(names)} entries ({', '.join(names)}) "
                         f"in its last axis; got shape {state.shape}")
    if not np.all(np.isfinite(state)):
        raise ValueError(f"state must be finite; got {state.tolist()} for ({', '.join(names)})")
    return state


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
