"""The benchmark's classical controllers, its 1 of a normalised score (SPEC.md, "The
benchmark's protocol"): `CLASSICAL`, the benchmark's own facts per domain, lwrl's (a module
here per domain, its `CLASSICAL`), then those other installed packages add with entry points
of the group `lwrl.classical` (`NAME = module:attribute`, NAME the domain, the attribute a
`Classical`; `lwrl.outside.DomainFacts`). A domain without one is refused in one line where
the benchmark needs it."""

from lwrl.outside import DomainFacts
from lwrl.studies.paper.benchmark.classical import acrobot, cartpole, mountain_car, pendulum
from lwrl.studies.paper.benchmark.classical.controller import Classical

CLASSICAL = DomainFacts("lwrl.classical", Classical, "classical controller", {
    "mountain_car": mountain_car.CLASSICAL,
    "pendulum": pendulum.CLASSICAL,
    "cartpole": cartpole.CLASSICAL,
    "acrobot": acrobot.CLASSICAL,
})
"""`{domain: Classical}` (see the module)."""
