"""MJCF models of the paper's MuJoCo plants, shipped as package data.

Each model's parameters are commented in its XML with the paper's symbols.
"""

from importlib import resources

NAMES = ("pendulum", "cartpole")


def path(name: str):
    """Return the path of the MJCF file of the model `name` (one of `NAMES`)."""
    if name not in NAMES:
        raise ValueError(f"unknown model {name!r}; available models: {', '.join(NAMES)}")
    return resources.files(__name__).joinpath(f"{name}.xml")


def read(name: str) -> str:
    """Return the MJCF text of the model `name` (one of `NAMES`)."""
    return path(name).read_text()
