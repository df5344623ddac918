"""The benchmark's two reference rows (docs/FINDINGS.md, "The light-weight claim judged again:
the second benchmark's rule"): a random policy, the 0 of the normalised score, and the
domain's classical controller (`studies.paper.benchmark.classical`), its 1.

Both are `Agents` (`agent.learner_contract`) that `runners.stepped.run_batched` runs as it
runs a learner's, on the same environments, seeds and episodes; but they are no learner:
nothing registers them, they never learn, and they ignore `learn` and `greedy` (a reference
acts alike whatever it is told). Of an `Agents`, `run_batched` reads `step`, and through
`arrays` the `batch_size` and `diverged`; recording an episode also reads the `delta` and
`weights` of `arrays`, which a reference fills with nothing learned (`ReferenceArrays`), and
finds no action values (no `q`).

The classical controllers take the plant's state (`Classical.control`), and the agents see
the task's observation (`TaskDefinition.observe`). They agree on every task:
- Mountain-Car and the cart-pole observe the state as it is;
- the pendulum observes its angle wrapped to [-pi, pi]: its controller wraps the angle itself;
- the acrobot observes both angles wrapped: its controller reads the shoulder's angle only
  through sines and cosines (the energy, the accelerations) and wraps the elbow's itself.
So the control at the observation is the control at the state, up to the round-off of a
cosine 2 pi k away (tests/test_benchmark_evaluation.py checks it at random states).

On a task made with continuous actions (`TaskDefinition.continuous`) both act as a learner
of continuous actions does, by a number u in [-1, 1] that the loop scales to the actuator's
range (`tasks.commands`): the random row draws u uniformly, the classical row takes the u
that commands its control, clipped to the range as the actuator saturates.
"""

import collections

import numpy as np

from lwrl import tasks
from lwrl.agent.learner_contract import CONTINUOUS_ACTIONS, Agents
from lwrl.settings import check_count
from lwrl.spaces import Box, Space
from lwrl.studies.paper.benchmark.classical import CLASSICAL
from lwrl.tasks.batched import BatchedEnv
from lwrl.tasks.task_definition import TaskDefinition

ReferenceArrays = collections.namedtuple("ReferenceArrays", "delta diverged weights")
"""What `run_batched` reads of a reference's `arrays`: `delta` `(B,)` NaN (no TD error), `diverged` `(B,)` False (nothing to diverge) and
`weights` `(B, 0)` (nothing learned)."""


def reference_actions(definition: TaskDefinition) -> Space:
    """The actions a reference row takes on `definition`'s task, as a learner of its kind
    would: `Discrete` of the task's controls, or on a task made with continuous actions
    `CONTINUOUS_ACTIONS`, a number in [-1, 1] the loops scale to the actuator's range."""
    return CONTINUOUS_ACTIONS if definition.continuous else tasks.spec_of(definition).action


class ReferencePolicy(Agents):
    """B agents of a reference row taking actions of `action_space` (`reference_actions`)
    and observing `dim` variables; a subclass chooses the actions (`step`)."""

    def __init__(self, batch: int, action_space: Space, dim: int):
        self.dim, self._action_space = dim, action_space
        self.arrays = ReferenceArrays(np.full(batch, np.nan), np.zeros(batch, dtype=bool),
                                      np.zeros((batch, 0)))

    @property
    def action_space(self) -> Space:
        """The actions it takes (`reference_actions`)."""
        return self._action_space

    @property
    def continuous(self) -> bool:
        """True where it acts by a number in [-1, 1] (a task made with continuous actions)."""
        return isinstance(self._action_space, Box)

    def no_actions(self) -> np.ndarray:
        """`(B,)` zeros of its kind of action, what the agents that do not act take."""
        return np.zeros(self.batch_size, dtype=np.float64 if self.continuous else np.int64)

    def acting(self, active) -> np.ndarray:
        """The indices of the agents that act this step: those `active` (None: all)."""
        return np.arange(self.batch_size) if active is None else np.flatnonzero(active)


