"""What the viewer (`viz`) and Gymnasium's `render()` draw of each domain: its `Scene`.

A scene is the viewer's own fact about a domain, kept here rather than in the domain (a
task is its spec and its physics): the two state variables across and up its value images,
and, for a domain without an MJCF model, the `Drawing` of its states (a domain with a model
is drawn from its geoms and cameras). `SCENES` holds lwrl's domains' scenes, then those that
other installed packages add with entry points of the group `lwrl.scenes` (`NAME =
module:attribute`, NAME the domain, the attribute a `Scene`; `lwrl.outside.DomainFacts`).
A domain without a scene has its first two state variables as value axes; asked to draw a
domain with neither a model nor a drawing, `drawing_of` says so in one line.
"""

import dataclasses
from typing import Optional

from lwrl.outside import DomainFacts
from lwrl.viz.drawing import Drawing
from lwrl.viz.scenes import mountain_car


@dataclasses.dataclass(frozen=True)
class Scene:
    """How the viewer shows one domain."""

    value_axes: tuple
    """The two state variables across and up the value images (the others held at 0)."""
    drawing: Optional[Drawing] = None
    """The shapes drawn where the domain has no MJCF model (else drawn from the model)."""


SCENES = DomainFacts("lwrl.scenes", Scene, "scene", {
    "mountain_car": Scene(("position", "velocity"), mountain_car.drawing()),
    "pendulum": Scene(("angle", "angular_velocity")),
    "cartpole": Scene(("pole_angle", "pole_angular_velocity")),
    "acrobot": Scene(("shoulder_angle", "elbow_angle")),
})
"""`{domain: Scene}`: lwrl's domains', then the entry points' (see the module)."""


def value_axes(domain: str, state_names: tuple) -> tuple:
    """The names of the two state variables across and up `domain`'s value images: its
    scene's, else the first two of `state_names`."""
    return SCENES[domain].value_axes if domain in SCENES else tuple(state_names[:2])


def drawing_of(domain: str) -> Drawing:
    """The `Drawing` of a domain without an MJCF model, or a one-line ValueError naming the
    entry-point group through which a package adds one."""
    scene = SCENES.of(domain)
    if scene.drawing is None:
        raise ValueError(f"the scene of {domain!r} has no drawing; a domain without an MJCF "
                         "model needs a Scene with one (entry-point group 'lwrl.scenes')")
    return scene.drawing
