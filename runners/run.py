"""The agent-environment loop: B agents, each on its own copy of a task, for K episodes.

Three ways to run the same thing, giving the same numbers for the same seeds (tested):

- `run_dm_env`: one agent on one dm_env environment (`tasks.load`), step by step (through
  `run_batched` and `tasks.batched.SteppedEnvs`, which any dm_env environments can use);
- `run_batched`: B agents on a `tasks.batched.BatchedEnv` (any plant), one array step at a
  time;
- `run_compiled`: B agents on the analytic plant in one numba-compiled loop that calls the
  task's own `transition` and the agent's own `agent_step`, in parallel over agents.

An agent stops after K episodes, or when it diverges (its weights are frozen, the episode it
diverged in is cut there and its later episodes are not run: NaN).
"""

import dataclasses
import functools

import numba
import numpy as np

from lwrl import tasks
from lwrl.agent.features import check_count
from lwrl.agent.sarsa import BatchedSarsa, agent_step
from lwrl.agent.threads import run_in_chunks
from lwrl.tasks.batched import BatchedEnv, SteppedEnvs
from lwrl.runners.recording import make_tape, recordings
from lwrl.tasks.integrators import check_integrator
from lwrl.tasks.plants import check_equations


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

    @classmethod
    def empty(cls, agents: int, episodes: int) -> "EpisodeResults":
        nan = np.full((agents, episodes), np.nan)
        return cls(nan.copy(), nan.copy(), nan.copy(), np.zeros((agents, episodes), dtype=bool),
                   np.full(agents, -1, dtype=np.int64))

    def agents(self, start: int, stop: int) -> "EpisodeResults":
        """The results of agents `start..stop-1` (recordings renumbered from 0)."""
        return EpisodeResults(
            self.steps[start:stop], self.returns[start:stop], self.uptime[start:stop],
            self.truncated[start:stop], self.diverged_episode[start:stop], self.interrupted,
            [dataclasses.replace(r, agent=r.agent - start) for r in self.recordings
             if start <= r.agent < stop])

    @property
    def diverged(self) -> np.ndarray:
        """`(B, K)`: True from the episode in which the agent diverged on."""
        episodes = np.arange(self.steps.shape[1])
        return (self.diverged_episode[:, None] >= 0) & (episodes >= self.diverged_episode[:, None])

    def columns(self, seeds) -> dict:
        """Flat columns, one entry per agent and episode (episodes numbered from 1), agent
        b seeded with `seeds[b]`: the results tables and `episodes.csv` are made of them."""
        agents, episodes = self.steps.shape
        return {"agent": np.repeat(np.arange(agents), episodes),
                "seed": np.repeat(np.asarray(seeds), episodes),
                "episode": np.tile(np.arange(1, episodes + 1), agents),
                "steps": self.steps.ravel(), "return": self.returns.ravel(),
                "uptime_s": self.uptime.ravel(), "truncated": self.truncated.ravel(),
                "diverged": self.diverged.ravel()}


def run_dm_env(env, agent: BatchedSarsa, episodes: int, learn: bool = True) -> EpisodeResults:
    """One agent (`agent.batch_size == 1`) on one dm_env environment of the suite (`tasks.load`),
    step by step: `run_batched` on the environment alone."""
    if agent.batch_size != 1:
        raise ValueError(f"run_dm_env runs one agent; got a batch of {agent.batch_size}")
    return run_batched(SteppedEnvs([env], uptime=lambda single: single.task.uptime), agent,
                       episodes, learn=learn)


