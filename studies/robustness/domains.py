"""What `lwrl robustness` varies and how long it evaluates, per domain: `ROBUSTNESS`, the
study's own facts (lwrl's here, then those other installed packages add with entry points of
the group `lwrl.robustness`, `NAME = module:attribute`, NAME the domain, the attribute a
`Robustness`; `lwrl.outside.DomainFacts`). A domain without one is refused in one line."""

import dataclasses

from lwrl.outside import DomainFacts


@dataclasses.dataclass(frozen=True)
class Robustness:
    """The robustness study's facts about one domain."""

    axes: tuple
    """The one or two physical parameters (names of `Domain.parameters`) whose grid the study
    spans: what a real plant most often has otherwise than modelled, its load and its
    actuator's strength."""
    evaluation_episodes: int = 10
    """Greedy episodes per agent and cell (fewer where the start is deterministic, so a
    greedy agent's episodes repeat)."""


ROBUSTNESS = DomainFacts("lwrl.robustness", Robustness, "robustness axes", {
    "mountain_car": Robustness(("gravity", "thrust")),
    "pendulum": Robustness(("mass", "torque")),
    "cartpole": Robustness(("pole_mass", "force"), evaluation_episodes=3),
    "acrobot": Robustness(("link_mass_2", "torque"), evaluation_episodes=3),
})
"""`{domain: Robustness}` (see the module)."""
