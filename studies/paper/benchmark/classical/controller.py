"""What a domain's classical controller is to the benchmark (`Classical`)."""

import dataclasses
from typing import Callable


@dataclasses.dataclass(frozen=True)
class Classical:
    """A domain's classical controller, which uses the model: the benchmark's reference, the
    1 of a normalised score (SPEC.md, "The benchmark's protocol"). A discrete task runs it
    through the action nearest its control (`TaskDefinition.nearest_action`: bang-bang where
    the actions are the actuator's two limits)."""

    control: Callable
    """`control(state, p) -> u`: the control (force, torque or thrust, in the task's units,
    within the actuator's range) it wants at one state `(d,)`, in the task's order (angles
    unwrapped or not), at the physical parameter values `p` `(P,)` (`tasks.parameters`),
    from which it derives its gains."""
    source: str
    """Where the controller comes from: the papers it follows."""
    summary: str
    """What it does, in one line."""
