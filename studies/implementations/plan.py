"""`lwrl implementations`' plan: the pairs of implementations, each task's measure and
protocol, the runs, and the translation of the tuned settings.

No learner and no task is named here: the pairs come from the registry (`pairs`), the
tasks from the command line, each task's measure from its definition (`measure`).
"""

import ast
import dataclasses
import functools
import importlib
import inspect
import textwrap

import numpy as np

from lwrl import agent as learners
from lwrl import tasks
from lwrl.agent.zoo import TUNED_AS
from lwrl.runners.config import RunConfig, protocol_defaults, task_defaults, tuned_settings
from lwrl.settings import default_of

PLANT = "analytic"
"""The plant of every run: the population learners train on the JAX ports of the analytic
plants (`lwrl.jax`) only, so the reference learners run on the same plant."""


@dataclasses.dataclass(frozen=True)
class Pair:
    """A reference learner and its population twin (registry names)."""

    reference: str
    twin: str

    @property
    def names(self) -> tuple:
        return self.reference, self.twin

    @property
    def slug(self) -> str:
        return f"{self.reference}-{self.twin}"


def pairs(registry=None, actions: str = "discrete") -> list:
    """Every population learner of `registry` (`{name: Learner}`, default the registry) that
    takes `actions` (`Learner.actions`) with the learner whose settings class its own
    subclasses, the closest where several do (e.g. a population learner over `X`'s settings
    and `X`); a population learner with none has no pair. `actions` is the study's kind of
    action: `discrete` (its default) runs the tasks as the paper poses them, `continuous`
    pairs the learners of continuous actions on the tasks made with them."""
    registry = learners.LEARNERS if registry is None else registry
    found = []
    for name, twin in registry.items():
        if not twin.population or twin.actions != actions:
            continue
        parents = [other for other, learner in registry.items()
                   if not learner.population and issubclass(twin.settings, learner.settings)]
        if parents:
            closest = max(parents, key=lambda other: len(registry[other].settings.__mro__))
            found.append(Pair(closest, name))
    return found


@dataclasses.dataclass(frozen=True)
class Measure:
    """A task's measure: a column of the results averaged over an agent's episodes."""

    column: str
    label: str
    higher_is_better: bool
    unit: str = ""

    @property
    def better(self) -> str:
        return "higher is better" if self.higher_is_better else "lower is better"


STEPS = Measure("steps", "mean steps per episode", False)
UPTIME = Measure("uptime_s", "mean up-time per episode", True, "s")


def measure(task: str) -> Measure:
    """The paper's measure of `task` (DOMAIN.TASK): the up-time where the task keeps one (the
    swing-ups and the balancing, Fig. 5, 6 and 8), else the steps per episode (to the goal,
    Fig. 2 and 3)."""
    return UPTIME if tasks.definition(*tasks.split_name(task)).has_uptime else STEPS


@dataclasses.dataclass(frozen=True)
class Cell:
    """One task and one pair: the protocol and the settings both implementations take."""

    task: str
    pair: Pair
    agents: int
    episodes: int
    task_options: dict
    settings: dict
    """The settings given to both (the tuned set, and the study's overrides)."""
    sources: dict
    """`{field: where its value comes from}` for the fields of `settings`."""

    @property
    def measure(self) -> Measure:
        return measure(self.task)

    @property
    def actions(self) -> str:
        """The kind of action both learners take (`Learner.actions`), hence the task's."""
        return learners.learner(self.pair.reference).actions

    def config(self, name: str, seed: int, agents: int = 1, **protocol) -> RunConfig:
        """The run of learner `name` (one of the pair) for `agents` agents from `seed`, on
        the task made with the pair's kind of action (a run key names it where it is not
        the default, discrete)."""
        values = dict(task=self.task, plant=PLANT, learner=name, agents=agents, seed=seed,
                      episodes=self.episodes, task_options=dict(self.task_options),
                      actions=self.actions)
        values.update(protocol)
        return RunConfig(**values, **self.settings)

    def configs(self, name: str) -> list:
        """One run per agent (seeds 0 to agents - 1): a finished agent is never computed
        again, and a larger study keeps the smaller one's agents. A sweep joins the runs of
        a population learner into one population again (they differ in their seeds only)."""
        return [self.config(name, seed) for seed in range(self.agents)]

    @property
    def key(self) -> str:
        return f"{self.task}-{self.pair.slug}"


