"""The sensors and the actuator of a real plant: observation noise, a late actuator, and
action noise.

Options of an environment (`tasks.load`, `tasks.batched.BatchedEnv`, Gymnasium's `make`),
applied between the agent and the plant in the same way whatever the plant:

- `observation_noise={state variable: sigma}`: the agent observes `observe(state) + sigma
  z` with z ~ N(0, 1) drawn anew for each variable and step, sigma in the variable's units
  (safe-control-gym's observation `white_noise`). Reward, termination and up-time are the
  true state's: the sensor is noisy, the task is not.
- `action_delay=k` (control steps): the control applied at an episode's step n is the one
  the agent chose at step n - k; before the first command arrives (steps 0 to k - 1) the
  actuator applies 0 (no force, torque or thrust).
- `action_noise=sigma` (the control's units): the applied control is `u + sigma z`, clipped
  to the actuator's range [min, max of the task's controls] (`TaskDefinition.control_range`,
  which also clips a continuous action, `actions="continuous"`, before the delay and the
  noise: they act on the control of either kind alike). This is safe-control-gym's
  action disturbance (`white_noise` added to the physical action, then clipped to the
  physical action bounds: `CartPole._preprocess_control`), kept for discrete actions because
  a discrete agent still drives a physical actuator: its choice becomes a force, and the
  force is what a real motor gets wrong, within what it can deliver (the pendulum's torque
  limit is its task). A random action with probability p (the discrete reading, e.g. the
  Arcade Learning Environment's sticky actions, which repeat the last one) would be a fault
  of the channel rather than of the actuator, and would blur with the agents' own
  epsilon-greedy exploration. On a bang-bang action at the range's end the clip leaves only
  the weakening half of the noise.

Each environment draws from its own stream, keyed from its seed (`stream_key`), at counter
`(episode, step, slot)`: Squares, a counter-based generator (Widynski 2020, "Squares: A Fast
Counter-Based RNG", arXiv:2004.06278), and Box-Muller for the normal deviates. A draw
depends on nothing but the key and where it is used, not on the order in which
environments or steps run, so a batch, a single environment and a compiled loop give the
same numbers; the pieces are element-wise numba-jitable functions (`noisy_observation`,
`applied_control`) that a compiled loop calls per agent, and that the environments run
compiled too (`lwrl.kernels`): NumPy's own `log` differs from the C library's in the last
bit on some CPUs. With every option at its default nothing is drawn and nothing changes.
"""

import math
from typing import Mapping

import numpy as np
from numba.extending import register_jitable

from lwrl import kernels
from lwrl.tasks.parameters import per_environment

OPTIONS = ("observation_noise", "action_delay", "action_noise")
"""The sensor and actuator options of an environment."""
MAX_DELAY = 1000
"""The longest actuation delay, in control steps."""
STREAM = 0x6477  # a spawn key: the disturbances' streams apart from any other use of a seed
"""The spawn key of the sensors' and actuator's streams (`stream_key`)."""
_ROTATE = np.uint64(32)
_EPISODE_SHIFT, _STEP_SHIFT = np.uint64(40), np.uint64(8)
_MANTISSA_SHIFT = np.uint64(11)
_TO_UNIT = 2.0 ** -53
ACTION_SLOT = 254
"""Counter slots 2j and 2j + 1 draw variable j's observation noise; 254 and 255 the action's."""


@register_jitable
def squares64(counter, key):
    """Widynski's squares64 (five rounds): 64 random bits of `counter` under `key` (uint64)."""
    x = counter * key
    y = x
    z = y + key
    x = x * x + y
    x = (x >> _ROTATE) | (x << _ROTATE)
    x = x * x + z
    x = (x >> _ROTATE) | (x << _ROTATE)
    x = x * x + y
    x = (x >> _ROTATE) | (x << _ROTATE)
    t = x * x + z
    x = (t >> _ROTATE) | (t << _ROTATE)
    return t ^ ((x * x + y) >> _ROTATE)


