"""The protocol's greedy evaluation of any library's policy (`lwrl bench evaluate`,
`lwrl.bench`): the episodes the benchmark evaluates every row on (`evaluation`: each agent's
`EPISODES` episodes from the starts of its seed + `EVALUATION_SEED`, capped at `STEP_CAP`
steps on the tasks measured in steps, the task's own episodes on the others), run by the
loop that runs the rows (`runners.stepped.run_batched`), and the results file `lwrl bench
score` takes (`outside`), with the protocol's version and the digest of the starts the
episodes ran from.

A policy is what acts on observations (the task's, float64, `TaskDefinition.state_names`):
- an object with Stable-Baselines3's `predict(observations, deterministic=True)`, given a
  batch `(n, d)`;
- a function (NumPy, JAX, ...) of a batch `(n, d)` giving `(n,)` actions, or of one
  observation `(d,)` giving one action: the first call, on a batch, tells which;
- the saved agents of a learner of lwrl's registry, an entry point's among them
  (`agent.io.load`, `lwrl train --save`), agent b the agent of seed b, evaluated together:
  one that diverged in training counts the task's worst outcome, as a row's does.
An action is the index of one of the task's actions, or on a task made with continuous
actions (`DOMAIN.TASK-continuous`) a number u in [-1, 1] that the loop scales to the
actuator's range (`tasks.commands`; beyond it, clipped), as lwrl's learners act.
"""

import dataclasses

import numpy as np
import pandas as pd

from lwrl.agent.learner_contract import Agents
from lwrl.runners.stepped import kind_of, run_batched
from lwrl.studies.paper.benchmark import evaluation, outside, protocol
from lwrl.studies.paper.benchmark.references import ReferencePolicy, reference_actions
from lwrl.tasks.commands import check_kinds
from lwrl.tasks.task_definition import check_actions


@dataclasses.dataclass(frozen=True)
class Evaluation:
    """The greedy episodes of some agents of one task at one fraction of the budget."""

    task: str
    """The task's name (`pendulum.swingup`)."""
    plant: str
    """The plant the episodes ran on (`analytic`, `mujoco`)."""
    fraction: float
    """The fraction of the training budget at which the agents were evaluated."""
    table: pd.DataFrame
    """Per agent and episode: `fraction`, `seed` (the agent's), `episode`, `steps`,
    `uptime_s`."""
    starts: dict
    """`{seed: (EPISODES, d)}` the first observation of each of its episodes."""


class Acting:
    """A policy (see the module) as a function of a batch of observations `(n, d)`."""

    def __init__(self, policy):
        if not (hasattr(policy, "predict") or callable(policy)):
            raise ValueError(f"a policy is a function of observations or has SB3's predict; "
                             f"got a {type(policy).__name__}")
        self.policy = policy
        self.batched = hasattr(policy, "predict") or None

    def __call__(self, observations: np.ndarray) -> np.ndarray:
        if hasattr(self.policy, "predict"):
            return np.asarray(self.policy.predict(observations, deterministic=True)[0])
        if self.batched is None:
            self.batched, actions = self._first(observations)
            return actions
        if self.batched:
            return np.asarray(self.policy(observations))
        return self._each(observations)

    def _each(self, observations: np.ndarray) -> np.ndarray:
        """The actions of a policy of one observation, called on each."""
        actions = [np.asarray(self.policy(o)) for o in observations]
        if any(action.size != 1 for action in actions):
            raise ValueError(f"the policy must give one action per observation: given a batch "
                             f"{observations.shape} or one observation {observations[0].shape}, "
                             f"it gave {np.shape(actions[0])}")
        return np.array([action.reshape(()) for action in actions])

    def _first(self, observations: np.ndarray) -> tuple:
        """`(batched, actions)` from the first call: the policy takes the batch where it gives
        one action per observation, else one observation at a time."""
        try:
            actions = np.asarray(self.policy(observations))
            if actions.shape in ((len(observations),), (len(observations), 1)):
                return True, actions
        except Exception:  # a policy of one observation may fail on a batch in any way
            pass
        return False, self._each(observations)


