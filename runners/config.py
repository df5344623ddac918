"""A run's configuration: one dataclass, written next to every result, and the paper's
settings per task (SPEC.md), which are its defaults."""

import dataclasses
import json
import math

import numpy as np

from lwrl.agent.cmac import CMAC
from lwrl.agent.features import check_count
from lwrl.agent.nrbf import DEFAULT_R2, NRBF
from lwrl.agent.traces import TRACES
from lwrl import tasks
from lwrl.tasks.plants import check_equations

PAPER = {
    # task: NRBF grid, normalisation ranges, and the paper's best agent (SPEC.md).
    "mountain_car.cost_to_go": dict(
        n=8, low=(-1.2, -0.07), high=(0.5, 0.07), trace="replacing", alpha=3.9, lam=0.9,
        epsilon=0.0, episodes=40, agents=30),
    "pendulum.swingup": dict(
        n=10, low=(-math.pi, -1.5), high=(math.pi, 1.5), trace="replacing", alpha=1.5, lam=0.4,
        epsilon=0.1, episodes=200, agents=10),
    "cartpole.balance": dict(
        n=6, low=(-2.4, -1.5, -math.radians(12), -5 * math.pi / 6),
        high=(2.4, 1.5, math.radians(12), 5 * math.pi / 6), trace="accumulating", alpha=0.5,
        lam=0.7, epsilon=0.1, episodes=200, agents=10),
}
"""Per task: the NRBF grid `n` and ranges; the best trace, alpha and lambda the paper (or, for
the cart-pole, the author's script) reports; epsilon; and the protocol's episodes and agents."""


CENTROID_PLACEMENTS = ("midpoints", "edges")
OPTIONAL_FIELDS = ("low", "high", "centroids", "task_options", "equations")
"""Readings of SPEC.md's open points that a run sets only to depart from the default."""


