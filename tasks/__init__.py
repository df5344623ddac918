"""lwrl's task suite: the paper's control tasks as dm_env environments.

    from lwrl import tasks
    env = tasks.load("cartpole", "balance", plant="mujoco", seed=0)
    env = tasks.load("cartpole", "balance", task_kwargs={"random": 0},          # dm_control's
                     environment_kwargs={"flat_observation": True})            # spelling
    env = tasks.load("cartpole", "balance", params={"pole_mass": 0.2},         # the physics,
                     observation_noise={"pole_angle": 0.01}, action_delay=1)   # the sensors
    ts = env.reset()
    ts = env.step(1)            # a discrete action index
    env = tasks.load("cartpole", "balance", actions="continuous")  # the force itself, in N
    ts = env.reset(); ts = env.step([3.5])                          # clipped to [-10, 10]

Each domain is one module ending with its `DOMAIN` (a `tasks.domain_contract.Domain`). The
registry has two parts, as `agent.LEARNERS` has: lwrl's own domains, `tasks/<domain>.py` and
one line of `DOMAIN_MODULES` below, and then the domains other installed packages add
through entry points of the group `lwrl.tasks` (`outside_domains`), with no lwrl file edited
to admit them. `DOMAINS[name]` is a domain's `Domain`; `ALL_TASKS` lists `(domain, task)`
pairs; `PLANTS[domain]` the plants of a domain, the default first, and
`ENVIRONMENT_PLANTS[domain]` those of a single environment. `definition(...)` gives a task's array functions (a
`tasks.task_definition.TaskDefinition`) and `tasks.batched` steps many copies of a task at
once. Every task takes its domain's physical parameters as the option `params`
(`Domain.parameters`, `tasks.parameters`) and the option `actions`, `"discrete"` (the
default: an index into the task's controls) or `"continuous"` (the control itself, clipped
to the actuator's range, `TaskDefinition.control_range`); an environment also takes the
sensor and actuator options of `tasks.disturbances`.
"""

import importlib
import importlib.metadata
import inspect
import os

if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    # The suite renders only when asked; without a display, choosing no OpenGL backend
    # keeps dm_control from trying (and warning about) GLFW at import. Set MUJOCO_GL=egl or
    # osmesa before importing lwrl to render headless.
    os.environ["MUJOCO_GL"] = "disable"

from dm_control.rl import control  # noqa: E402

from lwrl.tasks import disturbances  # noqa: E402
from lwrl.tasks.base import SuiteTask  # noqa: E402
from lwrl.tasks.task_definition import ACTIONS, TaskDefinition  # noqa: E402
from lwrl.tasks.domain_contract import Domain  # noqa: E402
from lwrl.spaces import Box, Discrete, TaskSpec  # noqa: E402
from lwrl.outside import admitted  # noqa: E402

DOMAIN_MODULES = ("mountain_car", "pendulum", "cartpole", "acrobot")
"""lwrl's own domains: the modules of `tasks/` that each define one domain, in the suite's
order."""

ENTRY_POINT_GROUP = "lwrl.tasks"
"""The entry-point group through which an installed distribution adds domains: each of its
entry points, `NAME = module:attribute`, names a `Domain` called NAME, with its tasks."""


def outside_domains(registered: dict, entry_points) -> dict:
    """`{name: Domain}` of `entry_points` (of `ENTRY_POINT_GROUP`), in the order of their
    names (then of their distributions), each added beside `registered` and those before it
    (`lwrl.outside.admitted`, as `agent.outside_learners` adds learners).

    One whose name is taken, that fails to import, that is not a `Domain` of its own name,
    or whose domain or task names are not names of letters, digits and _ (`DOMAIN.TASK` and
    the Gymnasium ids, `lwrl/{domain}-{task}-{plant}-v0`, are split at `.` and `-`), is
    skipped with a one-line warning naming it, its distribution and what is wrong.
    `python -W "error:lwrl.tasks entry point"` makes each an error."""
    return admitted(ENTRY_POINT_GROUP, Domain, "domain", registered, entry_points,
                    owner=lambda domain: domain.plants.step.__module__, check=_check_names)


def _check_names(domain: Domain) -> None:
    """A ValueError unless the domain's name and its tasks' are identifiers."""
    for name in (domain.name, *domain.tasks):
        if not (isinstance(name, str) and name.isidentifier()):
            raise ValueError(f"names the domain {domain.name!r} with the task or domain name "
                             f"{name!r}: names are letters, digits and _")


_OWN = {domain.name: domain for domain in
        (importlib.import_module(f"{__name__}.{module}").DOMAIN for module in DOMAIN_MODULES)}
DOMAINS = {**_OWN, **outside_domains(
    _OWN, importlib.metadata.entry_points(group=ENTRY_POINT_GROUP))}
