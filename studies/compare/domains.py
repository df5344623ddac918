"""What `lwrl compare` holds the plants of each domain to: `COMPARISONS`, the comparison's own
facts per domain with a MuJoCo plant (lwrl's here, then those other installed packages add
with entry points of the group `lwrl.plant_comparisons`, `NAME = module:attribute`, NAME the
domain, the attribute a `PlantComparison`; `lwrl.outside.DomainFacts`). A domain without one
is refused in one line."""

import dataclasses
from typing import Callable, Mapping, Optional

import numpy as np

from lwrl.outside import DomainFacts
from lwrl.tasks import acrobot, cartpole


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


def tilted_pole(rng: np.random.Generator) -> np.ndarray:
    """A cart-pole start for zero-action trials: the pole tilted by theta ~ U[-12, 12] deg,
    the rest 0 (the upright rest is an equilibrium zero action never leaves)."""
    start = cartpole.initial_states(rng, 1)[0]
    start[2] = rng.uniform(-cartpole.FAIL_ANGLE, cartpole.FAIL_ANGLE)
    return start


def raised_arm(rng: np.random.Generator) -> np.ndarray:
    """An acrobot start for zero-action trials: theta1, theta2 ~ U[-pi/2, pi/2] at rest
    (hanging at rest is an equilibrium zero action never leaves)."""
    start = acrobot.initial_states(rng, 1)[0]
    start[0::2] = rng.uniform(-np.pi / 2, np.pi / 2, size=2)
    return start


COMPARISONS = DomainFacts("lwrl.plant_comparisons", PlantComparison, "plant comparison", {
    "pendulum": PlantComparison(tolerances={"angle": 0.05}, transfer_episodes=10),
    "cartpole": PlantComparison(tolerances={"cart_position": 0.01, "pole_angle": 0.05},
                                transfer_episodes=3, rest_start=tilted_pole),
    "acrobot": PlantComparison(tolerances={"shoulder_angle": 0.05, "elbow_angle": 0.05},
                               transfer_episodes=3, rest_start=raised_arm),
})
"""`{domain: PlantComparison}` (see the module)."""