@register_jitable
def normal(key, episode, step, slot):
    """A standard normal deviate at counter `(episode, step, slot)` of the stream `key`:
    Box-Muller, sqrt(-2 ln u1) cos(2 pi u2), from the uniforms of slots `slot`, `slot + 1`
    (u1 in (0, 1], u2 in [0, 1))."""
    counter = ((np.uint64(episode) << _EPISODE_SHIFT) | (np.uint64(step) << _STEP_SHIFT)
               | np.uint64(slot))
    u1 = ((squares64(counter, key) >> _MANTISSA_SHIFT) + np.uint64(1)) * _TO_UNIT
    u2 = (squares64(counter + np.uint64(1), key) >> _MANTISSA_SHIFT) * _TO_UNIT
    return np.sqrt(-2.0 * np.log(u1)) * np.cos(2.0 * np.pi * u2)


@register_jitable
def noisy_observation(observation, sigma, key, episode, step):
    """Add the observation noise of one environment's `step` to `observation` `(d,)` in
    place: sigma_j z_j where `sigma[j] > 0`."""
    for j in range(observation.shape[0]):
        if sigma[j] > 0.0:
            observation[j] += sigma[j] * normal(key, episode, step, 2 * j)


@register_jitable
def applied_control(buffer, step, control, sigma, low, high, key, episode):
    """The control the actuator applies at an episode's `step` when the agent commands
    `control`: the command of `k = len(buffer)` steps ago (0 before one arrives; `buffer`
    holds the commands in transit, zeros at the episode's start, updated in place), plus
    sigma z clipped to `[low, high]` where `sigma > 0`."""
    applied = control
    if buffer.shape[0] > 0:
        slot = step % buffer.shape[0]
        applied = buffer[slot]
        buffer[slot] = control
    if sigma > 0.0:
        applied = min(max(applied + sigma * normal(key, episode, step, ACTION_SLOT), low), high)
    return applied


def _observe_rows(observations, rows, sigma, keys, episodes, steps):
    """`noisy_observation` for the environments `rows`, `observations[i]` that of `rows[i]`."""
    for i in range(rows.shape[0]):
        b = rows[i]
        noisy_observation(observations[i], sigma[b], keys[b], episodes[b], steps[i])


def _actuate_rows(controls, rows, buffers, delays, sigma, low, high, keys, episodes, steps):
    """`applied_control` for the environments `rows`, in place of their commands `controls`."""
    for i in range(rows.shape[0]):
        b = rows[i]
        controls[i] = applied_control(buffers[b, :delays[b]], steps[i], controls[i], sigma[b],
                                      low[b], high[b], keys[b], episodes[b])


OBSERVE_ROWS = kernels.kernel("disturb_observations", _observe_rows)
"""`_observe_rows` compiled: the sensors' noise on some environments' observations."""
ACTUATE_ROWS = kernels.kernel("disturb_controls", _actuate_rows)
"""`_actuate_rows` compiled: the actuator's delay and noise on some environments' commands."""


def stream_key(seed) -> np.uint64:
    """A Squares key for the environment seeded with `seed` (a non-negative integer, a NumPy
    Generator, which is not advanced, or None for fresh entropy): 16 non-zero hex digits,
    the upper 8 distinct and the lower 8 distinct with the lowest odd (Widynski's rule for
    keys), drawn from the seed's own stream (`STREAM`)."""
    if isinstance(seed, np.random.Generator):
        seed = int(seed.spawn(1)[0].integers(2 ** 63))
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(STREAM,)))
    digits = np.arange(1, 16)
    upper = rng.permutation(digits)[:8]
    last = rng.choice(digits[digits % 2 == 1])
    lower = np.append(rng.permutation(digits[digits != last])[:7], last)
    key = 0
    for digit in np.concatenate([upper, lower]):
        key = key << 4 | int(digit)
    return np.uint64(key)


