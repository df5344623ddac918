"""What a task gives a learner to know of it: its spaces and its `TaskSpec`.

As Gymnasium's spaces and gymnax's `action_space(params)`, a space says which values an
observation or an action may take, without any library of arrays behind it:

- `Discrete(n)`: the indices 0 .. n-1 (the paper's tasks: −1/0/+1 thrust, ±5 N·m, ±10 N);
- `Box(low, high)`: real vectors between `low` and `high` element-wise (`±inf` where a
  variable is unbounded: the pendulum's speed), float64.

A `TaskSpec` is everything a learner may know of a task (DESIGN.md, "Fifth stage"): its
name, observation and action spaces, state names, control timestep, step limit and the
physical parameters' values. It holds no function of the task: a learner made from a spec
cannot step, draw or peek at the plant. The spec of a task made with continuous actions has
a `Box` of the actuator's range (force, torque or thrust, `TaskDefinition.control_range`) as
its action space, one of discrete actions a `Discrete` of its controls' count.

They lie on the lowest floor, below both the suite (`tasks`, which makes specs:
`tasks.spec`, `tasks.spec_of`) and the learners (`agent`, which are made from them).
"""

import dataclasses
import math
from typing import Mapping, Union

import numpy as np


@dataclasses.dataclass(frozen=True)
class Discrete:
    """The action indices 0 .. n-1."""

    n: int
    """How many there are (at least 1)."""

    def __post_init__(self):
        if isinstance(self.n, bool) or not isinstance(self.n, (int, np.integer)) or self.n < 1:
            raise ValueError(f"a Discrete space needs a whole number of values n >= 1; got {self.n!r}")

    @property
    def shape(self) -> tuple:
        """`()`: an index is a scalar."""
        return ()

    def contains(self, value) -> bool:
        """True where `value` is one integer index in 0 .. n-1."""
        array = np.asarray(value)
        return (array.shape == () and array.dtype.kind in "iu"
                and 0 <= int(array) < self.n)

    def sample(self, rng: np.random.Generator) -> int:
        """One index drawn uniformly from `rng`."""
        return int(rng.integers(self.n))


@dataclasses.dataclass(frozen=True)
class Box:
    """Real vectors of `len(low)` elements, each within `[low[j], high[j]]`."""

    low: tuple
    """The smallest value of each element (`-inf`: unbounded below)."""
    high: tuple
    """The largest value of each element (`inf`: unbounded above)."""

    def __post_init__(self):
        low, high = (tuple(float(v) for v in np.ravel(bound)) for bound in (self.low, self.high))
        if len(low) != len(high) or not low:
            raise ValueError(f"a Box needs as many low as high bounds, at least one; got "
                             f"{len(low)} and {len(high)}")
        if any(math.isnan(a) or math.isnan(b) or a > b for a, b in zip(low, high)):
            raise ValueError(f"a Box needs low <= high in every element; got low {list(low)}, "
                             f"high {list(high)}")
        object.__setattr__(self, "low", low)
        object.__setattr__(self, "high", high)

    @property
    def shape(self) -> tuple:
        """`(n,)`: the length of a vector of the space."""
        return (len(self.low),)

    @property
    def bounded(self) -> bool:
        """True where every element has finite bounds."""
        return all(map(math.isfinite, self.low + self.high))

    def contains(self, value) -> bool:
        """True where `value` is a real vector of the space's shape within its bounds."""
        array = np.asarray(value)
        return (array.shape == self.shape and array.dtype.kind in "iuf"
                and bool(np.all((array >= self.low) & (array <= self.high))))

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        """One vector drawn uniformly within the bounds (a ValueError where one is
        infinite: there is no uniform draw there)."""
        if not self.bounded:
            raise ValueError("a Box with an infinite bound has no uniform sample")
        return rng.uniform(self.low, self.high)

    def unbounded_where(self, mask) -> "Box":
        """This box with the elements where `mask` is True unbounded (a sensor's noise can
        carry an observation past any bound)."""
        mask = np.asarray(mask, dtype=bool)
        return Box(np.where(mask, -np.inf, self.low), np.where(mask, np.inf, self.high))


