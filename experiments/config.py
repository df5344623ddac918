"""A run's configuration: one dataclass, written next to every result, and the paper's
settings per task (SPEC.md), which are its defaults."""

import dataclasses
import json
import math

import numpy as np

from agent.cmac import CMAC
from agent.features import check_count
from agent.nrbf import DEFAULT_R2, NRBF
from agent.traces import TRACES

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

    def __post_init__(self):
        if self.task not in PAPER:
            raise ValueError(f"unknown task {self.task!r}; available: {', '.join(PAPER)}")
        for name, value in PAPER[self.task].items():
            if name in ("low", "high"):
                continue
            if getattr(self, name) is None:
                setattr(self, name, value)
        if self.trace not in TRACES:
            raise ValueError(f"unknown trace {self.trace!r}; allowed: {', '.join(TRACES)}")
        if self.features not in ("nrbf", "cmac"):
            raise ValueError(f"unknown features {self.features!r}; allowed: nrbf, cmac")
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
    def seeds(self) -> list:
        """One seed per agent: `seed`, `seed + 1`, ..."""
        return list(range(self.seed, self.seed + self.agents))

    def feature_map(self):
        """The agents' features over the task's normalisation ranges."""
        paper = PAPER[self.task]
        if self.features == "cmac":
            return CMAC(paper["low"], paper["high"], intervals=self.n, tilings=self.tilings,
                        normalise_alpha=self.normalise_alpha)
        return NRBF(paper["low"], paper["high"], self.n, self.r2)

    @property
    def name(self) -> str:
        """Task, plant, trace, alpha, lambda and seed, for directory names."""
        return (f"{self.task}-{self.plant or 'default'}-{self.features}-{self.trace}"
                f"-a{self.alpha:g}-l{self.lam:g}-s{self.seed}")

    def to_json(self) -> str:
        return json.dumps(dataclasses.asdict(self), indent=2)