class Disturbances:
    """The sensor and actuator options of B environments, and their streams and commands in
    transit. `active` is False where every option is at its default: then nothing is drawn
    and nothing is changed.

    `sigma_observation` `(B, d)`, `delay` `(B,)` and `sigma_action` `(B,)` hold the options
    per environment; `low`, `high` `(B,)` each actuator's range; `buffers` `(B, max delay)`
    the commands in transit (each row's first `delay[b]`), which a compiled loop works in too.
    """

    def __init__(self, state_names: tuple, controls: np.ndarray, batch_size=None,
                 observation_noise=None, action_delay=0, action_noise=0.0):
        """`controls` `(B, A)`: each environment's controls, or its actuator's range `[low,
        high]` (`TaskDefinition.control_range_at`), which is their least and greatest, for
        continuous actions too; with `batch_size` None one
        environment, whose options are numbers, else each option is one value for every
        environment or a sequence of B. A one-line ValueError on a bad option."""
        count = 1 if batch_size is None else batch_size
        self.sigma_observation = np.zeros((count, len(state_names)))
        """`(B, d)` the observation noise's standard deviation per state variable."""
        if observation_noise is not None:
            if not isinstance(observation_noise, Mapping):
                raise ValueError(f"observation_noise must map state variables ({', '.join(state_names)}) "
                                 f"to standard deviations; got {observation_noise!r}")
            for name, sigma in observation_noise.items():
                if name not in state_names:
                    raise ValueError(f"unknown state variable {name!r} for observation_noise; "
                                     f"allowed: {', '.join(state_names)}")
                self.sigma_observation[:, state_names.index(name)] = per_environment(
                    f"observation_noise[{name!r}]", sigma, 0.0, math.inf, "(its units)", batch_size)
        self.delay = np.broadcast_to(per_environment(
            "action_delay", action_delay, 0, MAX_DELAY, "control steps", batch_size,
            integer=True), (count,)).astype(np.int64)
        """`(B,)` the actuation delay, in control steps."""
        self.sigma_action = np.broadcast_to(per_environment(
            "action_noise", action_noise, 0.0, math.inf, "(the control's units)", batch_size),
            (count,)).astype(np.float64)
        """`(B,)` the action noise's standard deviation, in the control's units."""
        controls = np.broadcast_to(np.asarray(controls, dtype=np.float64), (count, np.shape(controls)[-1]))
        self.low, self.high = controls.min(axis=1), controls.max(axis=1)
        self.keys = np.zeros(count, dtype=np.uint64)
        """`(B,)` each environment's stream key (`seed`)."""
        self.episodes = np.full(count, -1, dtype=np.int64)
        """`(B,)` each environment's current episode's index (-1 before the first)."""
        self.buffers = np.zeros((count, int(self.delay.max(initial=0))))
        """`(B, max delay)` the commands in transit (row b's first `delay[b]`)."""
        self.active = bool(np.any(self.sigma_observation > 0) or np.any(self.delay > 0)
                           or np.any(self.sigma_action > 0))
        """False where every option is at its default: nothing is drawn or changed."""

    def seed(self, seeds) -> None:
        """Key each environment's stream from its seed (`stream_key`); episodes count anew."""
        if self.active:
            self.keys[:] = [stream_key(seed) for seed in seeds]
            self.episodes[:] = -1

    def start(self, which: np.ndarray) -> None:
        """A new episode in the environments `which` (a mask or indices): nothing in transit."""
        if self.active:
            self.episodes[which] += 1
            self.buffers[which] = 0.0

    def observe(self, observations: np.ndarray, rows: np.ndarray, steps: np.ndarray) -> np.ndarray:
        """`observations` `(n, d)` of the environments `rows` at their episodes' `steps`, with
        their sensors' noise (a new array; the same where there is none)."""
        observations = np.array(observations, dtype=np.float64)
        if np.any(self.sigma_observation > 0):
            OBSERVE_ROWS(observations, np.asarray(rows, dtype=np.int64), self.sigma_observation,
                         self.keys, self.episodes, np.asarray(steps, dtype=np.int64))
        return observations

    def actuate(self, controls: np.ndarray, rows: np.ndarray, steps: np.ndarray) -> np.ndarray:
        """The controls the actuators of the environments `rows` apply at their episodes'
        `steps` when commanded `controls` `(n,)` (the commands themselves where inactive)."""
        controls = np.array(controls, dtype=np.float64)
        if self.active:
            ACTUATE_ROWS(controls, np.asarray(rows, dtype=np.int64), self.buffers, self.delay,
                         self.sigma_action, self.low, self.high, self.keys, self.episodes,
                         np.asarray(steps, dtype=np.int64))
        return controls
