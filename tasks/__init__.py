"""lwrl's task suite: the paper's three control tasks as dm_env environments.

    from lwrl import tasks
    env = tasks.load("cartpole", "balance", plant="mujoco", seed=0)
    ts = env.reset()
    ts = env.step(1)            # a discrete action index

`ALL_TASKS` lists `(domain, task)` pairs; `PLANTS[domain]` the plants of a domain, the
default first. `definition(...)` gives a task's array functions and `tasks.batched` steps
many copies of a task at once.
"""

import inspect
import math
import os

if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    # The suite never renders through dm_control; without a display, choosing no OpenGL
    # backend keeps dm_control from trying (and warning about) GLFW at import.
    os.environ["MUJOCO_GL"] = "disable"

from dm_control.rl import control  # noqa: E402

from lwrl.tasks import cartpole, mountain_car, pendulum  # noqa: E402
from lwrl.tasks.base import SuiteTask  # noqa: E402
from lwrl.tasks.definition import TaskDefinition  # noqa: E402

DOMAINS = {"mountain_car": mountain_car, "pendulum": pendulum, "cartpole": cartpole}
ALL_TASKS = tuple((name, task) for name, module in DOMAINS.items() for task in module.SUITE)
PLANTS = {name: module.PLANTS.names for name, module in DOMAINS.items()}


def _domain(domain: str):
    if domain not in DOMAINS:
        raise ValueError(f"unknown domain {domain!r}; available: {', '.join(DOMAINS)}")
    return DOMAINS[domain]


def task_options(domain: str, task: str) -> list:
    """The names of a task's options (e.g. `time_limit`, `track_limit`)."""
    module = _domain(domain)
    if task not in module.SUITE:
        raise ValueError(f"unknown task {task!r} of domain {domain!r}; available: "
                         f"{', '.join(module.SUITE)}")
    return list(inspect.signature(module.SUITE[task]).parameters)


def plant_option_names(domain: str, plant: str) -> list:
    """The options of a domain's plant: `integrator` and `equations` on the analytic plant
    of the domains integrated with Euler's method (pendulum and cartpole), else none."""
    return (["integrator", "equations"] if plant == "analytic" and _domain(domain).PLANTS.euler
            else [])


def resolve(domain: str, task: str, plant=None, **options):
    """Check a task, a plant and options; return `(definition, plant, plant_options)`.

    Options are the task's (e.g. `time_limit`, `track_limit`) and, for the analytic plant
    of pendulum and cartpole, `integrator` and `equations` (`tasks.plants.EQUATIONS`).
    """
    task_option_names = task_options(domain, task)
    module = _domain(domain)
    plants = module.PLANTS.names
    plant = plants[0] if plant is None else plant
    if plant not in plants:
        raise ValueError(f"unknown plant {plant!r} for {domain}; available: {', '.join(plants)}")
    plant_options = plant_option_names(domain, plant)
    unknown = sorted(set(options) - set(task_option_names) - set(plant_options))
    if unknown:
        allowed = ", ".join(["plant", "seed"] + task_option_names + plant_options)
        raise ValueError(f"unknown option {unknown[0]!r} for {domain}.{task} on the {plant} "
                         f"plant; allowed: {allowed}")
    if "time_limit" in options and not (isinstance(options["time_limit"], (int, float))
                                        and 0 < options["time_limit"] <= math.inf):
        raise ValueError(f"time_limit must be a positive number; got {options['time_limit']!r}")
    definition = module.SUITE[task](**{k: v for k, v in options.items() if k in task_option_names})
    return definition, plant, {k: v for k, v in options.items() if k in plant_options}


def definition(domain: str, task: str, **options) -> TaskDefinition:
    """The array functions of a task (start, observation, reward, termination, up-time)."""
    return resolve(domain, task, None, **options)[0]


def load(domain: str, task: str, plant=None, seed=None, **options) -> control.Environment:
    """Return the dm_env environment of `domain.task` on `plant` (default: the domain's first).

    `seed` seeds the task's random starts. Unknown names or options raise a ValueError
    that names what is allowed.
    """
    task_definition, plant, plant_options = resolve(domain, task, plant, **options)
    physics = _domain(domain).PLANTS.physics(plant, **plant_options)
    return control.Environment(physics, SuiteTask(task_definition, seed))
