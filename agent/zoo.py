"""Which Gymnasium environment rl-baselines3-zoo tuned stands for each domain: `TUNED_AS`.

A learner's `tuned` sets (`Learner.tuned`: the zoo's `hyperparams/` per Gymnasium id) are
taken on the domains tuned as that environment (`runners.config.tuned_settings`), as MuJoCo
Playground keeps tuned settings beside its learners rather than inside its environments.
`TUNED_AS` is lwrl's domains' (each its own counterpart, or the nearest one the zoo tuned),
then those other installed packages add with entry points of the group `lwrl.tuned_as`
(`NAME = module:attribute`, NAME the domain, the attribute a Gymnasium id;
`lwrl.outside.DomainFacts`). A domain without one takes the learner's own defaults.
"""

from lwrl.outside import DomainFacts

TUNED_AS = DomainFacts("lwrl.tuned_as", str, "Gymnasium counterpart", {
    "mountain_car": "MountainCar-v0",
    # the zoo tunes Pendulum-v1 for continuous torque only: the discrete swing-up's nearest
    # tuned task is the acrobot's
    "pendulum": "Acrobot-v1",
    "cartpole": "CartPole-v1",
    "acrobot": "Acrobot-v1",
})
"""`{domain: Gymnasium id}` (see the module)."""