def run_batched(env: BatchedEnv, agent: BatchedSarsa, episodes: int, learn: bool = True,
                progress=None, record=()) -> EpisodeResults:
    """B agents on a batched environment of B copies (a `BatchedEnv`, or `SteppedEnvs` of B
    dm_env environments); `progress(done_episodes)` is called as episodes finish. The
    `(agent, episode)` pairs in `record` are recorded step by step (`results.recordings`), as
    `run_compiled` records them; recording needs a `BatchedEnv`."""
    episodes = check_count("episodes", episodes, 1)
    if env.batch_size != agent.batch_size:
        raise ValueError(f"environment batch {env.batch_size} and agent batch "
                         f"{agent.batch_size} differ")
    batch = env.batch_size
    results = EpisodeResults.empty(batch, episodes)
    done = np.zeros(batch, dtype=np.int64)  # finished episodes per agent
    running = np.ones(batch, dtype=bool)
    returns = np.zeros(batch)
    recording = bool(len(record))  # else the step loop skips the tape entirely
    if recording:
        definition = env.definition
        tape = make_tape(record, batch, episodes, definition.step_limit,
                         len(definition.state_names), agent.num_actions,
                         agent.features.num_features)
    actions = np.zeros(batch, dtype=np.int64)
    ts = env.reset()
    try:
        while True:
            previous = actions
            actions = agent.step(ts.first(), ts.reward, ts.discount, ts.observation,
                                 active=running, learn=learn)
            if recording:
                rows = np.where(running, tape.slot[np.arange(batch), np.minimum(done, episodes - 1)], -1)
                _record_step(tape, rows, env, ts, agent, previous)
            newly_diverged = running & agent.diverged
            ended = running & (ts.last() | newly_diverged)
            for b in np.flatnonzero(ended):
                k = done[b]
                results.steps[b, k] = env.steps[b]
                results.returns[b, k] = returns[b]
                results.uptime[b, k] = env.uptime[b]
                results.truncated[b, k] = ts.last()[b] and ts.discount[b] == 1.0
                if newly_diverged[b]:
                    results.diverged_episode[b] = k
            done += ended
            running &= (done < episodes) & ~agent.diverged
            if progress is not None and ended.any():
                progress(int(ended.sum()))
            if not running.any():
                break
            ts = env.step(actions)
            returns = np.where(ts.first(), 0.0, returns + ts.reward)
    except KeyboardInterrupt:
        results.interrupted = True
    if recording:
        results.recordings = recordings(tape, definition, env.plant_name, env.seeds)
    return results


def _record_step(tape, rows, env, ts, agent, previous) -> None:
    """Write this step of the environments with a tape row (`rows[b] >= 0`) to the tape:
    the state and observation reached, Q there, and the action, reward and TD error that
    led to it."""
    for b in np.flatnonzero(rows >= 0):
        r, n = rows[b], env.steps[b]
        tape.states[r, n] = env.state[b]
        tape.observations[r, n] = ts.observation[b]
        tape.q_values[r, n] = agent.memory.q[b]
        if n > 0:
            tape.actions[r, n - 1] = previous[b]
            tape.rewards[r, n - 1] = ts.reward[b]
            tape.td_errors[r, n - 1] = agent.memory.delta[b]
            tape.length[r] = n
            tape.weights[r] = agent.memory.weights[b]


@functools.lru_cache(maxsize=None)
def _compiled_loop(transition):
    """The whole learning loop compiled around one task's `transition`: agents
    `start..stop-1` run episodes `first..first+count-1` (their starts given) unless diverged."""

    @numba.njit(nogil=True)
    def loop(start, stop, first, count, starts, start_observations, controls, dt,
             semi_implicit, slips, params, step_limit, learn, memory, hyper, spec, steps, returns,
             uptime, truncated, diverged_episode, done, tape):
        dim = starts.shape[2]
        for b in range(start, stop):
            state = np.empty(dim)
            next_state = np.empty(dim)
            observation = np.empty(dim)
            for k in range(first, first + count):
                if memory.diverged[b]:
                    break
                state[:] = starts[b, k]
                action = agent_step(b, True, 0.0, 1.0, start_observations[b, k], learn,
                                    memory, hyper, spec)
                r = tape.slot[b, k]
                if r >= 0:
                    tape.states[r, 0] = state
                    tape.observations[r, 0] = start_observations[b, k]
                    tape.q_values[r, 0] = memory.q[b]
                n, total, up, terminal = 0, 0.0, 0.0, False
                while True:
                    if r >= 0:
                        tape.actions[r, n] = action
                    reward, terminal, is_up = transition(state, controls[action], next_state,
                                                         observation, dt, semi_implicit, slips,
                                                         params)
                    n += 1
                    total += reward
                    up += dt * is_up  # summed as the environments sum it
                    state[:] = next_state
                    action = agent_step(b, False, reward, 0.0 if terminal else 1.0, observation,
                                        learn, memory, hyper, spec)
                    if r >= 0:
                        tape.states[r, n] = state
                        tape.observations[r, n] = observation
                        tape.rewards[r, n - 1] = reward
                        tape.td_errors[r, n - 1] = memory.delta[b]
                        tape.q_values[r, n] = memory.q[b]
                    if terminal or n >= step_limit or memory.diverged[b]:
                        break
                if r >= 0:
                    tape.length[r] = n
                    tape.weights[r] = memory.weights[b]
                steps[b, k] = n
                returns[b, k] = total
                uptime[b, k] = up
                truncated[b, k] = not terminal and n >= step_limit
                done[b] = k + 1
                if memory.diverged[b]:
                    diverged_episode[b] = k

    return loop


def episode_starts(definition, seeds, episodes: int) -> np.ndarray:
    """`(B, K, d)`: the start of each agent's episodes, drawn as `BatchedEnv` and `tasks.load`
    draw them (one generator per seed, the episodes' starts in order)."""
    return np.stack([definition.initial_states(np.random.default_rng(seed), episodes)
                     for seed in seeds])


