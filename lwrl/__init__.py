"""lwrl: light-weight reinforcement learning, as a living benchmark.

Främling (2008)'s gradient-descent Sarsa(lambda) with a normalised radial basis function
network, on the paper's control tasks in MuJoCo and as the paper's equations.

    import lwrl
    agents, results = lwrl.run(lwrl.RunConfig(task="pendulum.swingup", agents=10, episodes=30))
    env = lwrl.load("cartpole", "balance", plant="mujoco", seed=0)   # a dm_env
    import lwrl.gym                   # registers the Gymnasium ids lwrl/{domain}-{task}-{plant}-v0

The public surface, importable from `lwrl` itself (each is also where it lives):

- `RunConfig` (`lwrl.runners.config`): one run's environment, learner (and its settings)
  and protocol; fields left unset take the task's defaults.
- `run(config)` (`lwrl.runners.run`): train (or, with `learn=False`, run) a batch of agents;
  returns `(agents, EpisodeResults)`. `make_agents(config)`: the agents alone.
- `EpisodeResults` (`lwrl.runners.episodes`): steps, returns, up-time, truncations and
  divergences per agent and episode.
- `load(domain, task, plant=None, seed=None, **options)` (`lwrl.tasks`): a task as a dm_env
  environment. `definition(domain, task, **options)`: its `TaskDefinition` (array functions
  of start, observation, reward, termination, up-time). `BatchedEnv` (`lwrl.tasks.batched`):
  many copies stepped as arrays.
- The registries (`lwrl.tasks`): `TASK_NAMES` (every task as DOMAIN.TASK), `ALL_TASKS`
  (`(domain, task)` pairs), `DOMAINS` (`{name: Domain}`), `PLANTS` (`{domain: plants}`, the
  default first); and (`lwrl.agent`) `LEARNERS` (`{name: Learner}`, the default first) and
  `LEARNER_NAMES`.

Subpackages, from the bottom up: `models` (MJCF files), `tasks` (the suite), `agent` (the
learners), `analysis` (statistics and figures), `viz` (Rerun), `runners` (runs and sweeps),
`adapters` (other suites), `export` (the C controller), `studies` (the paper, the plant
comparison), `cli` (the `lwrl` command); `kernels` caches the compiled numba kernels on
disk, `outputs` writes outputs whole and claims them, `settings` holds the settings
dataclasses' field metadata, `outside` admits the learners and domains of other installed
packages (entry points), `gym` is the Gymnasium face. Each
subpackage and each public name is imported on first use, so `import lwrl` stays quick.
"""

import importlib
from typing import TYPE_CHECKING

__version__ = "0.2.0"

SUBPACKAGES = ("models", "tasks", "agent", "analysis", "viz", "runners", "adapters", "export",
               "studies", "cli", "gym", "kernels", "outputs", "settings", "outside")
"""The subpackages `lwrl.NAME` imports on first use (the module's docstring says what each is)."""

PUBLIC = {"RunConfig": "lwrl.runners.config", "run": "lwrl.runners.run",
          "make_agents": "lwrl.runners.run", "EpisodeResults": "lwrl.runners.episodes",
          "load": "lwrl.tasks", "definition": "lwrl.tasks", "BatchedEnv": "lwrl.tasks.batched",
          "TASK_NAMES": "lwrl.tasks", "ALL_TASKS": "lwrl.tasks", "DOMAINS": "lwrl.tasks",
          "PLANTS": "lwrl.tasks", "LEARNERS": "lwrl.agent", "LEARNER_NAMES": "lwrl.agent"}
"""`{public name: the module it comes from}`, as the docstring documents them."""

__all__ = ["__version__", *PUBLIC]

if TYPE_CHECKING:  # what static tools see; at run time, __getattr__ imports on first use
    from lwrl.agent import LEARNER_NAMES, LEARNERS
    from lwrl.runners.config import RunConfig
    from lwrl.runners.episodes import EpisodeResults
    from lwrl.runners.run import make_agents, run
    from lwrl.tasks import ALL_TASKS, DOMAINS, PLANTS, TASK_NAMES, definition, load
    from lwrl.tasks.batched import BatchedEnv
else:
    def __getattr__(name):
        if name in PUBLIC:
            return getattr(importlib.import_module(PUBLIC[name]), name)
        if name in SUBPACKAGES:
            return importlib.import_module(f"{__name__}.{name}")
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(list(globals()) + list(SUBPACKAGES) + list(PUBLIC))