def tuned_as(task: str) -> str:
    """The Gymnasium environment whose tuned sets the task's domain takes (`agent.zoo`)."""
    return TUNED_AS.of(tasks.split_name(task)[0])


def protocol(task: str, budgets: dict, episodes: int | None, time_limit: float | None) -> tuple:
    """`(episodes, task options)` of `task`: `budgets[task]` (the command's default per
    task) or the task's own episodes, then the study's overrides."""
    default, options = budgets.get(task, (protocol_defaults(task)["episodes"], {}))
    options = dict(options)
    if time_limit is not None:
        options["time_limit"] = float(time_limit)
    return (episodes or default), options


def cells(task_names, agents: int, budgets=None, episodes=None, timesteps=None,
          time_limit=None, registry_pairs=None, actions: str = "discrete") -> list:
    """Every `Cell` of the study: each task (in the order given, once) and each pair of
    `actions` (`pairs`); the settings the reference's tuned set for the task (none: the
    learners' defaults), `timesteps` replacing its horizon. A one-line ValueError for an
    unknown task, a task no pair runs on, or no pair."""
    budgets = budgets or {}
    found = pairs(actions=actions) if registry_pairs is None else registry_pairs
    if not found:
        raise ValueError(f"no population learner of {actions} actions in the registry has a "
                         "reference learner (a learner whose settings class its own subclasses)")
    result = []
    for task in dict.fromkeys(task_names):
        task_defaults(task)  # a one-line error for an unknown task
        count, options = protocol(task, budgets, episodes, time_limit)
        for pair in found:
            settings = tuned_settings(task, pair.reference)
            sources = {name: f"the zoo's {tuned_as(task)} set" for name in settings}
            if timesteps is not None:
                settings["timesteps"] = int(timesteps)
                sources["timesteps"] = "this study (--timesteps)"
            cell = Cell(task, pair, agents, count, options, settings, sources)
            for name in pair.names:  # a one-line error for what either does not run
                cell.config(name, 0)
            result.append(cell)
    return result


ABSENT = "—"
"""A setting's value for an implementation that does not have it."""


@dataclasses.dataclass(frozen=True)
class Row:
    """One setting of the translation: its value for each implementation and its source;
    `default`, for a setting only the twin has, the twin's default (what it does as the
    reference does, without the setting), else `ABSENT`."""

    name: str
    reference: object
    twin: object
    source: str
    help: str
    default: object = ABSENT

    @property
    def same(self) -> bool:
        """Both implementations take the value, or only the twin has the setting and holds
        it at its default."""
        return self.reference == self.twin or (self.reference == ABSENT
                                               and self.twin == self.default)


def translation(cell: Cell) -> list:
    """The settings of both implementations, field by field in the reference's order, then
    any field the twin has beyond them (the twin's own setting, e.g. the JAX learners'
    `normalize_observations`, with its default)."""
    reference, twin = (cell.config(name, 0).settings for name in cell.pair.names)
    ours = {field.name: field for field in dataclasses.fields(reference)}
    theirs = {field.name: field for field in dataclasses.fields(twin)}
    rows = []
    for name in [*ours, *(name for name in theirs if name not in ours)]:
        source = cell.sources.get(name, "the learner's default")
        rows.append(Row(name, getattr(reference, name) if name in ours else ABSENT,
                        getattr(twin, name) if name in theirs else ABSENT, source,
                        _field_help(type(reference), name) or _field_help(type(twin), name),
                        ABSENT if name in ours else default_of(theirs[name])))
    return rows


def reference_settings(reference: str, settings) -> dict:
    """`{field: value}` of the learner `reference`'s settings that a twin's `settings` (a
    subclass of the reference's, `pairs`) hold; a one-line ValueError where the twin sets
    one of its own settings away from its default, which the reference cannot take."""
    ours = {field.name for field in dataclasses.fields(learners.learner(reference).settings)}
    values = {}
    for field in dataclasses.fields(settings):
        value = getattr(settings, field.name)
        if field.name in ours:
            values[field.name] = value
        elif value != default_of(field):
            raise ValueError(f"{field.name}={value!r} is not a setting of {reference}; it "
                             f"runs as {field.name}={default_of(field)!r} (the default) only")
    return values


