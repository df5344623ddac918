"""A domain's plant in C, as the device programs take it (`export.device`)."""

import dataclasses
from typing import Mapping


@dataclasses.dataclass(frozen=True)
class CPlant:
    """A domain's plant as C99 for the device programs (`export.device`), in double: the
    bodies of two functions, `string.Template` texts whose `$name` placeholders are the
    domain's physical parameters (`Domain.parameters`, filled with a task's values) and the
    `constants` below. The state the plant keeps is what the learner observes."""

    start: str
    """The body of `static void plant_start(double *state, const double *unit)`: a start
    state from one draw in [0, 1) per state variable, `unit`, as `initial_states` draws it
    (numpy's `uniform` is `low + (high - low) u`)."""
    step: str
    """The body of `static double plant_step(double *state, double control, int *terminal)`:
    one step of `state` in place under `control` (an action's, `TaskDefinition.controls`),
    as the task's `transition` computes it; returns the reward and sets `*terminal`."""
    constants: Mapping
    """`{placeholder: number}`: the domain's other constants the texts use."""