"""`{name: Domain}` of every domain of the suite: lwrl's own, then those of the entry
points."""
ALL_TASKS = tuple((name, task) for name, domain in DOMAINS.items() for task in domain.tasks)
"""Every task as a `(domain, task)` pair."""
TASK_NAMES = tuple(f"{domain}.{task}" for domain, task in ALL_TASKS)
"""Every task as DOMAIN.TASK."""
PLANTS = {name: domain.plants.names for name, domain in DOMAINS.items()}
"""`{domain: plants}`: the plants each domain runs on, its default first."""
ENVIRONMENT_PLANTS = {name: domain.plants.environment_names for name, domain in DOMAINS.items()}
"""The plants of `load`'s dm_env environments per domain: `PLANTS` less the batched-only
(`tasks.plants.BATCHED_ONLY`)."""
ACTIONS_OPTION = "actions"
"""The option every task takes, on every plant: its kind of action (`ACTIONS`,
`TaskDefinition.with_actions`), `"discrete"` by default."""


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
    """The names of a task's options (e.g. `time_limit`, `track_limit`, `params`)."""
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

    Options are the task's (e.g. `time_limit`, `track_limit`, `params`), `actions`
    (`ACTIONS_OPTION`) and, for the analytic plant of the domains integrated with Euler's
    method, `integrator` and `equations` (`tasks.plants.EQUATIONS`).
    """
    return _resolve(domain_name, task, plant, (), options)[:3]


def resolve_environment(domain_name: str, task: str, plant=None, **options):
    """`resolve` for an environment, which also takes the sensor and actuator options
    (`tasks.disturbances.OPTIONS`): `(definition, plant, plant_options, disturbance
    options)`."""
    return _resolve(domain_name, task, plant, disturbances.OPTIONS, options)


def _resolve(domain_name: str, task: str, plant, environment_options: tuple, options: dict):
    task_option_names = task_options(domain_name, task)
    plants = domain(domain_name).plants.names
    plant = plants[0] if plant is None else plant
    if plant not in plants:
        raise ValueError(f"unknown plant {plant!r} for {domain_name}; available: {', '.join(plants)}")
    plant_options = plant_option_names(domain_name, plant)
    unknown = sorted(set(options) - set(task_option_names) - set(plant_options)
                     - {ACTIONS_OPTION} - set(environment_options))
    if unknown:
        allowed = ", ".join(["plant", "seed"] + task_option_names + plant_options
                            + [ACTIONS_OPTION] + list(environment_options))
        raise ValueError(f"unknown option {unknown[0]!r} for {domain_name}.{task} on the {plant} "
                         f"plant; allowed: {allowed}")
    definition = domain(domain_name).tasks[task](
        **{k: v for k, v in options.items() if k in task_option_names}
    ).with_actions(options.get(ACTIONS_OPTION, ACTIONS[0]))
    return (definition, plant, {k: v for k, v in options.items() if k in plant_options},
            {k: v for k, v in options.items() if k in environment_options})


def definition(domain_name: str, task: str, **options) -> TaskDefinition:
    """The array functions of a task (start, observation, reward, termination, up-time), with
    its kind of action (`actions`)."""
    return resolve(domain_name, task, None, **options)[0]


def spec_of(definition: TaskDefinition) -> TaskSpec:
    """What a learner may know of the task `definition` (`lwrl.spaces.TaskSpec`): its
    observation bounds, its actions (`Discrete` of its controls, or with continuous actions
    a `Box` of the actuator's range), state names, timestep, step limit, physical
    parameters' values by name and normalisation ranges (`TaskDefinition.ranges`)."""
    if definition.continuous:
        low, high = definition.control_range
        action = Box((low,), (high,))
    else:
        action = Discrete(definition.num_actions)
    names = domain(definition.domain).parameters.names
    return TaskSpec(definition.name, Box(*definition.bounds), action, definition.state_names,
                    definition.control_timestep, definition.step_limit,
                    dict(zip(names, definition.physical)),
                    Box(*definition.ranges))


def spec(name: str, **options) -> TaskSpec:
    """The `TaskSpec` of the task `DOMAIN.TASK` with its options (`definition`'s), e.g.
    `spec("pendulum.swingup", actions="continuous")`."""
    return spec_of(definition(*split_name(name), **options))


def load(domain_name: str, task: str, plant=None, seed=None, *, task_kwargs=None,
         environment_kwargs=None, **options) -> control.Environment:
    """Return the dm_env environment of `domain.task` on `plant` (default: the domain's first).

    `seed` seeds the task's random starts (and the sensors' and actuator's noise). As in
    dm_control's `suite.load`, `task_kwargs` may hold the seed as `random` and the task's
    options (`params={name: value}`, the physical parameters), and `environment_kwargs` is
    passed to `control.Environment` (e.g. `flat_observation=True`). `actions="continuous"`
    makes the action the control itself (`tasks.base.SuiteTask.action_spec`: a float64
    `BoundedArray` of shape (1,), the actuator's range, which clips it). The sensor and
    actuator options (`tasks.disturbances`) and `randomise={name: (low, high)}`, parameters
    drawn anew for each episode (`tasks.randomisation`), go in `task_kwargs` or as keywords,
    like the task's and `actions`.
    Unknown names or options raise a ValueError that names what is allowed.
    """
    task_kwargs = dict(task_kwargs or {})
    if "random" in task_kwargs:
        if seed is not None:
            raise ValueError("give the seed once: seed= or task_kwargs['random'], not both")
        seed = task_kwargs.pop("random")
    twice = sorted(set(task_kwargs) & set(options))
    if twice:
        raise ValueError(f"option {twice[0]!r} given both in task_kwargs and as a keyword")
    options = {**task_kwargs, **options}
    randomise = options.pop("randomise", None)
    task_definition, plant, plant_options, sensing = resolve_environment(
        domain_name, task, plant, **options)
    physics = domain(domain_name).plants.physics(plant, **plant_options,
                                                 physical=task_definition.physical)
    task_object = SuiteTask(task_definition, seed, disturbances.Disturbances(
        task_definition.state_names, task_definition.control_range, **sensing),
        domain(domain_name).parameters, randomise)
    return control.Environment(physics, task_object, **(environment_kwargs or {}))
