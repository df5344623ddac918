"""A run's configuration: frozen dataclasses, one per concern, composed into one.

- `EnvironmentSettings`: the task and its plant;
- `AgentSettings`: the learner (features, trace rule, step sizes);
- `ProtocolSettings`: episodes, agents and seeds;
- `RunConfig` = environment + agent + protocol (+ the task's options), written next to every
  result; `adapters.external.ExternalConfig` composes the same agent and protocol with
  another suite's environment.

Each field's docstring is its documentation and its command-line help: the `lwrl` command's
flags are generated from these fields (`cli.fields`), so a new field needs one edit. A field's
`metadata` may name its flags (`flags`), its allowed values (`choices`, checked here for
every run) and keep it off the command line (`cli=False`). Fields left None take the task's
defaults (`TaskDefinition.defaults`: the paper's settings, SPEC.md), resolved once, as the
configuration is made; it cannot change afterwards.
"""

import dataclasses
import hashlib
import json
import math

import numpy as np

from lwrl import tasks
from lwrl.agent.cmac import CMAC
from lwrl.agent.features import check_count
from lwrl.agent.nrbf import DEFAULT_R2, NRBF
from lwrl.agent.traces import TRACES
from lwrl.tasks.integrators import INTEGRATORS
from lwrl.tasks.plants import EQUATIONS

FEATURES = ("nrbf", "cmac")
PLANT_OPTIONS = ("integrator", "equations")
"""The settings that are options of a plant (`tasks.plant_option_names`)."""
CENTROID_PLACEMENTS = ("midpoints", "edges")


def task_defaults(task: str) -> dict:
    """The settings of a run of `task` (DOMAIN.TASK) unless told otherwise: the NRBF grid
    and ranges, the trace, alpha, lambda, epsilon and the protocol (`TaskDefinition.defaults`)."""
    if task not in tasks.TASK_NAMES:
        raise ValueError(f"unknown task {task!r}; available: {', '.join(tasks.TASK_NAMES)}")
    return dataclasses.asdict(tasks.definition(*tasks.split_name(task)).defaults)


def choices(*allowed) -> dict:
    """A field's metadata: its allowed values."""
    return {"choices": tuple(allowed)}


def fill(config, **values) -> None:
    """Set fields of a frozen configuration while it is being made (`__post_init__` only)."""
    for name, value in values.items():
        object.__setattr__(config, name, value)


def check_choices(config) -> None:
    """Every field with `choices` in its metadata holds one of them (or None)."""
    for field in dataclasses.fields(config):
        allowed = field.metadata.get("choices")
        value = getattr(config, field.name)
        if allowed and value is not None and value not in allowed:
            raise ValueError(f"unknown {field.name} {value!r}; allowed: {', '.join(allowed)}")


def _check_unit_interval(name: str, value) -> None:
    if not (isinstance(value, (int, float, np.floating)) and 0.0 <= value <= 1.0):
        raise ValueError(f"{name} must be a number in [0, 1]; got {value!r}")


