"""MJCF models of the suite's MuJoCo plants, shipped as package data: `<domain>.xml`.

Each model's parameters are commented in its XML with the paper's symbols; each has at least
two named cameras, as dm_control's suite models do.
"""

from importlib import resources


def names() -> tuple:
    """The models shipped, by name (the file name without `.xml`), sorted."""
    return tuple(sorted(entry.name[:-len(".xml")] for entry in resources.files(__name__).iterdir()
                        if entry.name.endswith(".xml")))


def path(name: str):
    """Return the path of the MJCF file of the model `name` (one of `names()`)."""
    if name not in names():
        raise ValueError(f"unknown model {name!r}; available models: {', '.join(names())}")
    return resources.files(__name__).joinpath(f"{name}.xml")


def read(name: str) -> str:
    """Return the MJCF text of the model `name` (one of `names()`)."""
    return path(name).read_text()
