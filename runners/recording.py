"""Whole episodes recorded step by step, for viewing (Rerun) and comparison.

A recording holds the arrays of one agent's episode: the plant's states (angles not
wrapped), the observations the agent saw, its actions and the controls they applied, the
rewards, the TD errors of its updates and its Q-values at each observed state, and its
weights at the end of the episode (for the value function).
"""

import collections
import dataclasses

import numpy as np
from numba.extending import register_jitable

from lwrl.agent.learner_contract import NoValues
from lwrl.kernels import copy_into


@dataclasses.dataclass
class EpisodeRecording:
    """One episode of one agent; T is the number of steps."""

    task: str
    """DOMAIN.TASK."""
    plant: str
    """`analytic` or `mujoco`."""
    agent: int
    """Index of the agent in its batch."""
    seed: int
    """The agent's seed."""
    episode: int
    """Episode index, from 0."""
    timestep: float
    """Seconds (Mountain-Car: steps) per agent step."""
    state_names: tuple
    """Names of the state variables (the columns of `states` and `observations`)."""
    controls: tuple
    """Force, torque or thrust of each action; with continuous actions the actuator's range
    `(low, high)`."""
    states: np.ndarray
    """`(T + 1, d)` plant states, the start first (angles not wrapped)."""
    observations: np.ndarray
    """`(T + 1, d)` what the agent saw (the pendulum's angle wrapped)."""
    actions: np.ndarray
    """`(T,)` action indices, or continuous actions in [-1, 1] (`tasks.commands`); action
    t moves `states[t]` to `states[t + 1]`."""
    rewards: np.ndarray
    """`(T,)` reward on entering `states[t + 1]`."""
    td_errors: np.ndarray
    """`(T,)` the TD error delta of the update made after step t (NaN when not learning)."""
    q_values: np.ndarray
    """`(T + 1, A)` Q(s_t, .) before the update at each observed state (the learner's
    action values, or the preferences it acts greedily on); `(T + 1, 0)` for a learner
    without action values (`recorded_values`)."""
    uptime: np.ndarray
    """`(T,)` seconds up so far after each step (NaN where the task has none)."""
    weights: np.ndarray
    """What the agent had learned at the end of the episode: its learner's
    `arrays.weights[b]` (e.g. Sarsa's `(A, N)`), which the learner's values read."""

    @property
    def steps(self) -> int:
        """T, the episode's steps: the actions taken."""
        return len(self.actions)

    @property
    def continuous(self) -> bool:
        """True where the actions are continuous, numbers in [-1, 1] (`controls` the
        actuator's range)."""
        return np.asarray(self.actions).dtype.kind == "f"

    @property
    def returns(self) -> np.ndarray:
        """`(T,)` the return so far after each step."""
        return np.cumsum(self.rewards)

    @property
    def times(self) -> np.ndarray:
        """`(T + 1,)` simulated time of each state."""
        return np.arange(self.steps + 1) * self.timestep


Tape = collections.namedtuple(
    "Tape", "slot states observations actions rewards td_errors q_values length weights")
"""Buffers the learning loops fill for the recorded episodes: `slot[b, k]` is the buffer
row of agent b's episode k (-1: not recorded); rows hold up to `L` steps."""


def recorded_values(agents) -> np.ndarray:
    """`(B, A)` the action values a recording keeps at each state: the agents'
    `latest_values` (read after each step, as the learner updates them in place), or `(B, 0)`
    for a learner that keeps none, whose recordings then hold no Q (`q_values` `(T + 1, 0)`)."""
    try:
        return agents.latest_values()
    except NoValues:
        return np.zeros((agents.batch_size, 0))


def make_tape(record, agents: int, episodes: int, step_limit, dim: int, num_values: int,
              weights_shape: tuple, continuous: bool = False) -> Tape:
    """Empty buffers for the `(agent, episode)` pairs in `record` (a tiny dummy if none);
    `num_values`: the action values recorded per state (`recorded_values`, 0 for none);
    `weights_shape`: one agent's `arrays.weights`; `continuous`: the actions are numbers
    (`Learner.actions`), not indices."""
    record = sorted(set(record))
    slot = np.full((agents, episodes), -1, dtype=np.int64)
    for row, (agent, episode) in enumerate(record):
        if not (0 <= agent < agents and 0 <= episode < episodes):
            raise ValueError(f"cannot record episode {episode} of agent {agent}: the run has "
                             f"{agents} agents and {episodes} episodes")
        slot[agent, episode] = row
    if record and not np.isfinite(step_limit):
        raise ValueError("recording episodes needs a finite time limit")
    rows, length = max(1, len(record)), int(step_limit) if record else 1
    return Tape(slot, np.zeros((rows, length + 1, dim)), np.zeros((rows, length + 1, dim)),
                np.zeros((rows, length), dtype=np.float64 if continuous else np.int64),
                np.zeros((rows, length)),
                np.zeros((rows, length)), np.zeros((rows, length + 1, num_values)),
                np.zeros(rows, dtype=np.int64), np.zeros((rows,) + tuple(weights_shape)))


@register_jitable
def record_state(tape, r, n, state, observation, q):
    """Step n of the episode in tape row r: the plant's state, what the agent saw and its Q
    there (before its update)."""
    copy_into(tape.states[r, n], state)
    copy_into(tape.observations[r, n], observation)
    copy_into(tape.q_values[r, n], q)


@register_jitable
def record_transition(tape, r, n, action, reward, delta):
    """The transition into step n >= 1: the action taken at step n - 1, the reward on entering
    step n and the TD error of the update it led to."""
    tape.actions[r, n - 1] = action
    tape.rewards[r, n - 1] = reward
    tape.td_errors[r, n - 1] = delta


@register_jitable
def record_end(tape, r, steps, weights):
    """The episode in tape row r ended after `steps` steps with the agent's `weights`
    (an episode cut short by an interrupt is never ended, and left out)."""
    tape.length[r] = steps
    for row in range(weights.shape[0]):
        copy_into(tape.weights[r, row], weights[row])


def recordings(tape: Tape, definition, plant: str, seeds) -> list:
    """The ended rows of `tape` as `EpisodeRecording`s, in (agent, episode) order (episodes
    an interrupted or diverged run did not reach or finish are left out)."""
    found = []
    for agent, episode in zip(*np.nonzero(tape.slot >= 0)):
        row = tape.slot[agent, episode]
        steps = tape.length[row]
        if steps == 0:
            continue
        states = tape.states[row, :steps + 1].copy()
        found.append(EpisodeRecording(
            task=definition.name, plant=plant, agent=int(agent), seed=int(seeds[agent]),
            episode=int(episode), timestep=definition.control_timestep,
            state_names=definition.state_names,
            controls=definition.control_range if definition.continuous else definition.controls,
            states=states,
            observations=tape.observations[row, :steps + 1].copy(),
            actions=tape.actions[row, :steps].copy(), rewards=tape.rewards[row, :steps].copy(),
            td_errors=tape.td_errors[row, :steps].copy(),
            q_values=tape.q_values[row, :steps + 1].copy(),
            uptime=np.cumsum(definition.uptime_increment(states[1:])),
            weights=tape.weights[row].copy()))
    return found