@dataclasses.dataclass(frozen=True, kw_only=True)
class EnvironmentSettings:
    """Which task, on which plant."""

    task: str = dataclasses.field(metadata={"cli": False})
    """DOMAIN.TASK of the suite."""
    plant: str | None = None
    """`mujoco`, `analytic` or `mjx` (MuJoCo's XLA port, batched runs only; default: the
    domain's first, MuJoCo where there is one)."""
    integrator: str = dataclasses.field(default="semi_implicit", metadata=choices(*INTEGRATORS))
    """Euler scheme of the analytic plant: `semi_implicit` (MuJoCo's) or `explicit` (the
    paper's literal reading)."""
    equations: str = dataclasses.field(default="paper", metadata=choices(*EQUATIONS))
    """Equations of the analytic plant: the paper's, or `kfnnet`, with the suspected slips
    of the author's code (SPEC.md, "Known traps")."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class AgentSettings:
    """The learner: features, trace rule and step sizes (None: the task's default)."""

    trace: str | None = dataclasses.field(default=None, metadata=choices(*TRACES))
    """Trace rule: `replacing` (eq. 6), `accumulating` (eq. 2) or `replacing_reset` (eq. 5)."""
    alpha: float | None = None
    """Learning rate alpha > 0 (eq. 1)."""
    lam: float | None = dataclasses.field(default=None, metadata={"flags": ("--lambda",)})
    """Trace decay lambda in [0, 1]."""
    epsilon: float | None = None
    """Exploration rate in [0, 1] of the epsilon-greedy policy."""
    gamma: float | None = None
    """Discount rate in [0, 1] (1 in all the paper's tasks)."""
    features: str = dataclasses.field(default="nrbf", metadata=choices(*FEATURES))
    """`nrbf` (the paper's network) or `cmac` (the tile-coding baseline)."""
    n: int | None = dataclasses.field(default=None, metadata={"flags": ("--n", "--centroids")})
    """NRBF centroids per dimension (>= 2), or CMAC intervals per dimension."""
    r2: float = DEFAULT_R2
    """NRBF spread r^2 of eq. 8, in normalised units (the paper: 0.01)."""
    tilings: int = 5
    """CMAC tilings."""
    normalise_alpha: bool = False
    """CMAC only: divide alpha by the tilings (Sutton's code)."""
    low: tuple | None = None
    """Lower end of each state variable's normalisation range, comma-separated (default:
    the task's)."""
    high: tuple | None = None
    """Upper end of each state variable's normalisation range, comma-separated (default:
    the task's)."""
    centroids: str = dataclasses.field(default="midpoints", metadata={
        **choices(*CENTROID_PLACEMENTS), "flags": ("--centroid-placement",)})
    """NRBF centroid placement: `midpoints` of n cells, `(i + 0.5) / n` (the author's code),
    or `edges`, `i / (n - 1)`, from one end of each range to the other (SPEC.md leaves it
    open: the paper says "regularly spaced")."""

    def check_agent(self) -> None:
        """A one-line ValueError for the first agent setting out of its range."""
        if not (isinstance(self.alpha, (int, float, np.floating)) and 0 < self.alpha < math.inf):
            raise ValueError(f"alpha must be a finite number > 0; got {self.alpha!r}")
        for name in ("lam", "epsilon", "gamma"):
            _check_unit_interval("lambda" if name == "lam" else name, getattr(self, name))
        check_count("n (centroids per dimension)", self.n, 2 if self.features == "nrbf" else 1)
        check_count("tilings", self.tilings, 1)
        if not (isinstance(self.r2, (int, float, np.floating)) and 0 < self.r2 < math.inf):
            raise ValueError(f"r2 (the spread r^2) must be a finite number > 0; got {self.r2!r}")

    def describe(self, dim: int) -> str:
        """One line for a run's header: trace, alpha, lambda, epsilon, gamma (where not 1)
        and the network over `dim` state variables."""
        gamma = f", gamma {self.gamma:g}" if self.gamma != 1 else ""
        return (f"{self.trace} traces, alpha {self.alpha:g}, lambda {self.lam:g}, epsilon "
                f"{self.epsilon:g}{gamma}, {self.features} {self.n}^{dim}")

    def feature_map_over(self, low, high):
        """The agents' features over the normalisation ranges `low..high`.

        Centroids at the `edges` are the midpoint grid of `agent.nrbf` over ranges widened by
        half a spacing, `(high - low) / (2 (n - 1))`, at each end, with r^2 scaled by
        `((n - 1) / n)^2`: in those units the distances, and so the features, are the same."""
        if self.features == "cmac":
            return CMAC(low, high, intervals=self.n, tilings=self.tilings,
                        normalise_alpha=self.normalise_alpha)
        if self.centroids == "edges":
            low, high = np.array(low), np.array(high)
            half = (high - low) / (2 * (self.n - 1))
            return NRBF(tuple(low - half), tuple(high + half), self.n,
                        self.r2 * ((self.n - 1) / self.n) ** 2)
        return NRBF(low, high, self.n, self.r2)


@dataclasses.dataclass(frozen=True, kw_only=True)
class ProtocolSettings:
    """How many agents, for how many episodes, from which seed (None: the task's)."""

    episodes: int | None = None
    """Episodes per agent."""
    agents: int | None = None
    """Agents B; agent b is seeded with `seed + b` (its starts and its random stream)."""
    seed: int = 0
    """Seed of the first agent."""

    def check_protocol(self) -> None:
        for name in ("episodes", "agents"):
            check_count(name, getattr(self, name), 1)
        check_count("seed", self.seed, 0)

    @property
    def seeds(self) -> list:
        """One seed per agent: `seed`, `seed + 1`, ..."""
        return list(range(self.seed, self.seed + self.agents))


KEY_ORDER = ("task", "plant", "integrator", "equations", "trace", "alpha", "lam", "epsilon",
             "gamma", "features", "n", "r2", "tilings", "normalise_alpha", "episodes", "agents",
             "seed", "low", "high", "centroids", "task_options")
"""The order in which a run's key hashes its fields: the order they had when the keys were
introduced, so that a finished run keeps its file name. Fields not listed follow, in their
own order."""
OPTIONAL_FIELDS = ("low", "high", "centroids", "task_options", "equations")
"""Readings of SPEC.md's open points that a key names only where a run departs from the
default, so that results computed before those options existed keep their identity."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class RunConfig(ProtocolSettings, AgentSettings, EnvironmentSettings):
    """One run: B agents of one configuration, each with its own seed, on one task and plant.

    Fields left None take the task's default (`task_defaults`), except `low` and `high`,
    which stay None for the task's ranges (`ranges`).
    """

    task_options: dict = dataclasses.field(default_factory=dict, metadata={"cli": False})
    """Options of the task (e.g. the cart-pole's `track_limit`; `tasks.resolve` checks them)."""

    def __post_init__(self):
        defaults = task_defaults(self.task)
        fill(self, **{name: value for name, value in defaults.items()
                      if name not in ("low", "high") and getattr(self, name) is None})
        check_choices(self)
        for field in dataclasses.fields(EnvironmentSettings):
            value = getattr(self, field.name)
            if field.name in PLANT_OPTIONS and value != field.default and field.name not in self.plant_options:
                raise ValueError(f"{field.name} {value!r} applies to the analytic plant of the tasks "
                                 f"that have it; {self.task} on the {self.plant_name} plant has "
                                 f"{', '.join(self.plant_options) or 'no plant options'}")
        for name in ("low", "high"):
            if getattr(self, name) is None:
                continue
            if len(getattr(self, name)) != len(defaults["low"]):
                raise ValueError(f"{name} must have one value per state variable of {self.task} "
                                 f"({len(defaults['low'])}); got {getattr(self, name)!r}")
            fill(self, **{name: tuple(float(value) for value in getattr(self, name))})
        self.check_agent()
        self.check_protocol()

    @property
    def domain(self) -> str:
        return self.task.split(".")[0]

    @property
    def task_name(self) -> str:
        return self.task.split(".")[1]

    @property
    def plant_name(self) -> str:
        """`plant`, or the domain's default plant where it is None."""
        return tasks.resolve(self.domain, self.task_name, self.plant)[1]

    @property
    def plant_options(self) -> dict:
        """The options of the run's plant (`tasks.plant_option_names`) with their values."""
        return {name: getattr(self, name)
                for name in tasks.plant_option_names(self.domain, self.plant_name)}

    @property
    def ranges(self) -> tuple:
        """`(low, high)`: the normalisation ranges set here, else the task's."""
        defaults = task_defaults(self.task)
        return (self.low if self.low is not None else tuple(defaults["low"]),
                self.high if self.high is not None else tuple(defaults["high"]))

    def feature_map(self):
        """The agents' features over the run's normalisation ranges (`feature_map_over`)."""
        return self.feature_map_over(*self.ranges)

    @property
    def name(self) -> str:
        """Task, plant, trace, alpha, lambda and seed, for directory names."""
        return (f"{self.task}-{self.plant or 'default'}-{self.features}-{self.trace}"
                f"-a{self.alpha:g}-l{self.lam:g}-s{self.seed}")

    def to_json(self) -> str:
        return json.dumps(dataclasses.asdict(self), indent=2)

    def key_json(self) -> str:
        """The JSON that identifies the run's results: every field in `KEY_ORDER`, but the
        readings in `OPTIONAL_FIELDS` only where set."""
        fields = dataclasses.asdict(self)
        ordered = [name for name in KEY_ORDER if name in fields]
        ordered += [name for name in fields if name not in KEY_ORDER]
        for field in dataclasses.fields(self):
            default = (field.default if field.default_factory is dataclasses.MISSING
                       else field.default_factory())
            if field.name in OPTIONAL_FIELDS and fields[field.name] == default:
                ordered.remove(field.name)
        return json.dumps({name: fields[name] for name in ordered}, indent=2)

    @property
    def key(self) -> str:
        """A file name for the run: readable, and unique to its whole configuration."""
        return f"{self.name}-{hashlib.sha1(self.key_json().encode()).hexdigest()[:12]}"