class PolicyAgents(ReferencePolicy):
    """The agents of an evaluation acting by one policy (`Acting`), or the saved agents of a
    learner of lwrl's registry (`Agents`, `agent.io.load`: agent b the seed b's), the first
    observation of each environment's first `EPISODES` episodes kept (`starts`): `Agents` as
    `run_batched` runs them, as the reference rows are (`references`)."""

    def __init__(self, policy, env):
        definition = env.definition
        super().__init__(env.batch_size, reference_actions(definition),
                         len(definition.state_names))
        self.loaded = policy if isinstance(policy, Agents) else None
        if self.loaded is None:
            self.act = Acting(policy)
        else:
            check_kinds(*kind_of(policy), definition, "the evaluation")
            if policy.batch_size != env.batch_size:
                raise ValueError(f"the saved agents are {policy.batch_size}; the evaluation "
                                 f"takes {env.batch_size}, of seeds 0 to {env.batch_size - 1}")
            self.arrays = policy.arrays  # a diverged agent acts no more
        self.starts = [[] for _ in range(env.batch_size)]

    def step(self, first, reward, discount, observation, active=None, learn=True,
             greedy=False) -> np.ndarray:
        """The policy's greedy action for each acting agent (`Agents.step`'s arguments; the
        others act 0); a one-line ValueError for an action that is not the task's."""
        observation = self.check_observation(observation)
        for b in np.flatnonzero(first):
            if len(self.starts[b]) < evaluation.EPISODES:
                self.starts[b].append(observation[b].copy())
        if self.loaded is not None:
            return self.loaded.step(first, reward, discount, observation, active=active,
                                   learn=False, greedy=True)
        acting = self.acting(active)
        actions = self.no_actions()
        if len(acting):
            actions[acting] = self._checked(self.act(observation[acting]), len(acting))
        return actions

    def _checked(self, actions: np.ndarray, count: int) -> np.ndarray:
        if actions.size != count:
            raise ValueError(f"the policy must give one action per observation: {count} "
                             f"observations, {actions.size} actions")
        actions = actions.reshape(count)
        if self.continuous:
            if not np.isfinite(actions).all():
                raise ValueError("the policy's continuous actions must be finite numbers in [-1, 1]")
            return actions.astype(np.float64)
        return check_actions(actions, self.action_space.n)


def evaluate(policy, task: str, seed=None, fraction: float = 1.0,
             plant: str = "analytic") -> Evaluation:
    """The protocol's greedy episodes of `policy` on `task` (a benchmark task,
    `protocol.BUDGETS`) on `plant`, as the agent of seed `seed` (0 to `protocol.AGENTS` - 1;
    None: every agent acting by it) after `fraction` of the budget (`protocol.FRACTIONS`).
    `policy` may also be the saved `Agents` of every seed (`seed` None)."""
    task = protocol.check_task(task, plant)
    if fraction not in protocol.FRACTIONS:
        raise ValueError(f"fraction must be one of {', '.join(map(str, protocol.FRACTIONS))}; "
                         f"got {fraction!r}")
    if isinstance(policy, Agents) and seed is not None:
        raise ValueError("saved agents are evaluated together, agent b as seed b: seed must be None")
    seeds = list(range(protocol.AGENTS)) if seed is None else [seed]
    if not all(isinstance(s, (int, np.integer)) and 0 <= s < protocol.AGENTS for s in seeds):
        raise ValueError(f"seed must be an integer 0 to {protocol.AGENTS - 1}; got {seed!r}")
    env = evaluation.evaluation_env(task, len(seeds), plant, seeds[0])
    agents = PolicyAgents(policy, env)
    results = run_batched(env, agents, evaluation.EPISODES, learn=False, greedy=True)
    table = pd.DataFrame(results.columns(seeds))[["seed", "episode", "steps", "uptime_s"]]
    table = _worst_where_diverged(table, task, np.asarray(seeds)[agents.diverged])
    return Evaluation(task, plant, float(fraction), table.assign(fraction=float(fraction)),
                      {s: np.stack(agents.starts[b]) for b, s in enumerate(seeds)})


def _worst_where_diverged(table: pd.DataFrame, task: str, diverged) -> pd.DataFrame:
    """Every episode of the agents of the seeds `diverged` (saved agents that diverged in
    training: they act no more) at the task's worst outcome, as the rows count them
    (`evaluation.worst`): the cap's steps, 0 s up; steps as integers (every other episode
    ends: no budget)."""
    worst = table["seed"].isin(list(diverged))
    table = table.assign(steps=table["steps"].where(~worst, evaluation.step_cap(task)))
    if evaluation.task_measure(task).column == "uptime_s":
        table["uptime_s"] = table["uptime_s"].where(~worst, 0.0)
    return table.astype({"steps": np.int64})


def results(evaluations, learner: str) -> pd.DataFrame:
    """The results file's table (`outside`) of `evaluations` (`Evaluation`s of one task and
    plant: every agent at every fraction), named `learner`: the protocol's version and per
    fraction the digest of the starts its episodes ran from. A one-line ValueError where it
    does not follow the protocol (`outside.check`)."""
    evaluations = list(evaluations)
    if not evaluations or len({(e.task, e.plant) for e in evaluations}) != 1:
        raise ValueError("results take the evaluations of one task on one plant")
    task, plant = evaluations[0].task, evaluations[0].plant
    starts = {}
    for each in evaluations:
        starts.setdefault(each.fraction, {}).update(each.starts)
    digests = {fraction: evaluation.starts_digest([by_seed[s] for s in sorted(by_seed)])
               for fraction, by_seed in starts.items()}
    table = pd.concat([e.table for e in evaluations], ignore_index=True)
    table = table.assign(learner=learner, task=task, budget=protocol.BUDGETS[task],
                         protocol=protocol.VERSION, starts=table["fraction"].map(digests))
    table = table.sort_values(["fraction", "seed", "episode"], ignore_index=True)
    table = table[[*outside.COLUMNS, "uptime_s"]]
    outside.check(table, f"the results of {learner}", plant)
    return table