@dataclasses.dataclass
class RunConfig:
    """One run: B agents of one configuration, each with its own seed, on one task and plant.

    Fields left None take the paper's value for the task (`PAPER`).
    """

    task: str = "mountain_car.cost_to_go"
    """DOMAIN.TASK of the suite."""
    plant: str | None = None
    """`analytic` or `mujoco` (default: the domain's first, MuJoCo where there is one)."""
    integrator: str = "semi_implicit"
    """Euler scheme of the analytic plant: `semi_implicit` (MuJoCo's) or `explicit`."""
    equations: str = "paper"
    """Equations of the analytic plant (pendulum and cart-pole): the paper's, or `kfnnet`,
    with the suspected slips of the author's code (`tasks.plants.EQUATIONS`)."""
    trace: str | None = None
    """`replacing` (eq. 6), `accumulating` (eq. 2) or `replacing_reset` (eq. 5)."""
    alpha: float | None = None
    """Learning rate alpha > 0 (eq. 1)."""
    lam: float | None = None
    """Trace decay lambda in [0, 1]."""
    epsilon: float | None = None
    """Exploration rate in [0, 1] of the epsilon-greedy policy."""
    gamma: float = 1.0
    """Discount rate in [0, 1] (1 in all the paper's tasks)."""
    features: str = "nrbf"
    """`nrbf` (the paper's network) or `cmac` (the tile-coding baseline)."""
    n: int | None = None
    """NRBF centroids per dimension (>= 2), or CMAC intervals per dimension."""
    r2: float = DEFAULT_R2
    """NRBF spread r^2 (eq. 8)."""
    tilings: int = 5
    """CMAC tilings."""
    normalise_alpha: bool = False
    """CMAC only: divide alpha by the tilings (Sutton's code) when true."""
    episodes: int | None = None
    """Episodes per agent."""
    agents: int | None = None
    """Number of agents B; agent b is seeded with `seed + b`."""
    seed: int = 0
    """Seed of agent 0 (its starts and its random stream)."""
    low: tuple | None = None
    """Lower ends of the normalisation ranges (None: the paper's, `PAPER`)."""
    high: tuple | None = None
    """Upper ends of the normalisation ranges (None: the paper's)."""
    centroids: str = "midpoints"
    """NRBF centroid placement: `midpoints` of n cells, `(i + 0.5) / n` (the author's code),
    or `edges`, `i / (n - 1)`, from one end of each range to the other (SPEC.md leaves it
    open: the paper says "regularly spaced")."""
    task_options: dict = dataclasses.field(default_factory=dict)
    """Options of the task (e.g. the cart-pole's `track_limit`; `tasks.resolve` checks them)."""

    def __post_init__(self):
        if self.task not in PAPER:
            raise ValueError(f"unknown task {self.task!r}; available: {', '.join(PAPER)}")
        for name, value in PAPER[self.task].items():
            if getattr(self, name) is None and name not in ("low", "high"):
                setattr(self, name, value)
        if self.trace not in TRACES:
            raise ValueError(f"unknown trace {self.trace!r}; allowed: {', '.join(TRACES)}")
        if self.features not in ("nrbf", "cmac"):
            raise ValueError(f"unknown features {self.features!r}; allowed: nrbf, cmac")
        check_equations(self.equations)
        if self.equations != "paper" and "equations" not in self.plant_options:
            raise ValueError(f"equations {self.equations!r} need the analytic plant of pendulum or "
                             f"cartpole; got {self.task} on the {self.plant_name} plant")
        if self.centroids not in CENTROID_PLACEMENTS:
            raise ValueError(f"unknown centroid placement {self.centroids!r}; allowed: "
                             f"{', '.join(CENTROID_PLACEMENTS)}")
        for name in ("low", "high"):
            if getattr(self, name) is None:
                continue
            if len(getattr(self, name)) != len(PAPER[self.task]["low"]):
                raise ValueError(f"{name} must have one value per state variable of {self.task} "
                                 f"({len(PAPER[self.task]['low'])}); got {getattr(self, name)!r}")
            setattr(self, name, tuple(float(value) for value in getattr(self, name)))
        for name in ("episodes", "agents"):
            check_count(name, getattr(self, name), 1)
        if not (isinstance(self.seed, (int, np.integer)) and self.seed >= 0):
            raise ValueError(f"seed must be a non-negative integer; got {self.seed!r}")

    @property
    def domain(self) -> str:
        return self.task.split(".")[0]

    @property
    def task_name(self) -> str:
        return self.task.split(".")[1]

    @property
    def plant_name(self) -> str:
        """`plant`, or the domain's default plant where it is None."""
        return self.plant or tasks.PLANTS[self.domain][0]

    @property
    def plant_options(self) -> dict:
        """The options of the run's plant (`tasks.plant_option_names`) with their values."""
        return {name: getattr(self, name)
                for name in tasks.plant_option_names(self.domain, self.plant_name)}

    @property
    def seeds(self) -> list:
        """One seed per agent: `seed`, `seed + 1`, ..."""
        return list(range(self.seed, self.seed + self.agents))

    @property
    def ranges(self) -> tuple:
        """`(low, high)`: the normalisation ranges set here, else the paper's."""
        paper = PAPER[self.task]
        return (self.low if self.low is not None else tuple(paper["low"]),
                self.high if self.high is not None else tuple(paper["high"]))

    def feature_map(self):
        """The agents' features over the normalisation ranges.

        Centroids at the `edges` are the midpoint grid of `agent.nrbf` over ranges widened by
        half a spacing, `(high - low) / (2 (n - 1))`, at each end, with r^2 scaled by
        `((n - 1) / n)^2`: in those units the distances, and so the features, are the same."""
        low, high = self.ranges
        if self.features == "cmac":
            return CMAC(low, high, intervals=self.n, tilings=self.tilings,
                        normalise_alpha=self.normalise_alpha)
        if self.centroids == "edges":
            low, high = np.array(low), np.array(high)
            half = (high - low) / (2 * (self.n - 1))
            return NRBF(tuple(low - half), tuple(high + half), self.n,
                        self.r2 * ((self.n - 1) / self.n) ** 2)
        return NRBF(low, high, self.n, self.r2)

    @property
    def name(self) -> str:
        """Task, plant, trace, alpha, lambda and seed, for directory names."""
        return (f"{self.task}-{self.plant or 'default'}-{self.features}-{self.trace}"
                f"-a{self.alpha:g}-l{self.lam:g}-s{self.seed}")

    def to_json(self) -> str:
        return json.dumps(dataclasses.asdict(self), indent=2)

    def key_json(self) -> str:
        """The JSON that identifies the run's results: every field, but the readings in
        `OPTIONAL_FIELDS` only where set, so that results computed before those options
        existed keep their identity."""
        fields = dataclasses.asdict(self)
        for field in dataclasses.fields(self):
            default = (field.default if field.default_factory is dataclasses.MISSING
                       else field.default_factory())
            if field.name in OPTIONAL_FIELDS and fields[field.name] == default:
                del fields[field.name]
        return json.dumps(fields, indent=2)
