"""A run's configuration: frozen dataclasses, one per concern, composed into one.

- `EnvironmentSettings`: the task and its plant;
- the learner's settings (`agent/<learner>.py`, e.g. `agent.sarsa.SarsaSettings`): one
  dataclass per learner;
- `ProtocolSettings`: episodes, agents and seeds;
- `RunConfig` = environment + learner and its settings + protocol (+ the task's options),
  written next to every result; `adapters.external.ExternalConfig` composes the same
  learner and protocol with another suite's environment.

Each field's docstring is its documentation and its command-line help: the `lwrl` command's
flags are generated from these fields (`cli.fields`), so a new field needs one edit; its
metadata (`lwrl.settings`) says everything else that is derived from it: the run's key,
the results tables' columns, what a batch may vary, what `--set` may change. Fields left
None take the task's defaults (`task_defaults`: the paper agent's settings on the task,
SPEC.md, else each field's own), resolved once, as the configuration is made; it cannot
change afterwards.
"""

import dataclasses
import hashlib
import json

from lwrl import agent, tasks
from lwrl.agent.learner_contract import LearnerSettings
from lwrl.agent.paper_settings import has_paper_settings, paper_settings
from lwrl.spaces import TaskSpec
from lwrl.agent.zoo import TUNED_AS
from lwrl.settings import (LATE, SCALARS, WHEN_SET, base_type, check_choices, check_count,
                           default_of, fill, setting)
from lwrl.tasks.commands import check_kinds
from lwrl.tasks import disturbances
from lwrl.tasks.integrators import INTEGRATORS
from lwrl.tasks.randomisation import check_ranges
from lwrl.tasks.plants import EQUATIONS
from lwrl.tasks.task_definition import ACTIONS


def task_defaults(task: str) -> dict:
    """The settings a run of `task` (DOMAIN.TASK) takes for those it is not given, by name.

    The one rule of a run's defaults: a field marked `per_task` (`lwrl.settings`: the NRBF
    grid n, the trace, alpha, lambda, epsilon, gamma, the protocol's episodes and agents)
    and left None takes the paper agent's setting of the same name on the task
    (`agent.paper_settings.PAPER_SETTINGS`) where the task has them, else the field's own
    `per_task` value (`unset_per_task`); tuned sets (`tuned_settings`) and the run's own
    values come before both. The normalisation ranges are the task's (`TaskSpec.ranges`),
    not among these. {} for a task without the paper agent's settings (an outside task's
    learner then runs on its own defaults); a one-line error for an unknown task."""
    if task not in tasks.TASK_NAMES:
        raise ValueError(f"unknown task {task!r}; available: {', '.join(tasks.TASK_NAMES)}")
    return dataclasses.asdict(paper_settings(task)) if has_paper_settings(task) else {}


def tuned_settings(task: str, learner: str) -> dict:
    """The settings tuned elsewhere for `learner` on `task` (DOMAIN.TASK): its `tuned` set
    for the Gymnasium environment the domain is tuned as (`agent.zoo.TUNED_AS`); {} where
    there is none (the task's defaults, then the learner's, stand)."""
    domain = tasks.split_name(task)[0]
    if domain not in TUNED_AS:
        return {}
    return dict(agent.learner(learner).tuned.get(TUNED_AS[domain], {}))


def task_spec(task: str, task_options: dict | None = None,
              actions: str = ACTIONS[0]) -> TaskSpec:
    """What a learner may know of `task` (DOMAIN.TASK) with its options and its kind of
    `actions`: its spec (`tasks.spec`)."""
    return tasks.spec(task, **(task_options or {}), actions=actions)


def unset_per_task(settings, defaults: dict) -> dict:
    """`{name: value}` of each `per_task` field of the dataclass `settings` left None: the
    value of `defaults` (`task_defaults`) of its name, else the field's own `per_task`."""
    return {field.name: defaults.get(field.name, field.metadata["per_task"])
            for field in dataclasses.fields(settings)
            if "per_task" in field.metadata and getattr(settings, field.name) is None}