@functools.lru_cache(maxsize=None)
def _field_docs(cls) -> dict:
    """`{field: docstring}` of a settings dataclass and its bases (the string after each
    field, as the command line's help reads it)."""
    docs = {}
    for klass in reversed(cls.__mro__):
        if not dataclasses.is_dataclass(klass):
            continue
        node = ast.parse(textwrap.dedent(inspect.getsource(klass))).body[0]
        if not isinstance(node, ast.ClassDef):
            continue
        body = node.body
        for statement, following in zip(body, body[1:]):
            if (isinstance(statement, ast.AnnAssign) and isinstance(following, ast.Expr)
                    and isinstance(following.value, ast.Constant)):
                docs[statement.target.id] = " ".join(str(following.value.value).split())
    return docs


def _field_help(cls, name: str) -> str:
    """A settings field's docstring, "" where it has none."""
    try:
        return _field_docs(cls).get(name, "")
    except (OSError, TypeError):  # no source to read
        return ""


def known_differences(name: str) -> tuple:
    """`(module, text)`: what the learner's own modules say differs from the learner it
    re-implements, the paragraphs starting "What differs" of the first docstring that has
    any, of its module (its `make`'s), then of the modules of the classes its agents are
    built from (`make`'s return annotation and its bases: what `sac_jax` and `td3_jax` share
    is said once, in `agent.off_policy_jax`); `(None, "")` where none says it."""
    make = learners.learner(name).make
    made = inspect.signature(make).return_annotation
    bases = made.__mro__ if isinstance(made, type) else ()
    for module_name in dict.fromkeys([make.__module__, *(cls.__module__ for cls in bases)]):
        module = importlib.import_module(module_name)
        paragraphs = [" ".join(part.split()) for part in (module.__doc__ or "").split("\n\n")]
        stated = [part for part in paragraphs if part.startswith("What differs")]
        if stated:
            return module_name, "\n\n".join(stated)
    return None, ""


def title(name: str) -> str:
    return learners.learner(name).title


def starts_box(cell: Cell, count: int = 256, seed: int = 0) -> np.ndarray:
    """`count` states drawn uniformly over the task's ranges (`TaskSpec.ranges`), where the
    initial networks are compared."""
    ranges = cell.config(cell.pair.reference, 0).task_spec.ranges
    low, high = np.asarray(ranges.low, dtype=float), np.asarray(ranges.high, dtype=float)
    return np.random.default_rng(seed).uniform(low, high, size=(count, len(low)))


INIT_AGENTS = 100
"""Untrained agents per implementation whose networks are compared (`initialisation`): the
spread of the initial outputs across agents needs more than the study's ten to be told
from its sampling error."""


def initialisation(cell: Cell, agents: int | None = None) -> dict:
    """Per implementation, its `agents` (default `INIT_AGENTS`) untrained agents (seeds 0
    on) summed up: the parameter count, the spread of the initial parameters, and of the
    network's outputs (`Agents.action_values`: the values of the actions, or
    `Agents.greedy_actions`: a continuous actor's greedy action, whose spread over actions
    is None) over states across the task's
    ranges: the initialisation compared by what it does, whatever order each flattens its
    layers in."""
    from lwrl.runners.run import make_agents
    agents = agents or INIT_AGENTS
    states = starts_box(cell)
    summary = {}
    for name in cell.pair.names:
        made = make_agents(cell.config(name, 0, agents=agents))
        weights = np.asarray(made.arrays.weights, dtype=float)
        outputs = np.asarray(made.greedy_actions(states)[..., None] if made.continuous
                             else made.action_values(states), dtype=float)  # (B, n, A)
        spread = outputs - outputs.mean(axis=-1, keepdims=True)  # what ranks the actions
        ranked = outputs.shape[-1] > 1  # a continuous actor's one output ranks nothing
        summary[name] = {"agents": agents, "parameters": int(weights.shape[1]),
                         "weight_std": float(weights.std()),
                         "weight_abs_max": float(np.abs(weights).max()),
                         "zero_fraction": float(np.mean(weights == 0.0)),
                         "output_mean": float(outputs.mean()),
                         "output_std_over_agents": float(outputs.mean(axis=1).std(axis=0).mean()),
                         "action_spread": float(np.abs(spread).mean()) if ranked else None}
    return summary
