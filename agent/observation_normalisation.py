"""Observation normalisation for the deep learners' JAX populations (`agent.dqn_jax`,
`agent.ppo_jax`, `agent.sac_jax`, `agent.td3_jax`), as Stable-Baselines3's
`VecNormalize(norm_obs=True, norm_reward=False)` does it, the wrapper that rl-baselines3-zoo's
`normalize: true` turns on (Raffin et al. 2021, JMLR 22(268)).

With `normalize_observations` set, each agent keeps running statistics of the observations
it sees in learning (`agent.running_stats`, the streaming learners' statistics), and its
networks read every observation as

    x = clip((s - mu) / sqrt(var + 1e-8), -10, 10)      (`VecNormalize.normalize_obs`,
                                                         `clip_obs` 10)

`act` adds the observation to the statistics (when learning; a greedy act, in evaluation or
after `timesteps`, leaves them frozen as learning left them), and the transition, its next
observation and an update's bootstrap observation are normalised with the statistics of that
step. Where this departs from `VecNormalize`, and why: the variance is the sample variance,
1 before two observations (`running_stats.stats_variance`: one implementation of the
statistics in lwrl), where SB3's `RunningMeanStd` starts from a count of 1e-4, mean 0 and
variance 1 and keeps the population variance; and a replay buffer keeps the observations
normalised as they were seen, where SB3 keeps them raw and normalises each minibatch by the
statistics of the time it is drawn.

The statistics are a part of each agent's state (`observation_stats`), so they are saved
and loaded and carried in checkpoints with it, and a part of what it has learned
(`PopulationAgents.learned_tree`), so that its values at states read them. Its arithmetic
is counted with the learner's (`counted`).
"""

import dataclasses

from lwrl.agent.arithmetic import Count
from lwrl.settings import WHEN_SET, check_flag, setting

CLIP = 10.0
"""The normalised observations' bound (`VecNormalize`'s `clip_obs`)."""
STATE = "observation_stats"
"""The agent's state's entry of its observation statistics."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class ObservationNormalisation:
    """The setting that turns the normalisation on (mixed into a learner's settings)."""

    normalize_observations: bool = setting(False, key=WHEN_SET)
    """Normalise each observation by the running mean and variance of those seen in
    learning: the deep learners' JAX populations as SB3's `VecNormalize(norm_obs=True)`
    (clipped to +-10; off by default), the streaming learners as their authors'
    `NormalizeObservation` (on by default)."""

    def check(self, task) -> None:
        """The learner's checks, and a one-line ValueError where `normalize_observations`
        is not true or false."""
        check_flag("normalize_observations", self.normalize_observations)
        super().check(task)

    def describe(self, dim: int) -> str:
        """The learner's description, and the normalisation where it is on."""
        return super().describe(dim) + (", observations normalised (running mean and "
                                        "variance, clipped to +-10)"
                                        if self.normalize_observations else "")


def normalised(observation, stats):
    """`observation` normalised by the running statistics `stats` and clipped to +-`CLIP`,
    float64 (see the module)."""
    import jax.numpy as jnp
    from lwrl.agent import running_stats
    return jnp.clip(running_stats.normalised(observation, stats), -CLIP, CLIP)


def initial_stats(dim: int) -> dict:
    """The statistics of no observation (`running_stats.stats_start`)."""
    from lwrl.agent import running_stats
    return running_stats.stats_start(dim)


def normalising(program):
    """`program` (`jax_population.Program`) reading its observations normalised by the
    statistics in the agent's state (see the module)."""
    import jax
    import jax.numpy as jnp
    from lwrl.agent import running_stats

    def act(state, observation, key, hyper, greedy, clock):
        stats = jax.tree.map(lambda old, new: jnp.where(greedy, old, new), state[STATE],
                             running_stats.stats_add(state[STATE], observation))
        action, extras = program.act(state, normalised(observation, stats), key, hyper, greedy,
                                     clock)
        return action, {"learner": extras, STATE: stats}

    def record(state, extras, observation, action, reward, terminated, truncated,
               final_observation, hyper, clock, write):
        stats = extras[STATE]
        state = program.record(state, extras["learner"], normalised(observation, stats),
                               action, reward, terminated, truncated,
                               normalised(final_observation, stats), hyper, clock, write)
        return {**state, STATE: jax.tree.map(lambda new, old: jnp.where(write, new, old),
                                             stats, state[STATE])}

    def update(state, next_observation, next_start, hyper, clock, due):
        return program.update(state, normalised(next_observation, state[STATE]), next_start,
                              hyper, clock, due)

    return dataclasses.replace(program, act=act, record=record, update=update)


def counted(arithmetic):
    """The learner's `arithmetic` (`Learner.arithmetic`) with the normalisation's where the
    settings turn it on, counted as the streaming learners' (`stream_agents.observation_counts`):
    an observation normalised, d multiply-adds and d square roots, in a greedy decision; in an
    agent-step of learning, three (the observation where the agent acts on it and where the
    transition is recorded, and the next observation) and the observation into the
    statistics (2 d). The statistics are frozen in a greedy decision, so its square roots
    could be constants of a controller; they are counted as computed here."""
    def with_normalisation(settings, task, steps=None):
        counts = arithmetic(settings, task, steps)
        if not settings.normalize_observations:
            return counts
        dim = len(task.state_names)
        normalised = Count(dim, dim)
        return dataclasses.replace(
            counts, decision=counts.decision + normalised,
            step=counts.step + 3 * normalised + Count(2 * dim),
            source=f"{counts.source}, observations normalised ({__name__}.counted)")
    return with_normalisation
