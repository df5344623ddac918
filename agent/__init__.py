"""lwrl's learners, over arrays: one module per learner, each ending with its `LEARNER`.

`agent.learner_contract` is the contract every learner fills (`Learner`, `Agents`). The
registry has two parts: `LEARNER_MODULES` below, lwrl's own learners, as `tasks.DOMAIN_MODULES`
is the suite's, and then the learners other installed packages add through entry points of
the group `lwrl.learners` (`outside_learners`), with no lwrl file edited to admit them.
`LEARNERS[name]` is a learner's `Learner`, `learner(name)` the same with a one-line error
naming the learners. Shared pieces: `features`, `nrbf` and `cmac` (feature maps), `linear`
(what linear learners share), `stable_baselines` (what the Stable-Baselines3 learners
share), `arithmetic` (what the learners' counted arithmetic shares), `traces`, `policy`,
`streams` and `threads`; `io` saves and loads agents.
"""

import importlib
import importlib.metadata

from lwrl.agent.learner_contract import Learner
from lwrl.outside import admitted

LEARNER_MODULES = ("sarsa", "true_online_sarsa", "ase_ace", "actor_critic", "dqn", "ppo", "sac", "td3",
                   "ppo_jax", "dqn_jax", "sac_jax", "td3_jax", "stream_q",
                   "stream_ac", "stream_ac_discrete", "ars", "ars_continuous")
"""lwrl's own learners: the modules of `agent/` that each define one learner, the default
first."""

ENTRY_POINT_GROUP = "lwrl.learners"
"""The entry-point group through which an installed distribution adds learners: each of its
entry points, `NAME = module:attribute`, names a `Learner` called NAME."""


def outside_learners(registered: dict, entry_points) -> dict:
    """`{name: Learner}` of `entry_points` (of `ENTRY_POINT_GROUP`), in the order of their
    names (then of their distributions), each added beside `registered` and those before it
    (`lwrl.outside.admitted`, as `tasks.outside_domains` adds domains).

    One whose name is taken, that fails to import or that is not a `Learner` of its own
    name is skipped, with a one-line warning naming it, its distribution and what is wrong
    (why a warning, not an error: `lwrl.outside`).
    `python -W "error:lwrl.learners entry point"` makes each an error."""
    return admitted(ENTRY_POINT_GROUP, Learner, "learner", registered, entry_points,
                    owner=lambda learner: learner.settings.__module__)


_OWN = {module.LEARNER.name: module.LEARNER for module in
        (importlib.import_module(f"{__name__}.{name}") for name in LEARNER_MODULES)}
LEARNERS = {**_OWN, **outside_learners(
    _OWN, importlib.metadata.entry_points(group=ENTRY_POINT_GROUP))}
"""`{name: Learner}` of every learner: lwrl's own, then those of the entry points."""
LEARNER_NAMES = tuple(LEARNERS)
"""The names of `LEARNERS`, the default first."""
DEFAULT_LEARNER = LEARNER_NAMES[0]
"""The learner a run takes where it names none: the first of `LEARNERS`, `sarsa` (the
paper's Sarsa(lambda))."""


def learner(name: str):
    """The `Learner` called `name`, or a ValueError naming the learners."""
    if name not in LEARNERS:
        raise ValueError(f"unknown learner {name!r}; available: {', '.join(LEARNERS)}")
    return LEARNERS[name]