Space = Union[Discrete, Box]
"""A task's space: `Discrete` action indices or a `Box` of numbers."""


@dataclasses.dataclass(frozen=True)
class TaskSpec:
    """Everything a learner may know of a task (see the module)."""

    name: str
    """DOMAIN.TASK."""
    observation: Box
    """Every observation of an episode lies in it, the terminal one included."""
    action: Space
    """`Discrete(A)`: an index into the task's controls; `Box` of shape (1,): the control
    itself, clipped to the actuator's range."""
    state_names: tuple
    """The observation's elements, in order."""
    control_timestep: float
    """Seconds (Mountain-Car: steps) per agent step."""
    step_limit: float
    """Steps after which an episode is truncated (`inf`: never)."""
    parameters: Mapping[str, float] = dataclasses.field(hash=False)
    """The physical parameters' values the task has, by name (`Domain.parameters`)."""
    ranges: Box | None = None
    """The box a learner's representation spans unless its settings say otherwise: each
    state variable's normalisation range (finite where `observation` may not be: the
    pendulum's speed), `TaskDefinition.ranges`; None: the task gives
    none."""

    @property
    def continuous(self) -> bool:
        """True where an action is the control itself (a `Box`)."""
        return isinstance(self.action, Box)

    @property
    def actions(self) -> str:
        """The kind of its actions: `discrete` (a `Discrete` space) or `continuous`."""
        return "continuous" if self.continuous else "discrete"


def space_document(space: Space) -> dict:
    """`space` as JSON: `{"n": n}` or `{"low": [...], "high": [...]}`."""
    if isinstance(space, Discrete):
        return {"n": int(space.n)}
    return {"low": list(space.low), "high": list(space.high)}


def space_of(document: dict) -> Space:
    """The space `space_document` wrote."""
    return Discrete(document["n"]) if "n" in document else Box(document["low"], document["high"])


def spec_document(spec: TaskSpec) -> dict:
    """`spec` as JSON (an agent file keeps the spec its agents were made from)."""
    return {"name": spec.name, "observation": space_document(spec.observation),
            "action": space_document(spec.action), "state_names": list(spec.state_names),
            "control_timestep": spec.control_timestep, "step_limit": spec.step_limit,
            "parameters": dict(spec.parameters),
            "ranges": None if spec.ranges is None else space_document(spec.ranges)}


def spec_of_document(document) -> TaskSpec:
    """The spec `spec_document` wrote; or, from a file written before specs, the task as it
    was described then: `[name, state names, discrete actions (0: continuous), low, high,
    kind]` or the same as a dict (`name`, `state_names`, `num_actions`, `low`, `high`,
    `actions`), which told a learner its normalisation ranges and kind of actions only: such
    a spec has an unbounded observation (and continuous action), no timestep (NaN), no step
    limit and no parameters."""
    if isinstance(document, dict) and "observation" in document:
        ranges = document["ranges"]
        return TaskSpec(document["name"], space_of(document["observation"]),
                        space_of(document["action"]), tuple(document["state_names"]),
                        float(document["control_timestep"]), float(document["step_limit"]),
                        dict(document["parameters"]),
                        None if ranges is None else space_of(ranges))
    if isinstance(document, dict):
        document = [document[key] for key in ("name", "state_names", "num_actions", "low", "high")
                    ] + [document.get("actions", "discrete")]
    name, state_names, num_actions, low, high, *kind = document
    continuous = (kind or ["discrete"])[0] == "continuous"
    dim = len(state_names)
    return TaskSpec(name, Box([-math.inf] * dim, [math.inf] * dim),
                    Box((-math.inf,), (math.inf,)) if continuous else Discrete(num_actions),
                    tuple(state_names), math.nan, math.inf, {}, Box(low, high))
