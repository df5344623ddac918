"""The domains' plants in C for the device programs (`export.device`): `C_PLANTS`, lwrl's
own (a module here per domain, its `C_PLANT`), then those other installed packages add with
entry points of the group `lwrl.c_plants` (`NAME = module:attribute`, NAME the domain, the
attribute a `CPlant`; `lwrl.outside.DomainFacts`). A domain without one is refused in one
line by the device programs."""

from lwrl.export.c_plants import mountain_car
from lwrl.export.c_plants.plant import CPlant
from lwrl.outside import DomainFacts

C_PLANTS = DomainFacts("lwrl.c_plants", CPlant, "plant in C", {
    "mountain_car": mountain_car.C_PLANT,
})
"""`{domain: CPlant}` (see the module)."""