class RandomPolicy(ReferencePolicy):
    """Actions drawn uniformly from `action_space`, agent b from its own NumPy
    stream seeded from `seeds[b]`: its draws depend on its seed alone, not on the batch it
    runs in, so a row is reproducible. The stream is a child of the seed's `SeedSequence`
    (`spawn`), not `default_rng(seed)` itself, from which an environment of the same seed
    draws its starts (`tasks.task_definition.random_starts`): the actions are independent of
    the starts."""

    def __init__(self, action_space: Space, dim: int, seeds):
        seeds = [check_count("seed", seed, 0) for seed in seeds]
        super().__init__(len(seeds), action_space, dim)
        self.streams = [np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])
                        for seed in seeds]

    @classmethod
    def on(cls, env: BatchedEnv) -> "RandomPolicy":
        """The row on `env`, agent b seeded as environment b is (`BatchedEnv.seeds`)."""
        return cls(reference_actions(env.definition), len(env.definition.state_names),
                   env.seeds)

    def step(self, first, reward, discount, observation, active=None, learn=True,
             greedy=False) -> np.ndarray:
        """One uniform draw per acting agent, an action's index or u in [-1, 1]
        (`Agents.step`'s arguments; the others act 0)."""
        self.check_observation(observation)
        actions = self.no_actions()
        space = self.action_space
        for b in self.acting(active):
            stream = self.streams[b]
            actions[b] = (stream.uniform(space.low[0], space.high[0]) if self.continuous
                          else stream.integers(space.n))
        return actions


class ClassicalPolicy(ReferencePolicy):
    """The domain's classical controller (`classical.CLASSICAL`, its `source` says whose) on
    `definition`'s task: agent b takes the action nearest
    (`TaskDefinition.nearest_action`) the control wanted at its observation and its
    episode's physical parameter values, as tests/test_classical.py runs it, or on a task
    made with continuous actions the u in [-1, 1] that commands that control (`commanding`).

    It reads those values from `physical` `(B, P)` at every step: give it the environment's
    own `BatchedEnv.physical`, which an environment redraws in place for each episode where
    it randomises them, so that the gains follow the episode's plant. The model-based
    reference knows the plant; a learner is not told."""

    def __init__(self, definition: TaskDefinition, physical: np.ndarray):
        classical = CLASSICAL.of(definition.domain)
        count = len(tasks.domain(definition.domain).parameters.items)
        if np.ndim(physical) != 2 or np.shape(physical)[1] != count:
            raise ValueError(f"physical must have shape (B, {count}), one row of parameter "
                             f"values per agent; got shape {np.shape(physical)}")
        super().__init__(len(physical), reference_actions(definition),
                         len(definition.state_names))
        self.definition, self.physical, self.control = definition, physical, classical.control

    @classmethod
    def on(cls, env: BatchedEnv) -> "ClassicalPolicy":
        """The row on `env`, reading its episodes' parameter values (`BatchedEnv.physical`)."""
        return cls(env.definition, env.physical)

    def step(self, first, reward, discount, observation, active=None, learn=True,
             greedy=False) -> np.ndarray:
        """The action of the classical control of each acting agent (`Agents.step`'s
        arguments; the others act 0)."""
        observation = self.check_observation(observation)
        actions = self.no_actions()
        acting = self.acting(active)
        wanted = np.array([self.control(observation[b], self.physical[b]) for b in acting])
        if self.continuous:
            actions[acting] = commanding(self.definition.control_range_at(self.physical[acting]),
                                         wanted)
        else:
            actions[acting] = self.definition.nearest_action(wanted, self.physical[acting])
        return actions


def commanding(control_range: np.ndarray, controls) -> np.ndarray:
    """`(B,)` the continuous actions u in [-1, 1] that command `controls` `(B,)` in the
    actuators' ranges `control_range` `(B, 2)`: `tasks.commands.commands` inverted, a
    control beyond the range taking its end, as the actuator saturates."""
    low, high = control_range[:, 0], control_range[:, 1]
    return np.clip((np.asarray(controls, dtype=np.float64) - 0.5 * (low + high))
                   / (0.5 * (high - low)), -1.0, 1.0)


ROWS = {"random": RandomPolicy.on, "classical": ClassicalPolicy.on}
"""`{row: make(env)}`: the reference rows, the 0 and the 1 of the normalised score, each
made for a `BatchedEnv`."""
