"""lwrl's learners, over arrays: one module per learner, each ending with its `LEARNER`.

`agent.learner_contract` is the contract every learner fills (`Learner`, `Agents`); `LEARNER_MODULES`
below is the registry, as `tasks.DOMAIN_MODULES` is the suite's. `LEARNERS[name]` is a
learner's `Learner`, `learner(name)` the same with a one-line error naming the learners.
Shared pieces: `features`, `nrbf` and `cmac` (feature maps), `linear` (what linear learners
share), `stable_baselines` (what the Stable-Baselines3 learners share), `arithmetic` (what
the learners' counted arithmetic shares), `traces`, `policy`, `streams` and `threads`; `io`
saves and loads agents.
"""

import importlib

LEARNER_MODULES = ("sarsa", "true_online_sarsa", "ase_ace", "dqn", "ppo", "ppo_jax", "dqn_jax")
"""The registry: the modules of `agent/` that each define one learner, the default first."""

LEARNERS = {module.LEARNER.name: module.LEARNER for module in
            (importlib.import_module(f"{__name__}.{name}") for name in LEARNER_MODULES)}
"""`{name: Learner}` of every learner."""
LEARNER_NAMES = tuple(LEARNERS)
DEFAULT_LEARNER = LEARNER_NAMES[0]


def learner(name: str):
    """The `Learner` called `name`, or a ValueError naming the learners."""
    if name not in LEARNERS:
        raise ValueError(f"unknown learner {name!r}; available: {', '.join(LEARNERS)}")
    return LEARNERS[name]
