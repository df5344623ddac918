"""MJCF models of the suite's MuJoCo plants, shipped as package data: `<domain>.xml`.

Each model's parameters are commented in its XML with the paper's symbols; each has at least
two named cameras, as dm_control's suite models do. A domain of another package
(`tasks.ENTRY_POINT_GROUP`) ships its model in its own package and names the file itself
(`DomainPlants.model`), which `path` and `read` take as they take a name.
"""

from importlib import resources
from importlib.resources.abc import Traversable


def names() -> tuple:
    """The models shipped, by name (the file name without `.xml`), sorted."""
    return tuple(sorted(entry.name[:-len(".xml")] for entry in resources.files(__name__).iterdir()
                        if entry.name.endswith(".xml")))


def path(name: str | Traversable) -> Traversable:
    """Return the path of the MJCF file of the model `name`: one of `names()`, or the file of
    another package's model itself (a `pathlib.Path` or an `importlib.resources` file,
    `resources.files(package) / "model.xml"`), returned as it is."""
    if not isinstance(name, str):
        return name
    if name not in names():
        raise ValueError(f"unknown model {name!r}; available models: {', '.join(names())}")
    return resources.files(__name__).joinpath(f"{name}.xml")


def read(name: str | Traversable) -> str:
    """Return the MJCF text of the model `name` (one of `names()`, or a file: `path`)."""
    return path(name).read_text()
