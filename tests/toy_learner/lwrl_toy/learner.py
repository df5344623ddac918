"""A toy learner of lwrl, from outside lwrl: tabular Sarsa(0) over a grid of cells, in NumPy.

It is written against lwrl's public learner contract alone (`lwrl.agent.learner_contract`,
with `lwrl.settings` for its settings' checks and metadata) and reaches lwrl's registry
through its entry point `toy = lwrl_toy.learner:LEARNER` of the group `lwrl.learners`
(pyproject.toml), as any installed package would; tests/test_outside_learner.py installs it
so and holds it to the contract. It has no compiled step: it runs in the stepped loop.

Each state variable's range (the task's normalisation ranges, `TaskSpec.ranges`) is
cut into `cells` equal intervals, states beyond it falling in the outer ones, so a state
lies in one of cells^d cells. An agent keeps one value per cell and action, starting at 0,
and acts epsilon-greedily on them; arriving in s' after taking a in s, it chooses a' and
updates Q(s, a) += alpha (r + gamma discount Q(s', a') - Q(s, a)), where Q(s', a') = 0 at
a terminal state (discount 0), where it chooses no action.

Agent b's random numbers: its draw n is the first uniform of NumPy's generator seeded with
(seed_b, n), so its draws depend on its own seed alone, and the two numbers are its whole
stream, saved with its values.
"""

import collections
import dataclasses

import numpy as np

from lwrl.agent.learner_contract import Agents, Learner, LearnerSettings
from lwrl.settings import check_count, check_positive, check_unit_interval, setting

Arrays = collections.namedtuple(
    "Arrays", "weights q delta diverged alpha epsilon gamma seed draws cell action")
"""One batch's state, each with a leading axis B: `weights` `(B, cells^d, A)` (the values),
`q` `(B, A)` (the values at the latest state), `delta` (the latest TD error, NaN where none)
and `diverged`; each agent's settings; its stream (`seed`, `draws`); the cell and action
of its latest step."""