def run_compiled(domain: str, task: str, agent: BatchedSarsa, episodes: int, seeds,
                 learn: bool = True, integrator: str = "semi_implicit", equations: str = "paper",
                 progress=None, record=(), **options) -> EpisodeResults:
    """B agents on the analytic plant of `domain.task`, in one compiled loop; environment b
    is seeded with `seeds[b]` as in `BatchedEnv`. Episodes run in about 20 blocks, after each
    of which `progress(episodes_done)` is called. The `(agent, episode)` pairs in `record`
    are recorded step by step (`results.recordings`)."""
    episodes = check_count("episodes", episodes, 1)
    plant_options = ({"integrator": integrator, "equations": equations}
                     if tasks.DOMAINS[domain].PLANTS.euler else {})
    definition, _, _ = tasks.resolve(domain, task, "analytic", **options, **plant_options)
    semi_implicit, slips = check_integrator(integrator), check_equations(equations)
    seeds = list(seeds)
    if len(seeds) != agent.batch_size:
        raise ValueError(f"{len(seeds)} seeds for a batch of {agent.batch_size} agents")
    batch = agent.batch_size
    results = EpisodeResults.empty(batch, episodes)
    steps = np.zeros((batch, episodes), dtype=np.int64)
    starts = episode_starts(definition, seeds, episodes)
    step_limit = definition.step_limit if np.isfinite(definition.step_limit) else np.iinfo(np.int64).max
    loop = _compiled_loop(definition.transition)
    tape = make_tape(record, batch, episodes, definition.step_limit, starts.shape[2],
                     agent.num_actions, agent.features.num_features)
    done = np.zeros(batch, dtype=np.int64)  # episodes each agent has finished
    block = max(1, episodes // 20)
    try:
        for first in range(0, episodes, block):
            count = min(block, episodes - first)
            run_in_chunks(
                loop, batch, first, count, starts, definition.observe(starts),
                np.asarray(definition.controls, dtype=np.float64),
                tasks.DOMAINS[domain].PLANTS.timestep, semi_implicit, slips,
                np.asarray(definition.params, dtype=np.float64), int(step_limit), bool(learn),
                agent.memory, agent.hyper, agent.spec, steps, results.returns, results.uptime,
                results.truncated, results.diverged_episode, done, tape, min_chunk=1,
                chunks_per_worker=8)
            if progress is not None:
                progress(batch * count)
    except KeyboardInterrupt:
        results.interrupted = True
    ran = np.arange(episodes)[None, :] < done[:, None]
    results.steps = np.where(ran, steps, np.nan)
    results.returns[~ran] = np.nan
    results.uptime[~ran] = np.nan
    if not definition.has_uptime:
        results.uptime[:] = np.nan
    results.recordings = recordings(tape, definition, "analytic", seeds)
    return results


def make_agent(*configs) -> BatchedSarsa:
    """The agents of one or more `RunConfig`s, each configuration's `agents` in order, with
    zero weights. Configurations after the first differ from it at most in trace, alpha,
    lambda, epsilon and seeds (`sweep.batches` groups them so)."""
    base = configs[0]
    per_agent = [config for config in configs for _ in range(config.agents)]
    definition = tasks.definition(base.domain, base.task_name, **base.task_options)
    return BatchedSarsa(base.feature_map(), definition.num_actions,
                        alpha=[c.alpha for c in per_agent], lam=[c.lam for c in per_agent],
                        epsilon=[c.epsilon for c in per_agent],
                        trace=[c.trace for c in per_agent], gamma=base.gamma,
                        seeds=[seed for config in configs for seed in config.seeds])


def run(config, agent: BatchedSarsa | None = None, learn: bool = True,
        progress=None, record=(), seeds=None) -> tuple[BatchedSarsa, EpisodeResults]:
    """Run a `RunConfig`: the compiled loop on the analytic plant, the batched stepper on
    MuJoCo. Returns the agents (new ones unless given) and their results, with recordings of
    the `(agent, episode)` pairs in `record`. `seeds` (one per agent of a given `agent`)
    replaces the configuration's, for batches that join several configurations."""
    agent = make_agent(config) if agent is None else agent
    seeds = config.seeds if seeds is None else list(seeds)
    domain, task = config.domain, config.task_name
    if config.plant_name == "analytic":
        results = run_compiled(domain, task, agent, config.episodes, seeds, learn=learn,
                               progress=progress, record=record, **config.plant_options,
                               **config.task_options)
    else:
        env = BatchedEnv(domain, task, config.plant_name, seeds, **config.plant_options,
                         **config.task_options)
        results = run_batched(env, agent, config.episodes, learn=learn, progress=progress,
                              record=record)
    return agent, results
