"""What the project knows about one domain, in one value: `Domain`.

Each domain module (`tasks/<domain>.py`) ends with one `DOMAIN = Domain(...)`, and the
registry (`tasks.DOMAINS`) lists the modules. Every other room looks a domain up here and
names none: the runners take the plants and the run defaults, the viewer the drawing and
the value image's axes, the plant comparison the tolerances, the Gymnasium registration the
observation bounds (those are per task, in `TaskDefinition`), the documentation the physical
parameters, the device programs the plant in C, the benchmark the classical controller.
"""

import dataclasses
from importlib.resources.abc import Traversable
from typing import Callable, Mapping, Optional, Union

import numpy as np

from lwrl.tasks.parameters import Parameters
from lwrl.tasks.plants import DomainPlants


@dataclasses.dataclass(frozen=True)
class Box:
    """A solid box the viewer draws: half sizes and centre (x, y, z), colour (r, g, b)."""

    half_size: tuple
    center: tuple
    color: tuple


@dataclasses.dataclass(frozen=True)
class Line:
    """A polyline the viewer draws: points `(n, 3)`, radius, colour (r, g, b)."""

    points: np.ndarray
    radius: float
    color: tuple


@dataclasses.dataclass(frozen=True)
class Drawing:
    """The 3-D scene of a domain without an MJCF model (z up, in the task's units).

    `fixed` shapes are drawn once in the world; `bodies` maps a moving body's name to its
    shapes in the body's frame; `poses(states (T, d))` gives each body's
    `(translation (T, 3), quaternion (T, 4) x-first)`; `eye` is the default camera
    `(position, look_target)`. Domains with a model are drawn from its geoms and cameras.
    """

    fixed: Mapping
    bodies: Mapping
    poses: Callable
    eye: tuple


@dataclasses.dataclass(frozen=True)
class PlantComparison:
    """How `lwrl compare` holds the plants of a domain against each other."""

    tolerances: Mapping
    """`{state variable: error}` (rad, m) a plant may have before it counts as having left
    the reference; the compared configuration variables."""
    transfer_episodes: int
    """Greedy episodes per agent and plant in the transfer test (fewer where the start is
    deterministic, so a greedy agent's episodes repeat)."""
    rest_start: Optional[Callable] = None
    """`rest_start(rng) -> (d,)`: a start for the zero-action energy trials, where the
    task's own start is an equilibrium that zero action never leaves (None: the task's)."""


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


@dataclasses.dataclass(frozen=True)
class Domain:
    """One domain of the suite: its tasks, its plants and what each room needs of it."""

    name: str
    """E.g. `cartpole`; the registry's key and the prefix of the task names."""
    tasks: Mapping
    """`{task name: factory(**options) -> TaskDefinition}`; the factory's keyword
    arguments are the task's options."""
    plants: DomainPlants
    """How the domain builds its plants (analytic, and MuJoCo where it has a model)."""
    value_axes: tuple
    """The two state variables across and up the value images (the others held at 0)."""
    drawing: Optional[Drawing] = None
    """The viewer's scene where the domain has no MJCF model (else drawn from the model)."""
    comparison: Optional[PlantComparison] = None
    """The plant comparison's settings, for domains with a MuJoCo plant."""
    c_plant: Optional[CPlant] = None
    """Its plant in C for the device programs, where it has one."""
    robustness_axes: tuple = ()
    """The one or two physical parameters (names of `parameters`) whose grid the robustness
    study spans (`lwrl robustness`): what a real plant most often has otherwise than
    modelled, its load and its actuator's strength."""
    tuned_as: Optional[str] = None
    """The Gymnasium environment whose settings other suites tuned (rl-baselines3-zoo's
    `hyperparams/`) a learner takes on this domain's tasks (`Learner.tuned`): its own
    counterpart, or the nearest one the zoo tuned; None: none."""
    classical: Optional[Classical] = None
    """Its classical controller (the benchmark's 1 of a normalised score), where it has
    one."""

    @property
    def model(self) -> Optional[Union[str, Traversable]]:
        """The name of the domain's MJCF file in `models/`, or another package's file
        (`DomainPlants.model`; None: no MuJoCo plant)."""
        return self.plants.model

    @property
    def parameters(self) -> Parameters:
        """The domain's physical parameters (`tasks.parameters`): each one's name, symbol,
        unit, the paper's value and the accepted range, in the order of a parameter vector."""
        return self.plants.parameters
