"""How a learner's action becomes the actuator's command, in every run loop.

A learner declares the kind of action it takes (`Learner.actions`, the task kinds of
`tasks.task_definition.ACTIONS`):

- `discrete`: an index into the task's controls; the command is that control
  (`controls[action]`, the controls at the episode's parameter values);
- `continuous`: a number in [-1, 1], the convention of continuous-control learners
  (Stable-Baselines3 rescales its Box actions to it; dm_control's actuators are normalised
  so): the command is the point of the actuator's range `[low, high]` at the episode's
  parameter values that it names, `mid + u half` with `mid = (low + high) / 2` and
  `half = (high - low) / 2`, so that u = 0 is the middle of the range and a symmetric range
  takes `u high` exactly. An action outside [-1, 1] is clipped to it first, as the
  actuator saturates; the task's own clipping (`TaskDefinition.saturate`) then changes
  nothing.

The compiled loop binds `COMMANDS[kind]` (`runners.compiled`); the stepped loop calls
`commands` over its batch, with the same arithmetic."""

import numpy as np
from numba.extending import register_jitable


@register_jitable
def discrete_command(controls, action):
    """The control of discrete `action` among the episode's `controls` `(A,)`."""
    return controls[action]


@register_jitable
def continuous_command(control_range, action):
    """The command that continuous `action` in [-1, 1] names in the episode's actuator
    range `control_range` `(2,)` (the module's docstring)."""
    low, high = control_range[0], control_range[1]
    u = min(max(action, -1.0), 1.0)
    return 0.5 * (low + high) + u * (0.5 * (high - low))


COMMANDS = {"discrete": discrete_command, "continuous": continuous_command}
"""The command of an action, by the kind of action a learner takes."""


def episode_controls(definition, physical: np.ndarray) -> np.ndarray:
    """`(..., C)`: what a loop's command reads per episode, at the parameter values
    `physical` `(..., P)`: the controls of a task with discrete actions, the actuator's
    range `[low, high]` of one with continuous ones."""
    if definition.continuous:
        return definition.control_range_at(physical)
    return definition.controls_at(physical)


def commands(control_range: np.ndarray, actions) -> np.ndarray:
    """`(B,)` the commands of continuous `actions` `(B,)` in the actuators' ranges
    `control_range` `(B, 2)` (`continuous_command` over a batch, the same arithmetic)."""
    control_range = np.asarray(control_range, dtype=np.float64)
    low, high = control_range[:, 0], control_range[:, 1]
    u = np.clip(np.asarray(actions, dtype=np.float64), -1.0, 1.0)
    return 0.5 * (low + high) + u * (0.5 * (high - low))


def check_kinds(name: str, actions: str, definition, source: str) -> None:
    """A one-line ValueError where the learner `name`, which takes `actions` (`discrete` or
    `continuous`), meets a task `definition` made with the other kind, naming the kind that
    runs it."""
    if actions == definition.actions:
        return
    if actions == "discrete":
        definition.check_discrete(f"{source}: {name}")
    low, high = definition.control_range
    raise ValueError(
        f"{source}: {name} takes continuous actions (the {definition.control_name} in "
        f"[{low:g}, {high:g}], from an action in [-1, 1]); {definition.name} was made with "
        f"actions={definition.actions!r}: run it with actions='continuous' (--action-kind "
        "continuous)")