def with_defaults(settings, defaults: dict):
    """`settings` with its `per_task` fields left None set (`unset_per_task`)."""
    values = unset_per_task(settings, defaults)
    return dataclasses.replace(settings, **values) if values else settings


def learner_settings(name: str, given) -> LearnerSettings:
    """Learner `name`'s settings from `given`: its settings dataclass, a dict of its fields,
    or None (all unset); a one-line error names the fields it has."""
    cls = agent.learner(name).settings
    if given is None:
        return cls()
    if isinstance(given, cls):
        return given
    if not isinstance(given, dict):
        raise ValueError(f"the settings of {name} must be a {cls.__name__} or a dict; got "
                         f"{type(given).__name__}")
    known = {field.name for field in dataclasses.fields(cls)}
    unknown = sorted(set(given) - known)
    if unknown:
        raise ValueError(f"{unknown[0]} is not a setting of {name}; its settings: "
                         f"{', '.join(sorted(known))}")
    return cls(**given)


def parameters_help() -> str:
    """The domains' parameters and their ranges, for `--param`'s and `--randomise`'s help."""
    return "; ".join(f"{name}: " + ", ".join(parameter.allowed() for parameter in domain.parameters.items)
                     for name, domain in tasks.DOMAINS.items() if domain.parameters.items)


@dataclasses.dataclass(frozen=True, kw_only=True)
class EnvironmentSettings:
    """Which task, on which plant."""

    task: str = setting(cli=False)
    """DOMAIN.TASK of the suite."""
    plant: str | None = None
    """`mujoco`, `analytic` or `mjx` (MuJoCo's XLA port: batched runs and the JAX population
    learners only; default: the domain's first, MuJoCo where there is one)."""
    integrator: str = setting("semi_implicit", choices=INTEGRATORS)
    """Euler scheme of the analytic plant: `semi_implicit` (MuJoCo's) or `explicit` (the
    paper's literal reading)."""
    equations: str = setting("paper", choices=EQUATIONS, key=WHEN_SET, reading=True)
    """Equations of the analytic plant: the paper's, or `kfnnet`, with the suspected slips
    of the author's code (SPEC.md, "Known traps")."""
    params: dict[str, float] = setting(default_factory=dict, key=WHEN_SET, per_agent=True,
                                       flags=("--param",), describe=parameters_help)
    """A physical parameter at another value than the paper's, NAME=VALUE (repeatable; the
    domain's `Domain.parameters`, `lwrl tasks --parameters`)."""
    observation_noise: dict[str, float] = setting(default_factory=dict, key=WHEN_SET,
                                                  per_agent=True)
    """Gaussian noise on an observed state variable, NAME=SIGMA in its units (repeatable;
    `tasks.disturbances`)."""
    action_delay: int = setting(0, key=WHEN_SET, per_agent=True)
    """Control steps K between choosing an action and the actuator applying it (0 before
    the first arrives)."""
    action_noise: float = setting(0.0, key=WHEN_SET, per_agent=True)
    """Gaussian noise SIGMA added to the applied force or torque, in its units, clipped to
    the actuator's range."""
    actions: str = setting(ACTIONS[0], choices=ACTIONS, key=WHEN_SET, flags=("--action-kind",))
    """`discrete` (an index into the task's controls) or `continuous` (the force, torque or
    thrust itself, in the actuator's range): the task's kind of action (`tasks.load`'s
    `actions`), which must be the learner's (`Learner.actions`)."""
    randomise: dict[str, tuple] = setting(default_factory=dict, key=WHEN_SET,
                                          describe=parameters_help)
    """A physical parameter drawn anew for every episode of every agent, uniformly in
    NAME=LOW:HIGH (repeatable; domain randomisation, `tasks.randomisation`): the draws are
    columns of the results."""

    def environment_options(self) -> dict:
        """The physical parameters, the sensor and actuator options and the randomisation
        that depart from their defaults, as `tasks.load` and the run loops take them."""
        return {field.name: getattr(self, field.name) for field in dataclasses.fields(EnvironmentSettings)
                if field.name in ENVIRONMENT_OPTIONS and getattr(self, field.name) != default_of(field)}


