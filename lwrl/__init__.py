"""lwrl: light-weight reinforcement learning, as a living benchmark.

Främling (2008)'s gradient-descent Sarsa(lambda) with a normalised radial basis function
network, on the paper's control tasks in MuJoCo and as the paper's equations.

    import lwrl
    env = lwrl.tasks.load("cartpole", "balance", plant="mujoco", seed=0)   # a dm_env
    import lwrl.gym                   # registers the Gymnasium ids lwrl/{domain}-{task}-{plant}-v0

Subpackages, from the bottom up: `models` (MJCF files), `tasks` (the suite), `agent` (the
learners), `analysis` (statistics and figures), `viz` (Rerun), `runners` (runs and sweeps),
`adapters` (other suites), `export` (the C controller), `studies` (the paper, the plant
comparison), `cli` (the `lwrl` command); `kernels` caches the compiled numba kernels on
disk. Each is imported on first use.
"""

import importlib

__version__ = "0.2.0"

SUBPACKAGES = ("models", "tasks", "agent", "analysis", "viz", "runners", "adapters", "export",
               "studies", "cli", "gym", "kernels", "outputs")


def __getattr__(name):
    if name in SUBPACKAGES:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(list(globals()) + list(SUBPACKAGES))
