"""lwrl-toy: a learner of lwrl from another package (`lwrl_toy.learner`), admitted to lwrl's
registry by its entry point alone (pyproject.toml, group `lwrl.learners`)."""