PLANT_OPTIONS = ("integrator", "equations")
"""The settings that are options of a plant (`tasks.plant_option_names`)."""
ENVIRONMENT_OPTIONS = ("params", "randomise") + disturbances.OPTIONS
"""The settings that are options of every environment and run loop: the physics, its
randomisation and the sensors and actuator."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class ProtocolSettings:
    """How many agents, for how many episodes, from which seed (None: the task's)."""

    episodes: int | None = setting(per_task=100)
    """Episodes per agent."""
    agents: int | None = setting(per_task=10, per_agent=True)
    """Agents B; agent b is seeded with `seed + b` (its starts and its random stream)."""
    seed: int = setting(0, per_agent=True)
    """Seed of the first agent."""
    budget: int | None = setting(None, key=WHEN_SET)
    """Environment steps per agent at most (none: no budget): an agent stops once it has
    taken them, the episode it is in cut there as at a time limit (truncated), so that
    `episodes` is then the most it runs and every learner gets the same experience."""

    def check_protocol(self) -> None:
        """A one-line ValueError unless `episodes` and `agents` are at least 1, `seed` at
        least 0 and `budget`, where given, at least 1."""
        for name in ("episodes", "agents"):
            check_count(name, getattr(self, name), 1)
        check_count("seed", self.seed, 0)
        if self.budget is not None:
            check_count("budget", self.budget, 1)

    @property
    def seeds(self) -> list:
        """One seed per agent: `seed`, `seed + 1`, ..."""
        return list(range(self.seed, self.seed + self.agents))


def protocol_defaults(task: str) -> dict:
    """`{"episodes": ..., "agents": ...}`: the protocol a run of `task` (DOMAIN.TASK) has
    unless told otherwise (`task_defaults`' rule)."""
    return unset_per_task(ProtocolSettings(), task_defaults(task))


@dataclasses.dataclass(frozen=True, kw_only=True)
class LearnerChoice:
    """Which learner, with which settings."""

    learner: str = setting(agent.DEFAULT_LEARNER, choices=agent.LEARNER_NAMES, key=WHEN_SET)
    """The learner, one of `agent.LEARNERS` (default: the paper's gradient-descent
    Sarsa(lambda) over NRBF or CMAC features); its settings follow."""
    settings: LearnerSettings | None = setting(cli=False)
    """The learner's settings (its settings dataclass; None fields: the task's defaults)."""

    def settings_fields(self, late: bool) -> list:
        """The learner's settings fields, in order: those named in the key before the
        protocol's fields, or (`late`) after them."""
        return [field for field in dataclasses.fields(self.settings)
                if (field.metadata.get("key") == LATE) == late]


def as_written_now(values: dict) -> dict:
    """A run's configuration as a file keeps it (a run's config.json, an agent file's
    `config` metadata), with the names a `RunConfig` takes today: files written before
    2026-12-07 keep the learner's settings under `agent`, their name then, which this
    gives as `settings` (every other name, and anything not a dict, unchanged)."""
    if not isinstance(values, dict) or "agent" not in values or "settings" in values:
        return values
    return {("settings" if name == "agent" else name): value for name, value in values.items()}


def compose(config, values: dict, defaults: dict | None = None) -> None:
    """Fill a configuration `config` of a dataclass with a `LearnerChoice` (made with
    `init=False`) from flat `values`: its own fields by name, the learner's settings from
    `settings` (whole) and from the names that are not its own fields; then `defaults`
    (`{name: value}` of either kind) for what is still unset (None). A name neither has is
    a one-line error naming the learner's settings."""
    cls = type(config)
    learner = values.get("learner", agent.DEFAULT_LEARNER)
    check_choices(LearnerChoice(learner=learner))
    names = {field.name for field in dataclasses.fields(cls)}
    own = {name: value for name, value in values.items() if name in names}
    flat = {name: value for name, value in values.items() if name not in names}
    settings = learner_settings(learner, own.pop("settings", None))
    if flat:
        learner_settings(learner, flat)  # names each unknown setting in one line
        settings = dataclasses.replace(settings, **flat)
    for field in dataclasses.fields(cls):
        fill(config, **{field.name: own.get(field.name, default_of(field))})
    defaults = defaults or {}
    fill(config, **{name: value for name, value in defaults.items()
                    if name in names and getattr(config, name) is None})
    setting_names = {field.name for field in dataclasses.fields(settings)}
    fill(config, settings=dataclasses.replace(settings, **{
        name: value for name, value in defaults.items()
        if name in setting_names and getattr(settings, name) is None}))


@dataclasses.dataclass(frozen=True, kw_only=True, init=False)
class RunConfig(LearnerChoice, ProtocolSettings, EnvironmentSettings):
    """One run: B agents of one learner and configuration, each with its own seed, on one
    task and plant.

    `RunConfig(task=..., learner=..., **settings)`: `settings` are fields of the
    environment, the protocol or the learner's settings, by name (the learner's may also
    come whole, as `settings`); fields left None take the task's defaults (`task_defaults`),
    except a linear learner's `low` and `high`, which stay None for the task's ranges.
    `dataclasses.replace` takes the learner's fields by name in the same way.
    """

    task_options: dict = setting(default_factory=dict, cli=False, key=WHEN_SET)
    """Options of the task (e.g. the cart-pole's `track_limit`; `tasks.resolve` checks them)."""
    trained: str | None = setting(cli=False, key=WHEN_SET)
    """The key of a run whose agents, as they ended it, this run takes (kept by a sweep with
    `keep_agents`, `runners.sweep`); None: new agents."""
    learn: bool = setting(True, cli=False, key=WHEN_SET)
    """False: the agents make no update (an evaluation)."""
    greedy: bool = setting(False, cli=False, key=WHEN_SET)
    """True: the agents act greedily (an evaluation)."""

    def __init__(self, **values):
        compose(self, values)
        self.__post_init__()

    def __post_init__(self):
        if "actions" in self.task_options:  # one spelling per run, so one key: `actions`
            options = dict(self.task_options)
            kind = options.pop("actions")
            if self.actions not in (ACTIONS[0], kind):
                raise ValueError(f"actions {self.actions!r} and task_options' actions {kind!r} "
                                 "differ; give the kind of action once, as actions")
            fill(self, task_options=options, actions=kind)
        defaults = task_defaults(self.task)
        fill(self, **unset_per_task(self, defaults))
        check_choices(self)
        for field in dataclasses.fields(EnvironmentSettings):
            value = getattr(self, field.name)
            if field.name in PLANT_OPTIONS and value != field.default and field.name not in self.plant_options:
                raise ValueError(f"{field.name} {value!r} applies to the analytic plant of the tasks "
                                 f"that have it; {self.task} on the {self.plant_name} plant has "
                                 f"{', '.join(self.plant_options) or 'no plant options'}")
        self.check_environment()
        learner = agent.learner(self.learner)
        check_kinds(learner.name, learner.actions, tasks.definition(self.domain, self.task_name, **self.task_options,
                                              actions=self.actions), "the run")
        fill(self, settings=with_defaults(self.settings, defaults))
        info = self.task_spec
        reason = learner.fits(info)
        if reason is not None:
            raise ValueError(reason)
        self.settings.check(info)
        self.check_protocol()

    def check_environment(self) -> None:
        """A one-line ValueError for a parameter, sensor or actuator option or range that
        the task does not take; the values as they are written (numbers, tuples)."""
        options = self.environment_options()
        parameters = tasks.domain(self.domain).parameters
        ranges = check_ranges(parameters, options.pop("randomise", {}))
        definition, _, _, sensing = tasks.resolve_environment(self.domain, self.task_name,
                                                             self.plant_name, **options)
        disturbances.Disturbances(definition.state_names, definition.controls, **sensing)
        # One spelling per run, so one key: the domain's order, floats.
        fill(self, randomise=ranges,
             params={name: float(self.params[name]) for name in parameters.names
                     if name in self.params},
             observation_noise={name: float(self.observation_noise[name])
                                for name in definition.state_names
                                if name in self.observation_noise})

    @property
    def domain(self) -> str:
        """DOMAIN of the task's DOMAIN.TASK."""
        return self.task.split(".")[0]

    @property
    def task_name(self) -> str:
        """TASK of the task's DOMAIN.TASK."""
        return self.task.split(".")[1]

    @property
    def plant_name(self) -> str:
        """`plant`, or where it is None the domain's default plant, or the analytic plant
        for a learner that trains on the JAX tasks (`Learner.population`)."""
        plant = self.plant
        if plant is None and agent.learner(self.learner).population:
            plant = "analytic"
        return tasks.resolve(self.domain, self.task_name, plant)[1]

    @property
    def plant_options(self) -> dict:
        """The options of the run's plant (`tasks.plant_option_names`) with their values."""
        return {name: getattr(self, name)
                for name in tasks.plant_option_names(self.domain, self.plant_name)}

    @property
    def task_spec(self) -> TaskSpec:
        """What the learner may know of the run's task."""
        return task_spec(self.task, self.task_options, self.actions)

    @property
    def name(self) -> str:
        """Task, plant, the learner's label and the seed, for file and directory names."""
        return f"{self.task}-{self.plant or 'default'}-{self.settings.label()}-s{self.seed}"

    def describe(self) -> str:
        """The learner's settings in one line, for a run's header."""
        return self.settings.describe(len(self.task_spec.state_names))

    def to_json(self) -> str:
        """Every field as indented JSON."""
        return json.dumps(dataclasses.asdict(self), indent=2)

    def flat_fields(self) -> list:
        """`(field, value)` of every setting of the run, the learner's among them, in the
        order the run's key names them: the environment's, the learner's, the protocol's,
        the learner's `LATE` readings, then the run's own (`learner`, `task_options`)."""
        def of(obj, fields):
            return [(field, getattr(obj, field.name)) for field in fields]
        parts = {field.name for cls in (EnvironmentSettings, ProtocolSettings)
                 for field in dataclasses.fields(cls)}
        own = [field for field in dataclasses.fields(RunConfig)
               if field.name not in parts and field.name != "settings"]
        return (of(self, dataclasses.fields(EnvironmentSettings))
                + of(self.settings, self.settings_fields(late=False))
                + of(self, dataclasses.fields(ProtocolSettings))
                + of(self.settings, self.settings_fields(late=True)) + of(self, own))

    def flat(self) -> dict:
        """`{name: value}` of `flat_fields`."""
        return {field.name: value for field, value in self.flat_fields()}

    def columns(self) -> dict:
        """The settings repeated on every row of the run's results table: each of one value
        (its type a `lwrl.settings.SCALARS`, not a tuple or a dict), but the seed, which the
        rows carry per agent, and a setting left unset (None: a column of it would read back
        from the run's file as numbers, not as the table the run made); and each physical
        parameter and observation noise set (`params.NAME`, `observation_noise.NAME`)."""
        columns = {}
        for field, value in self.flat_fields():
            if field.name in ("params", "observation_noise"):  # a column per value set
                columns.update({f"{field.name}.{name}": v for name, v in value.items()})
            elif field.name != "seed" and value is not None and base_type(field.type) in SCALARS:
                columns[field.name] = value
        return columns

    def key_json(self) -> str:
        """The JSON that identifies the run's results: every setting in `flat_fields`' order,
        those whose metadata says `WHEN_SET` or `LATE` only where they depart from their
        default, so that results computed before those settings existed keep their key."""
        named = {field.name: value for field, value in self.flat_fields()
                 if field.metadata.get("key") not in (WHEN_SET, LATE) or value != default_of(field)}
        return json.dumps(named, indent=2)

    @property
    def key(self) -> str:
        """A file name for the run: readable, and unique to its whole configuration."""
        return f"{self.name}-{hashlib.sha1(self.key_json().encode()).hexdigest()[:12]}"
