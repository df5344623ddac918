"""lwrl's task suite: the paper's control tasks as dm_env environments.

    from lwrl import tasks
    env = tasks.load("cartpole", "balance", plant="mujoco", seed=0)
    env = tasks.load("cartpole", "balance", task_kwargs={"random": 0},          # dm_control's
                     environment_kwargs={"flat_observation": True})            # spelling
    ts = env.reset()
    ts = env.step(1)            # a discrete action index

Each domain is one module, `tasks/<domain>.py`, ending with its `DOMAIN` (a
`tasks.domain_contract.Domain`), and one line of `DOMAIN_MODULES` below. `DOMAINS[name]` is
a domain's `Domain`; `ALL_TASKS` lists `(domain, task)` pairs; `PLANTS[domain]` the plants
of a domain, the default first, and `ENVIRONMENT_PLANTS[domain]` those of a single
environment. `definition(...)` gives a task's array functions (a
`tasks.task_definition.TaskDefinition`) and `tasks.batched` steps many copies of a task at
once.
"""

import importlib
import inspect
import os

if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    # The suite renders only when asked; without a display, choosing no OpenGL backend
    # keeps dm_control from trying (and warning about) GLFW at import. Set MUJOCO_GL=egl or
    # osmesa before importing lwrl to render headless.
    os.environ["MUJOCO_GL"] = "disable"

from dm_control.rl import control  # noqa: E402

from lwrl.tasks.base import SuiteTask  # noqa: E402
from lwrl.tasks.task_definition import TaskDefinition  # noqa: E402
from lwrl.tasks.domain_contract import Domain  # noqa: E402

DOMAIN_MODULES = ("mountain_car", "pendulum", "cartpole", "acrobot")
"""The registry: the modules of `tasks/` that each define one domain, in the suite's order."""

DOMAINS = {domain.name: domain for domain in
           (importlib.import_module(f"{__name__}.{module}").DOMAIN for module in DOMAIN_MODULES)}
"""`{name: Domain}` of every domain of the suite."""
ALL_TASKS = tuple((name, task) for name, domain in DOMAINS.items() for task in domain.tasks)
TASK_NAMES = tuple(f"{domain}.{task}" for domain, task in ALL_TASKS)
"""Every task as DOMAIN.TASK."""
PLANTS = {name: domain.plants.names for name, domain in DOMAINS.items()}
ENVIRONMENT_PLANTS = {name: domain.plants.environment_names for name, domain in DOMAINS.items()}
"""The plants of `load`'s dm_env environments per domain: `PLANTS` less the batched-only
(`tasks.plants.BATCHED_ONLY`)."""


def domain(name: str) -> Domain:
    """The `Domain` called `name`, or a ValueError naming the domains."""
    if name not in DOMAINS:
        raise ValueError(f"unknown domain {name!r}; available: {', '.join(DOMAINS)}")
    return DOMAINS[name]


def split_name(name: str) -> tuple[str, str]:
    """`(domain, task)` of `DOMAIN.TASK`, or a ValueError naming the suite's tasks."""
    domain_name, dot, task = name.partition(".")
    if not dot or not task:
        raise ValueError(f"task must be written DOMAIN.TASK, one of: {', '.join(TASK_NAMES)}; "
                         f"got {name!r}")
    return domain_name, task


def task_options(domain_name: str, task: str) -> list:
    """The names of a task's options (e.g. `time_limit`, `track_limit`)."""
    tasks = domain(domain_name).tasks
    if task not in tasks:
        raise ValueError(f"unknown task {task!r} of domain {domain_name!r}; available: "
                         f"{', '.join(tasks)}")
    return list(inspect.signature(tasks[task]).parameters)


def plant_option_names(domain_name: str, plant: str) -> list:
    """The options of a domain's plant: those of its analytic plant (`integrator` and
    `equations` where it has them, `DomainPlants.analytic_options`); MuJoCo has none."""
    return list(domain(domain_name).plants.analytic_options) if plant == "analytic" else []


def resolve(domain_name: str, task: str, plant=None, **options):
    """Check a task, a plant and options; return `(definition, plant, plant_options)`.

    Options are the task's (e.g. `time_limit`, `track_limit`) and, for the analytic plant
    of the domains integrated with Euler's method, `integrator` and `equations`
    (`tasks.plants.EQUATIONS`).
    """
    task_option_names = task_options(domain_name, task)
    plants = domain(domain_name).plants.names
    plant = plants[0] if plant is None else plant
    if plant not in plants:
        raise ValueError(f"unknown plant {plant!r} for {domain_name}; available: {', '.join(plants)}")
    plant_options = plant_option_names(domain_name, plant)
    unknown = sorted(set(options) - set(task_option_names) - set(plant_options))
    if unknown:
        allowed = ", ".join(["plant", "seed"] + task_option_names + plant_options)
        raise ValueError(f"unknown option {unknown[0]!r} for {domain_name}.{task} on the {plant} "
                         f"plant; allowed: {allowed}")
    definition = domain(domain_name).tasks[task](
        **{k: v for k, v in options.items() if k in task_option_names})
    return definition, plant, {k: v for k, v in options.items() if k in plant_options}


def definition(domain_name: str, task: str, **options) -> TaskDefinition:
    """The array functions of a task (start, observation, reward, termination, up-time)."""
    return resolve(domain_name, task, None, **options)[0]


def load(domain_name: str, task: str, plant=None, seed=None, *, task_kwargs=None,
         environment_kwargs=None, **options) -> control.Environment:
    """Return the dm_env environment of `domain.task` on `plant` (default: the domain's first).

    `seed` seeds the task's random starts. As in dm_control's `suite.load`, `task_kwargs`
    may hold the seed as `random` and the task's options, and `environment_kwargs` is
    passed to `control.Environment` (e.g. `flat_observation=True`). Unknown names or options
    raise a ValueError that names what is allowed.
    """
    task_kwargs = dict(task_kwargs or {})
    if "random" in task_kwargs:
        if seed is not None:
            raise ValueError("give the seed once: seed= or task_kwargs['random'], not both")
        seed = task_kwargs.pop("random")
    twice = sorted(set(task_kwargs) & set(options))
    if twice:
        raise ValueError(f"option {twice[0]!r} given both in task_kwargs and as a keyword")
    task_definition, plant, plant_options = resolve(domain_name, task, plant, **task_kwargs, **options)
    physics = domain(domain_name).plants.physics(plant, **plant_options)
    return control.Environment(physics, SuiteTask(task_definition, seed), **(environment_kwargs or {}))
