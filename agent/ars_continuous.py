"""ARS for continuous actions: `agent.ars`'s learner (Mania, Guy & Recht 2018, arXiv:1803.07055,
Algorithm 1, V1-t and V2-t) on the tasks made with continuous actions (`--action-kind
continuous`), its action the linear output theta x clipped to [-1, 1]
(`random_search.continuous_action`; sb3-contrib's `ARSLinearPolicy` clips it to the action
space), which the loops scale to the actuator's range. Everything else is `agent.ars`'s: its
settings, its program, its defaults."""

from lwrl.agent.ars import ArsAgents, ArsSettings
from lwrl.agent.ars import LEARNER as DISCRETE
from lwrl.agent.ars import arithmetic, memory
from lwrl.agent.jax_population import jax_unavailable
from lwrl.agent.learner_contract import Learner
from lwrl.agent.off_policy import fits_continuous


class ArsContinuousAgents(ArsAgents):
    """B ARS agents of continuous actions (see the module)."""


def make(settings, task, seeds) -> ArsContinuousAgents:
    """B ARS agents of continuous actions, agent b with `settings[b]` and its random stream
    from `seeds[b]`."""
    return ArsContinuousAgents(settings, task, seeds)


def load(document, arrays) -> ArsContinuousAgents:
    """The agents `ArsContinuousAgents.saved` wrote (a ValueError if the parts do not fit)."""
    return ArsContinuousAgents.loaded(document, arrays, ArsSettings)


LEARNER = Learner(
    name="ars_continuous", title=DISCRETE.title + ", continuous actions", source=DISCRETE.source,
    settings=ArsSettings, make=make, load=load, memory=memory,
    fits=fits_continuous("ars_continuous"), unavailable=jax_unavailable("ars_continuous"),
    actions="continuous", population=True, arithmetic=arithmetic)
"""The `ars_continuous` learner as the registry holds it (`agent.LEARNERS`)."""
ArsContinuousAgents.learner = LEARNER