SETTINGS = ("alpha", "epsilon", "gamma")
"""The settings each agent of a batch has its own value of (`per_agent`)."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class ToySettings(LearnerSettings):
    """Tabular Sarsa(0) over a grid of cells."""

    alpha: float = setting(0.5, per_agent=True)
    """Step size alpha > 0."""
    epsilon: float = setting(0.05, per_agent=True)
    """Probability epsilon in [0, 1] of a uniformly random action."""
    gamma: float = setting(1.0, per_agent=True)
    """Discount gamma in [0, 1]."""
    cells: int = 6
    """Intervals per state variable (the grid has cells^d cells)."""

    def check(self, task) -> None:
        check_positive("alpha", self.alpha)
        check_unit_interval("epsilon", self.epsilon)
        check_unit_interval("gamma", self.gamma)
        check_count("cells", self.cells, 1)

    def label(self) -> str:
        return f"toy-c{self.cells}-a{self.alpha:g}-e{self.epsilon:g}"

    def describe(self, dim: int) -> str:
        return (f"toy tabular Sarsa(0) over {self.cells}^{dim} cells, alpha {self.alpha:g}, "
                f"epsilon {self.epsilon:g}, gamma {self.gamma:g}")


class ToyAgents(Agents):
    """B independent toy agents; `alpha`, `epsilon` and `gamma` one per agent (or one for
    all), the grid one for the batch."""

    def __init__(self, *, seeds, alpha, epsilon, gamma, cells, low, high, num_actions,
                 settings=()):
        batch = len(seeds)
        self.dim, self.cells = len(low), cells
        self.low, self.high = np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)
        self.settings = tuple(settings)

        def per_agent(values):
            return np.broadcast_to(np.asarray(values, dtype=np.float64), (batch,)).copy()

        self.arrays = Arrays(
            weights=np.zeros((batch, cells ** self.dim, num_actions)),
            q=np.zeros((batch, num_actions)), delta=np.full(batch, np.nan),
            diverged=np.zeros(batch, dtype=bool), alpha=per_agent(alpha),
            epsilon=per_agent(epsilon), gamma=per_agent(gamma),
            seed=np.asarray(seeds, dtype=np.uint64), draws=np.zeros(batch, dtype=np.uint64),
            cell=np.zeros(batch, dtype=np.int64), action=np.zeros(batch, dtype=np.int64))

    def cells_of(self, states) -> np.ndarray:
        """The cell of each state `(..., d)`: its interval along each variable, the last
        variable's the fastest."""
        scaled = (np.asarray(states, dtype=np.float64) - self.low) / (self.high - self.low)
        index = np.clip(np.floor(scaled * self.cells), 0, self.cells - 1).astype(np.int64)
        return np.ravel_multi_index(tuple(np.moveaxis(index, -1, 0)), (self.cells,) * self.dim)

    def step(self, first, reward, discount, observation, active=None, learn=True,
             greedy=False) -> np.ndarray:
        observation = self.check_observation(observation)
        batch = self.batch_size
        active = np.ones(batch, dtype=bool) if active is None else np.asarray(active, dtype=bool)
        first, reward = np.asarray(first, dtype=bool), np.asarray(reward, dtype=np.float64)
        discount, cells = np.asarray(discount, dtype=np.float64), self.cells_of(observation)
        actions = np.zeros(batch, dtype=np.int64)
        for b in np.flatnonzero(active):
            actions[b] = self._step_one(b, first[b], reward[b], discount[b], cells[b], learn,
                                        greedy)
        return actions

    def _step_one(self, b, first, reward, discount, cell, learn, greedy) -> int:
        """Agent b arrives in `cell`: its next action (0 at a terminal state), and the
        update of the value it left unless `first`, `learn` is False or it diverged."""
        arrays = self.arrays
        values = arrays.weights[b]
        terminal = not first and discount == 0.0
        action = 0 if terminal else self._choose(b, values[cell], greedy)
        arrays.delta[b] = np.nan
        if not first and learn and not arrays.diverged[b]:
            ahead = 0.0 if terminal else values[cell, action]
            left = arrays.cell[b], arrays.action[b]
            delta = reward + arrays.gamma[b] * discount * ahead - values[left]
            arrays.delta[b] = delta
            if np.isfinite(delta):
                values[left] += arrays.alpha[b] * delta
            else:
                arrays.diverged[b] = True
        arrays.q[b] = values[cell]
        arrays.cell[b], arrays.action[b] = cell, action
        return action

    def _choose(self, b, values, greedy) -> int:
        """The first of the best actions or, unless `greedy`, with probability epsilon a
        uniformly random one (from the same draw: below epsilon, it is uniform there)."""
        if not greedy:
            draw, epsilon = self._uniform(b), self.arrays.epsilon[b]
            if draw < epsilon:
                return int(draw / epsilon * len(values))
        return int(np.argmax(values))

    def _uniform(self, b) -> float:
        """Agent b's next draw in [0, 1) (see the module's docstring)."""
        arrays = self.arrays
        draw = np.random.default_rng([int(arrays.seed[b]), int(arrays.draws[b])]).random()
        arrays.draws[b] += 1
        return draw

    def action_values(self, states, weights=None) -> np.ndarray:
        """The values of each state's cell: every agent's `(B, ..., A)`, or those of
        `weights` (one agent's) `(..., A)`."""
        cells = self.cells_of(states)
        return self.arrays.weights[:, cells] if weights is None else np.asarray(weights)[cells]

    def value_box(self) -> tuple:
        """The ranges the grid cuts."""
        return tuple(self.low), tuple(self.high)

    def saved(self) -> tuple[dict, dict]:
        arrays = self.arrays
        document = {"cells": self.cells, "low": self.low.tolist(), "high": self.high.tolist(),
                    "num_actions": self.arrays.q.shape[1],
                    **{name: getattr(arrays, name).tolist() for name in SETTINGS}}
        return document, {name: getattr(arrays, name)
                          for name in ("weights", "seed", "draws", "diverged")}


def make(settings, task, seeds) -> ToyAgents:
    """The agents of `settings` (one `ToySettings` per agent, of one grid) on `task`."""
    grids = sorted({each.cells for each in settings})
    if len(grids) > 1:
        raise ValueError(f"the agents of one batch share their cells; got {grids}")
    return ToyAgents(seeds=seeds, **{name: [getattr(each, name) for each in settings]
                                     for name in SETTINGS},
                     cells=grids[0], low=task.ranges.low, high=task.ranges.high,
                     num_actions=task.action.n, settings=settings)


def load(document, arrays) -> ToyAgents:
    """The agents `ToyAgents.saved` wrote (a ValueError where the parts do not fit)."""
    agents = ToyAgents(seeds=arrays["seed"], **{name: document[name] for name in SETTINGS},
                       cells=document["cells"], low=document["low"], high=document["high"],
                       num_actions=document["num_actions"])
    weights = arrays["weights"]
    if weights.shape != agents.arrays.weights.shape:
        raise ValueError(f"weights of shape {weights.shape} do not fit "
                         f"{agents.arrays.weights.shape}")
    agents.arrays.weights[:] = weights
    agents.arrays.draws[:] = arrays["draws"]
    return agents


def memory(settings, task) -> int:
    """Bytes of one agent's arrays: its values over the grid and at the latest state, eight
    numbers and its divergence flag."""
    actions = task.action.n
    return 8 * (settings.cells ** len(task.state_names) * actions + actions + 8) + 1


LEARNER = Learner(
    name="toy", title="toy tabular Sarsa(0) over a grid of cells (outside lwrl)",
    source="Sutton and Barto (2018), Reinforcement Learning, section 6.4",
    settings=ToySettings, make=make, load=load, memory=memory)
ToyAgents.learner = LEARNER
