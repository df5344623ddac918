"""What a run yields: per-agent, per-episode results, and the bookkeeping that ends an
episode, written once for every way of running (`runners.stepped`, `runners.compiled`)."""

import dataclasses

import numpy as np
from numba.extending import register_jitable


@dataclasses.dataclass
class EpisodeResults:
    """Per-agent, per-episode results; arrays `(B, K)` unless noted."""

    steps: np.ndarray
    """Agent steps in the episode (float: NaN where not run)."""
    returns: np.ndarray
    """Sum of the episode's rewards."""
    uptime: np.ndarray
    """Seconds up (NaN where the task has none or the episode was not run)."""
    truncated: np.ndarray
    """True where the episode hit the time limit (not a terminal state)."""
    diverged_episode: np.ndarray
    """`(B,)`: the episode in which the agent diverged, -1 if it did not."""
    interrupted: bool = False
    """True if the run was interrupted (Ctrl-C): episodes not run are NaN."""
    recordings: list = dataclasses.field(default_factory=list)
    """`EpisodeRecording`s of the episodes asked for with `record`."""
    physical: dict = dataclasses.field(default_factory=dict)
    """`{name: (B, K) values}` of the physical parameters drawn per episode (`randomise`,
    `tasks.randomisation`; NaN where not run); empty where none was drawn."""
    earlier_compute: tuple = (0.0, 0.0)
    """`(wall, CPU)` seconds earlier processes spent on the run before it went on from the
    state they kept (`runners.resume`); zeros for a run computed in one go."""

    @classmethod
    def empty(cls, agents: int, episodes: int) -> "EpisodeResults":
        """Results of `agents` x `episodes` episodes not yet run: NaN steps, returns and
        up-times, none truncated, no agent diverged (-1)."""
        nan = np.full((agents, episodes), np.nan)
        return cls(nan.copy(), nan.copy(), nan.copy(), np.zeros((agents, episodes), dtype=bool),
                   np.full(agents, -1, dtype=np.int64))

    def agents(self, start: int, stop: int) -> "EpisodeResults":
        """The results of agents `start..stop-1` (recordings renumbered from 0)."""
        return EpisodeResults(
            self.steps[start:stop], self.returns[start:stop], self.uptime[start:stop],
            self.truncated[start:stop], self.diverged_episode[start:stop], self.interrupted,
            [dataclasses.replace(r, agent=r.agent - start) for r in self.recordings
             if start <= r.agent < stop],
            {name: values[start:stop] for name, values in self.physical.items()})

    @property
    def diverged(self) -> np.ndarray:
        """`(B, K)`: True from the episode in which the agent diverged on."""
        episodes = np.arange(self.steps.shape[1])
        return (self.diverged_episode[:, None] >= 0) & (episodes >= self.diverged_episode[:, None])

    def columns(self, seeds) -> dict:
        """Flat columns, one entry per agent and episode (episodes numbered from 1), agent
        b seeded with `seeds[b]`, and one per parameter drawn per episode (`physical`): the
        results tables and `episodes.csv` are made of them."""
        agents, episodes = self.steps.shape
        return {"agent": np.repeat(np.arange(agents), episodes),
                "seed": np.repeat(np.asarray(seeds), episodes),
                "episode": np.tile(np.arange(1, episodes + 1), agents),
                "steps": self.steps.ravel(), "return": self.returns.ravel(),
                "uptime_s": self.uptime.ravel(), "truncated": self.truncated.ravel(),
                "diverged": self.diverged.ravel(),
                **{name: values.ravel() for name, values in self.physical.items()}}


def step_budget(budget) -> int:
    """A run's budget of steps per agent (`RunConfig.budget`) as the loops take it: the
    largest int64 for none."""
    return np.iinfo(np.int64).max if budget is None else int(budget)


@register_jitable
def finish_episode(b, k, steps, total, uptime, truncated, diverged, out_steps, out_returns,
                   out_uptime, out_truncated, diverged_episode, done):
    """Agent b finished its episode k: `steps` steps, return `total`, `uptime` seconds up,
    `truncated` at the time limit, and `diverged` in it (its later episodes are not run).
    Writes the `out_*` arrays `(B, K)`, `diverged_episode` and `done` `(B,)` in place; runs
    in Python and in compiled loops alike."""
    out_steps[b, k] = steps
    out_returns[b, k] = total
    out_uptime[b, k] = uptime
    out_truncated[b, k] = truncated
    done[b] = k + 1
    if diverged:
        diverged_episode[b] = k


def episode_starts(definition, seeds, episodes: int) -> np.ndarray:
    """`(B, K, d)`: the start of each agent's episodes, drawn as `BatchedEnv` and `tasks.load`
    draw them (one generator per seed, the episodes' starts in order)."""
    return np.stack([definition.initial_states(np.random.default_rng(seed), episodes)
                     for seed in seeds])
