"""A domain of the suite, in one value: `Domain`, its physics and nothing else.

Each domain module (`tasks/<domain>.py`) ends with one `DOMAIN = Domain(...)`, and the
registry (`tasks.DOMAINS`) lists the modules. A domain is its name, its tasks (each a
`TaskDefinition`, whose spec a learner sees: `lwrl.spaces`), its plants and its physical
parameters, as dm_control's suite keeps a task apart from viewers and benchmarks. What
another part knows of a domain is that part's own fact, in that part's registry by domain
name (`lwrl.outside.DomainFacts`, each with an entry-point group through which other
packages add entries): the viewer's scenes (`viz.scenes`), the device programs' plants in C
(`export.c_plants`), the plant comparison's tolerances (`studies.compare.domains`), the
robustness study's axes (`studies.robustness.domains`), the benchmark's classical
controllers (`studies.paper.benchmark.classical`) and the Gymnasium environment
rl-baselines3-zoo tuned for it (`agent.zoo`).
"""

import dataclasses
from importlib.resources.abc import Traversable
from typing import Mapping, Optional, Union

from lwrl.tasks.parameters import Parameters
from lwrl.tasks.plants import DomainPlants


@dataclasses.dataclass(frozen=True)
class Domain:
    """One domain of the suite: its tasks and its plants (see the module)."""

    name: str
    """E.g. `cartpole`; the registry's key and the prefix of the task names."""
    tasks: Mapping
    """`{task name: factory(**options) -> TaskDefinition}`; the factory's keyword
    arguments are the task's options."""
    plants: DomainPlants
    """How the domain builds its plants (analytic, and MuJoCo where it has a model), with
    its physical parameters."""

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
