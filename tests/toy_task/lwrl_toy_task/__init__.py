"""lwrl-toy-task: a domain of lwrl's suite from another package (`lwrl_toy_task.toy_mass`, with
its MJCF model `toy_mass.xml`), admitted to lwrl's registry by its entry point alone
(pyproject.toml, group `lwrl.tasks`)."""
