"""The agent-environment loop one array step at a time: B agents on B environments of any
plant (`tasks.batched.BatchedEnv`), or on dm_env environments of any kind
(`tasks.batched.SteppedEnvs`). `runners.compiled` runs the same loop compiled, with the
same bookkeeping (`runners.episodes.finish_episode`, `runners.recording`) and numbers."""

import numpy as np

from lwrl.agent.learner_contract import Agents
from lwrl.runners.episodes import EpisodeResults, finish_episode, step_budget
from lwrl.runners.recording import (make_tape, record_end, record_state, record_transition,
                                    recorded_values, recordings)
from lwrl.settings import check_count
from lwrl.tasks.commands import check_kinds, commands
from lwrl.tasks.batched import BatchedEnv, SteppedEnvs


def kind_of(agents) -> tuple[str, str]:
    """`(name, actions)` of an `Agents`, or of another object with its stepped interface
    (`step`, `diverged`, `batch_size`, `continuous`: `studies.robustness.controller`)."""
    learner = getattr(agents, "learner", None)
    name = type(agents).__name__ if learner is None else learner.name
    return name, "continuous" if agents.continuous else "discrete"


def run_dm_env(env, agents: Agents, episodes: int, learn: bool = True,
               greedy: bool = False) -> EpisodeResults:
    """One agent (`agents.batch_size == 1`) on one dm_env environment of the suite (`tasks.load`),
    step by step: `run_batched` on the environment alone."""
    if agents.batch_size != 1:
        raise ValueError(f"run_dm_env runs one agent; got a batch of {agents.batch_size}")
    if hasattr(env.task, "definition"):  # the suite's
        check_kinds(*kind_of(agents), env.task.definition, "run_dm_env")
    return run_batched(SteppedEnvs([env], uptime=lambda single: single.task.uptime), agents,
                       episodes, learn=learn, greedy=greedy)


class CutShort(Exception):
    """What an agent or an environment raises when it can go no further (the device behind a
    link gone silent, `export.link.LinkLost`): `run_batched` stops there as at Ctrl-C, the
    finished episodes kept, the one under way left out, the results marked interrupted."""


def run_batched(env: BatchedEnv, agents: Agents, episodes: int, learn: bool = True,
                progress=None, record=(), greedy: bool = False, budget=None) -> EpisodeResults:
    """B agents of any learner on a batched environment of B copies (a `BatchedEnv`, or
    `SteppedEnvs` of B dm_env environments); `learn` and `greedy` as for `Agents.step`;
    `progress(done_episodes)` is called as episodes finish; `budget`: environment steps per
    agent at most (None: no budget), the episode that spends them cut there, truncated, as
    `run_compiled` cuts it. The
    `(agent, episode)` pairs in `record` are recorded step by step (`results.recordings`), as
    `run_compiled` records them; recording needs a `BatchedEnv`. Ctrl-C, or a `CutShort`
    from the agent or the environment, stops it with the finished episodes kept, the
    results marked `interrupted`."""
    episodes = check_count("episodes", episodes, 1)
    if isinstance(env, BatchedEnv):
        check_kinds(*kind_of(agents), env.definition, "run_batched")
    if env.batch_size != agents.batch_size:
        raise ValueError(f"environment batch {env.batch_size} and agent batch "
                         f"{agents.batch_size} differ")
    batch = env.batch_size
    results = EpisodeResults.empty(batch, episodes)
    done = np.zeros(batch, dtype=np.int64)  # finished episodes per agent
    running = np.ones(batch, dtype=bool)
    budget = step_budget(budget)
    spent = np.zeros(batch, dtype=np.int64)  # transitions each agent has taken
    returns = np.zeros(batch)
    recording = bool(len(record))  # else the step loop skips the tape entirely
    if recording:
        definition = env.definition
        values = recorded_values(agents)
        tape = make_tape(record, batch, episodes, definition.step_limit,
                         len(definition.state_names), values.shape[1],
                         agents.arrays.weights.shape[1:], agents.continuous)
    actions = np.zeros(batch, dtype=np.float64 if agents.continuous else np.int64)
    ts = env.reset()
    try:
        while True:
            previous = actions
            actions = agents.step(ts.first(), ts.reward, ts.discount, ts.observation,
                                 active=running, learn=learn, greedy=greedy)
            rows = np.full(batch, -1)
            if recording:
                rows = np.where(running, tape.slot[np.arange(batch), np.minimum(done, episodes - 1)], -1)
                for b in np.flatnonzero(rows >= 0):
                    n = env.steps[b]
                    record_state(tape, rows[b], n, env.state[b], ts.observation[b], values[b])
                    if n > 0:
                        record_transition(tape, rows[b], n, previous[b], ts.reward[b],
                                          agents.arrays.delta[b])
            newly_diverged = running & agents.diverged
            cut = running & (spent >= budget) & ~ts.first()
            ended = running & (ts.last() | newly_diverged | cut)
            for b in np.flatnonzero(ended):
                finish_episode(b, done[b], env.steps[b], returns[b], env.uptime[b],
                               (ts.last()[b] and ts.discount[b] == 1.0) or
                               (cut[b] and not ts.last()[b]), newly_diverged[b],
                               results.steps, results.returns, results.uptime, results.truncated,
                               results.diverged_episode, done)
                if rows[b] >= 0:
                    record_end(tape, rows[b], env.steps[b], agents.arrays.weights[b])
            running &= (done < episodes) & ~agents.diverged & (spent < budget)
            if progress is not None and ended.any():
                progress(int(ended.sum()))
            if not running.any():
                break
            ts = env.step(commands(env.control_range, actions) if agents.continuous else actions)
            spent += running & ~ts.first()
            returns = np.where(ts.first(), 0.0, returns + ts.reward)
    except (KeyboardInterrupt, CutShort):
        results.interrupted = True
    if recording:
        results.recordings = recordings(tape, definition, env.plant_name, env.seeds)
    return results
