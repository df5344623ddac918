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
import warnings

from lwrl.agent.learner_contract import Learner

LEARNER_MODULES = ("sarsa", "true_online_sarsa", "ase_ace", "actor_critic", "dqn", "ppo", "sac", "td3",
                   "ppo_jax", "dqn_jax")
"""lwrl's own learners: the modules of `agent/` that each define one learner, the default
first."""

ENTRY_POINT_GROUP = "lwrl.learners"
"""The entry-point group through which an installed distribution adds learners: each of its
entry points, `NAME = module:attribute`, names a `Learner` called NAME."""


def outside_learners(registered: dict, entry_points) -> dict:
    """`{name: Learner}` of `entry_points` (of `ENTRY_POINT_GROUP`), in the order of their
    names (then of their distributions), each added beside `registered` and those before it.

    One whose name is taken, that fails to import or that is not a `Learner` of its own
    name is skipped, with a one-line warning naming it, its distribution and what is wrong.
    A warning, not an error (pytest stops at a plugin that fails to import, as a plugin
    changes how every test runs; Gymnasium warned of a failing environment plugin and went
    on): `lwrl.agent` is imported by every command, and one broken package must not stop
    the runs of every other learner. Nothing passes unnoticed for that: every run, results
    table and saved agent names its learner, so a skipped one cannot stand in for another
    (asking for it is an unknown learner), and a taken name keeps the learner that had it.
    `python -W "error:lwrl.learners entry point"` makes each an error."""
    found: dict = {}
    for entry_point in sorted(entry_points, key=lambda each: (each.name, each.dist.name)):
        try:
            found[entry_point.name] = _loaded(entry_point, {**registered, **found})
        except ValueError as problem:
            dist = entry_point.dist
            warnings.warn(f"{ENTRY_POINT_GROUP} entry point '{entry_point.name} = "
                          f"{entry_point.value}' of {dist.name} {dist.version} {problem}; "
                          "skipped", stacklevel=2)
    return found


def _loaded(entry_point, taken: dict) -> Learner:
    """The `Learner` an entry point names, or a ValueError saying what is wrong with it."""
    if entry_point.name in taken:
        owner = taken[entry_point.name].settings.__module__
        raise ValueError(f"takes the name of {owner}'s learner: an added learner needs a "
                         "name of its own")
    try:
        named = entry_point.load()
    except Exception as error:  # whatever the package raises, it is the package's fault
        raise ValueError(f"fails to import ({type(error).__name__}: "
                         f"{' '.join(str(error).split())})") from None
    if not isinstance(named, Learner):
        raise ValueError(f"names a {type(named).__name__}, not a Learner "
                         "(lwrl.agent.learner_contract)")
    if named.name != entry_point.name:
        raise ValueError(f"names the learner {named.name!r}: an entry point's name must be "
                         "its learner's")
    return named


_OWN = {module.LEARNER.name: module.LEARNER for module in
        (importlib.import_module(f"{__name__}.{name}") for name in LEARNER_MODULES)}
LEARNERS = {**_OWN, **outside_learners(
    _OWN, importlib.metadata.entry_points(group=ENTRY_POINT_GROUP))}
"""`{name: Learner}` of every learner: lwrl's own, then those of the entry points."""
LEARNER_NAMES = tuple(LEARNERS)
DEFAULT_LEARNER = LEARNER_NAMES[0]


def learner(name: str):
    """The `Learner` called `name`, or a ValueError naming the learners."""
    if name not in LEARNERS:
        raise ValueError(f"unknown learner {name!r}; available: {', '.join(LEARNERS)}")
    return LEARNERS[name]
