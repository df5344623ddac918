"""lwrl's learner against the same algorithm written as JAX code (the PureJaxRL style).

The peer (written here, not project code) is lwrl's Sarsa(lambda) with NRBF features as a
JAX program: one agent's step is a pure function, `jax.vmap` maps it over agents (each with
its own PRNG key and hyper-parameters) and `jax.lax.scan` runs it over a fixed number of
steps, all under one `jax.jit`, in float64 (`jax_enable_x64`). It follows lwrl's
definitions, not its code:

- features: NRBF eq. 8 and 9 factorised per dimension as `agent/nrbf.py` computes them
  (each dimension's Gaussians normalised, then their outer product in C order, the last
  state variable fastest), with its underflow guard (the smallest squared distance
  subtracted in the exponent, the normalised state clamped to [-400 n r^2, 1 + 400 n r^2]);
- Q(s, a) = w_a . phibar(s) with weights zero at the start; epsilon-greedy with ties broken
  uniformly at random; delta = r + gamma d Q(s', a') - Q(s, a), with d = 0 at a terminal
  state (no action drawn there) and every term from the weights before the update;
- traces as `agent/traces.py`: replacing (eq. 6) or accumulating (eq. 2), decayed by
  gamma lambda, values below 1e-100 flushed to 0, reset to 0 at each episode's start; a
  delta that is not finite marks the agent diverged and freezes its weights;
- the tasks: `tasks/mountain_car.py`'s difference equation and `tasks/cartpole.py`'s
  equations with semi-implicit Euler (MuJoCo's; lwrl's default), their rewards, terminal
  states and starts, the time limit as a truncation (the agent bootstraps from the last
  state), and auto-reset inside the scan: the step that ends an episode also starts the
  next one, so every scanned step of every agent is one real plant transition.

Its design, for speed (`learner_step`, `make_block`):

- the features are kept as their per-dimension factors `(d, n)`: Q is contracted factor by
  factor (`action_values`, W viewed as `(A, N / n, n)` times the last factor, and so on),
  and the full feature vector is formed only inside the fused trace-and-weight update;
- the exploration noise is drawn once per block of steps: each agent's key is split once
  per block and the block's uniforms drawn in one vectorised call;
- the auto-reset after a terminal state is branch-free: a start state is drawn every step,
  and the state observed next is the start where the step was terminal, else s' (Q at a
  terminal state is never needed: its bootstrap is 0), so one set of features and one Q
  serve both cases; only the rare steps where some agent's episode is truncated (it needs
  both s' and a start) run a batch-level `lax.cond` (`restart`);
- Q(s', a') under the updated weights is carried to the next step, where it is Q(s, a) of
  the TD error: each step evaluates Q twice (before the update at s' for the choice and the
  bootstrap, after it for the carried value and, after a terminal state, the next episode's
  first action, chosen from the updated weights as lwrl's learner does).

The peer draws its random numbers from JAX's PRNG, so its numbers differ from lwrl's; it
must learn the same, which `learning_check` measures on the paper's Mountain-Car protocol.
`tests/test_jax_peer.py` also checks its features and plant steps against lwrl's, and its
learner step on a fixed trajectory with fixed actions: features, Q, TD errors and weights
after every transition equal lwrl's learner's to round-off (measured: within 3e-15 of the
largest weight on both tasks, the test allows 1e-12; the factor-by-factor Q adds in
another order than lwrl's dot products).

One run of this script measures, on Mountain-Car and Cart-Pole with the paper's agent of
each task (`TaskDefinition.defaults`), for 1, 30 and 300 agents:

1. **lwrl**: `runners.compiled.run_compiled`, as `benchmarks.agent_speed` measures it
   (episodes grown until a run lasts about `--seconds`; the default thread pool);
2. **JAX peer**: blocks of `BLOCK` scanned steps from zero weights, called until
   `--seconds` have passed (XLA decides how many threads it uses);

and prints agent-steps per second of each (wall time), the ratio lwrl / JAX, the CPU time
per agent-step of each (all threads) and their ratio, and each one's compile time, which no
rate includes
(lwrl's kernels are compiled in a fresh cache directory unless `--cached`, so that the time
is a compile and not a load from `~/.cache/lwrl`). An agent-step is one plant transition:
for the peer, the scanned steps of all agents. Ratios compare rates measured in the same run.
On a machine that other jobs keep busy the wall-time ratio understates lwrl, whose threads
find no free core, and the CPU-time ratio is the fairer one.

Where the peer's time goes (XLA's optimised HLO, `jax.jit(...).lower(...).compile()
.as_text()`): XLA runs the scan on about one core (its CPU time per agent-step is about its
wall time on an idle machine), where lwrl spreads a batch over the cores; each scanned step
runs some 40 kernels (41 at 30 cart-pole agents), a fixed cost of a few microseconds that
one agent pays alone; and the
vmapped design updates every agent's weights and traces at every step, streaming them all
through memory (41 KB per cart-pole agent, 12 MB for 300), where lwrl runs each agent's
episodes one after another with its arrays in cache.

Tried (CPU ns per agent-step, the fastest of 5 blocks, every variant in one process, the
machine loaded, load average 9 on 2 cores; 1 / 30 / 300 agents):

| Q(s, .) as | cart-pole | Mountain-Car |
|---|---:|---:|
| `(A, N/n, n) @ g_j`, factor by factor (kept) | 14.1k / 21.9k / 21.6k | 3.9k / 1.05k / 1.73k |
| `(A, n, N/n)` times g_j summed over the middle axis | 13.4k / 22.1k / 28.7k | 3.9k / 1.41k / 2.80k |
| `(A, N/n, n)` times g_j summed over the last axis | 13.2k / 28.5k / 33.3k | 3.6k / 1.47k / 2.67k |
| `weights @ phi`, phi formed | 16.3k / 21.7k / 28.2k | 3.6k / 0.95k / 1.69k |
| `(weights * phi).sum(1)`, phi formed | 31.5k / 37.7k / 33.6k | 4.5k / 1.29k / 2.26k |

Against the design before this one (phi formed for every state, Q(s, .) recomputed at
every step for the TD error, the resets under a `lax.cond` on any episode's end), measured
in one process on the loaded machine with the middle-axis contraction: cart-pole 1 agent
14.5k against 28.5k ns of CPU per agent-step, Mountain-Car 30 and 300 agents 1.5k and 2.2k
against 1.6k and 2.8k; cart-pole 30 and 300 agents 34.5k and 31.1k against 30.8k and 30.7k,
within the noise. With the middle-axis sums XLA wrote the broadcast factor of the first
contraction out as a full-size array; with the kept `@` it does not, and a step's full-size
passes are the weights' update, the traces' update with their reset (each forming the
features again) and a copy of the traces around the `lax.cond` (the optimised HLO at 30
cart-pole agents). Also tried, no difference beyond the noise (kept: neither): the scan unrolled 2 or 4
steps (Mountain-Car 1 agent 5.6k / 4.6k / 5.1k ns, cart-pole 1 agent 15.6k / 15.7k /
21.8k), and XLA's own emitters in place of its YNNPACK fusions
(`--xla_cpu_experimental_ynn_fusion_type=`).

Run from the repository root (needs the `jax` extra, `pip install -e .[jax]`; CPU only):

    python -m benchmarks.jax_peer              # about 3 s per measurement, a few minutes
    python -m benchmarks.jax_peer --quick      # smoke test
"""

import argparse
import contextlib
import dataclasses
import functools
import math
import os
import shutil
import tempfile
import time
import typing
from typing import Callable

import jax
import jax.numpy as jnp
import numba
import numpy as np

from benchmarks.agent_speed import machine, plural
from lwrl import tasks
from lwrl.agent.threads import workers
from lwrl.agent.traces import FLUSH_THRESHOLD
from lwrl import agent as learners
from lwrl.runners.compiled import compiled_loop
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agent, run, run_compiled
from lwrl.tasks import cartpole, mountain_car

jax.config.update("jax_enable_x64", True)

AGENTS = (1, 30, 300)
"""The batch sizes measured."""
BLOCK = 1000
"""Scanned steps per jitted call of the peer."""
QUICK_SECONDS = 0.1
"""Time budget per measurement with `--quick`."""
QUICK_AGENTS = (3,)
"""The batch sizes measured with `--quick`."""
CHECK_AGENTS, CHECK_EPISODES = 30, 40
"""The learning check: the paper's best Mountain-Car agent, 30 agents x 40 episodes."""


# --- The tasks, in JAX -----------------------------------------------------------------------

def mountain_car_step(state, thrust):
    """`tasks.mountain_car.step` on one state `(2,)` at the paper's values."""
    position, velocity = state[0], state[1]
    velocity = jnp.clip(velocity + mountain_car.NOMINAL.thrust * thrust
                        - mountain_car.NOMINAL.gravity * jnp.cos(3.0 * position),
                        -mountain_car.MAX_SPEED, mountain_car.MAX_SPEED)
    unclipped = position + velocity
    position = jnp.maximum(unclipped, mountain_car.MIN_POSITION)
    velocity = jnp.where(unclipped >= mountain_car.MIN_POSITION, velocity, 0.0)
    return jnp.stack([position, velocity])


def mountain_car_outcome(state):
    """(reward, terminal): -1 a step, 0 on reaching the goal, which is terminal."""
    terminal = state[0] > mountain_car.GOAL_POSITION
    return jnp.where(terminal, 0.0, -1.0), terminal


def mountain_car_start(uniforms):
    """x ~ U[-1.2, 0.5], v ~ U[-0.07, 0.07] from two uniforms in [0, 1)."""
    low = jnp.array([mountain_car.MIN_POSITION, -mountain_car.MAX_SPEED])
    high = jnp.array([mountain_car.GOAL_POSITION, mountain_car.MAX_SPEED])
    return low + (high - low) * uniforms


def cartpole_step(state, force):
    """`tasks.cartpole.step` on one state `(4,)` with semi-implicit Euler, the paper's
    equations (no slips) at the paper's values (`cartpole.NOMINAL`)."""
    paper = cartpole.NOMINAL
    total_mass, pole_mass_length = paper.cart_mass + paper.pole_mass, paper.pole_mass * paper.half_length
    x, x_dot, theta, theta_dot = state[0], state[1], state[2], state[3]
    sin_theta, cos_theta = jnp.sin(theta), jnp.cos(theta)
    friction = paper.cart_friction * jnp.sign(x_dot)
    spin = pole_mass_length * theta_dot * theta_dot * sin_theta
    theta_acc = (
        paper.gravity * sin_theta
        + cos_theta * (-force - spin + friction) / total_mass
        - paper.pole_friction * theta_dot / pole_mass_length
    ) / (paper.half_length * (4.0 / 3.0 - paper.pole_mass * cos_theta * cos_theta / total_mass))
    x_acc = (force + spin - pole_mass_length * theta_acc * cos_theta - friction) / total_mass
    dt = cartpole.TIMESTEP
    x_dot = x_dot + dt * x_acc
    theta_dot = theta_dot + dt * theta_acc
    return jnp.stack([x + dt * x_dot, x_dot, theta + dt * theta_dot, theta_dot])


def cartpole_outcome(state):
    """(reward, terminal): failing (|theta| > 12 deg or |x| > 2.4 m) is terminal, reward -1."""
    fail = (jnp.abs(state[2]) > cartpole.FAIL_ANGLE) | (jnp.abs(state[0]) > cartpole.TRACK_LIMIT)
    return jnp.where(fail, -1.0, 0.0), fail


def cartpole_start(uniforms):
    """All zeros (the paper's start is deterministic)."""
    return jnp.zeros(4) * uniforms


@dataclasses.dataclass(frozen=True)
class PeerTask:
    """A task as the peer runs it, and the paper's agent for it (`RunConfig` defaults)."""

    name: str
    step: Callable
    outcome: Callable
    start: Callable
    controls: tuple
    step_limit: int
    dim: int


TASKS = {
    "mountain_car.cost_to_go": PeerTask(
        "mountain_car.cost_to_go", mountain_car_step, mountain_car_outcome, mountain_car_start,
        mountain_car.THRUSTS, mountain_car.STEP_LIMIT, 2),
    "cartpole.balance": PeerTask(
        "cartpole.balance", cartpole_step, cartpole_outcome, cartpole_start, cartpole.FORCES,
        round(cartpole.TIME_LIMIT / cartpole.TIMESTEP), 4),
}
"""The benchmarked tasks in JAX."""


# --- The agent, in JAX -----------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class Agent:
    """What compiled code fixes about the agents: the NRBF grid and the trace rule."""

    low: tuple
    high: tuple
    n: int
    r2: float
    accumulating: bool
    num_actions: int


def factors(agent: Agent, state):
    """The NRBF features (eq. 8, 9) of one state as their per-dimension factors `(d, n)`,
    `g_j / sum_k g_j[k]`, guarded as `agent/nrbf.py` (the features are their outer product,
    `outer`)."""
    n = agent.n
    low, high = jnp.array(agent.low), jnp.array(agent.high)
    centroids = (jnp.arange(n) + 0.5) / n
    margin = 400.0 * n * agent.r2
    s = jnp.clip((state - low) / (high - low), -margin, 1.0 + margin)
    distance = jnp.abs(s[:, None] - centroids[None, :])  # (d, n)
    nearest = distance.min(axis=1, keepdims=True)
    g = jnp.exp(-(distance - nearest) * (distance + nearest) / agent.r2)
    return g / g.sum(axis=1, keepdims=True)


def outer(g):
    """The feature vector `(n^d,)` of factors `(d, n)`, as `nrbf_features_into` forms it:
    the last dimension's factors first, each earlier dimension's factor times the product of
    the later ones, over a `(n,) * d` array whose C order is the neurons' order."""
    d, n = g.shape
    phi = g[d - 1]
    for j in range(d - 2, -1, -1):
        phi = g[j].reshape((n,) + (1,) * (d - 1 - j)) * phi
    return phi.reshape(-1)


def features(agent: Agent, state):
    """NRBF features (eq. 8, 9) of one state `(n^d,)`, factorised and guarded as
    `agent/nrbf.py`."""
    return outer(factors(agent, state))


def action_values(weights, g):
    """Q(s, .) = w phibar(s) (eq. 9) for weights `(A, N)` and the factors `g` `(d, n)` of
    phibar(s), contracted factor by factor without forming phibar: W viewed as
    `(A, N / n, n)` times g_{d-1} (a matrix-vector product), the result `(A, N / n)` viewed
    as `(A, N / n^2, n)` times g_{d-2}, and so on to `(A,)`: A N (1 + 1/n + ...)
    multiply-adds."""
    num_actions = weights.shape[0]
    d, n = g.shape
    q = weights
    for j in range(d - 1, -1, -1):
        q = q.reshape(num_actions, -1, n) @ g[j]
    return q.reshape(num_actions)


def epsilon_greedy(q, epsilon, uniforms):
    """An action for Q `(A,)` from three uniforms: the exploration test, the random action,
    the tie-break among the greedy actions (NaN in Q: action 0, as lwrl)."""
    num_actions = q.shape[0]
    random_action = jnp.minimum((uniforms[1] * num_actions).astype(jnp.int32), num_actions - 1)
    ties = q == q.max()
    count = ties.sum()
    pick = jnp.minimum((uniforms[2] * count).astype(jnp.int32), count - 1)
    greedy = jnp.argmax(ties & (jnp.cumsum(ties) == pick + 1))
    return jnp.where(uniforms[0] < epsilon, random_action, greedy).astype(jnp.int32)


UNIFORMS_PER_STEP = 6
"""Uniforms an agent-step draws for its actions (3 for the next state's or, at a terminal
state, the next episode's first; 3 for the next episode's first after a truncation), plus
the task's dimension for the next episode's start."""


class Carry(typing.NamedTuple):
    """One agent between two plant transitions (each field gains a leading axis B under
    `vmap`): its weights and traces `(A, N)`, the state and its features' factors `(d, n)`,
    the action taken there and its value Q(s, a) under the current weights, the steps of the
    episode so far and whether the agent diverged."""

    weights: jax.Array
    traces: jax.Array
    state: jax.Array
    g: jax.Array
    action: jax.Array
    q_taken: jax.Array
    steps: jax.Array
    diverged: jax.Array


def update(agent: Agent, weights, traces, g, action, gamma_lambda, step):
    """The trace rule (eq. 6 or 2, from `gamma_lambda` times the traces, `agent/traces.py`'s
    flush below 1e-100) and `w <- w + step e` (eq. 1) for the features of factors `g` in the
    taken action's row, in one elementwise pass that XLA fuses: the feature vector is formed
    only here. Returns `(weights, traces)`."""
    taken = (jnp.arange(agent.num_actions) == action)[:, None]
    decayed = gamma_lambda * traces
    gradient = jnp.where(taken, outer(g)[None, :], 0.0)
    updated = decayed + gradient if agent.accumulating else jnp.maximum(decayed, gradient)
    updated = jnp.where(jnp.abs(updated) >= FLUSH_THRESHOLD, updated, 0.0)
    return weights + step * updated, updated


def learner_step(agent: Agent, carry: Carry, hyper, next_state, reward, terminal, truncated,
                 start, choose) -> tuple[Carry, dict]:
    """One agent's Sarsa(lambda) update for the transition from `carry`'s (s, a) to
    `next_state` (s'), branch-free: where s' is `terminal` the next episode begins at
    `start` in the same pass. `choose(q)` is the policy (the benchmark: epsilon-greedy on
    the step's uniforms). Returns the carry at the next observed state (s', or `start`
    after a terminal; `restart` moves it to a start after a truncation, where the traces are
    reset here) and what lwrl's learner exposes after the same transition (`diagnostics`)."""
    alpha, gamma, lam, _ = hyper
    observed = jnp.where(terminal, start, next_state)
    g = factors(agent, observed)
    q = action_values(carry.weights, g)  # Q(s', .) before the update
    action = choose(q)
    bootstrap = jnp.where(terminal, 0.0, gamma * q[action])
    delta = reward - carry.q_taken + bootstrap
    finite = jnp.isfinite(delta)
    step = jnp.where(~carry.diverged & finite, alpha * delta, 0.0)
    weights, traces = update(agent, carry.weights, carry.traces, carry.g, carry.action,
                             gamma * lam, step)
    q_after = action_values(weights, g)  # Q(observed, .) after the update
    # after a terminal state the next episode's first action is chosen from the updated
    # weights, as lwrl's learner does when it starts an episode
    first_action = choose(q_after)
    action = jnp.where(terminal, first_action, action)
    carry = carry._replace(weights=weights,
                           traces=jnp.where(terminal | truncated, 0.0, traces),
                           state=observed, g=g, action=action, q_taken=q_after[action],
                           diverged=carry.diverged | ~finite)
    return carry, {"delta": delta, "q": jnp.where(terminal, q_after, q)}


def restart(agent: Agent, carry: Carry, start, choose) -> tuple[Carry, jax.Array]:
    """The next episode's start for one agent whose last episode was truncated: its
    features, and its first action from the current weights. Returns the carry and Q there."""
    g = factors(agent, start)
    q = action_values(carry.weights, g)
    action = choose(q)
    return carry._replace(state=start, g=g, action=action, q_taken=q[action]), q


def agent_transition(task: PeerTask, agent: Agent, carry: Carry, hyper, uniforms):
    """One plant transition of one agent and its update (`learner_step`). Returns the new
    carry, whether the episode was truncated (its restart is `make_block`'s) and the steps
    of the episode if it ended (else 0)."""
    epsilon = hyper[3]
    controls = jnp.array(task.controls)
    next_state = task.step(carry.state, controls[carry.action])
    reward, terminal = task.outcome(next_state)
    steps = carry.steps + 1
    truncated = ~terminal & (steps >= task.step_limit)
    last = terminal | truncated
    start = task.start(uniforms[UNIFORMS_PER_STEP:UNIFORMS_PER_STEP + task.dim])
    carry, _ = learner_step(agent, carry, hyper, next_state, reward, terminal, truncated,
                            start, lambda q: epsilon_greedy(q, epsilon, uniforms[0:3]))
    return carry._replace(steps=jnp.where(last, 0, steps)), truncated, jnp.where(last, steps, 0)


def agent_restart(task: PeerTask, agent: Agent, carry: Carry, hyper, uniforms, truncated):
    """Where `truncated`, the next episode's start (`restart`); elsewhere the carry as is."""
    start = task.start(uniforms[UNIFORMS_PER_STEP:UNIFORMS_PER_STEP + task.dim])
    restarted, _ = restart(agent, carry, start,
                           lambda q: epsilon_greedy(q, hyper[3], uniforms[3:6]))
    return jax.tree.map(lambda new, old: jnp.where(truncated, new, old), restarted, carry)


def initial_carry(task: PeerTask, agent: Agent, keys):
    """The agents' state before their first episode: zero weights and traces, each agent's
    first start and first action, and its key. At zero weights every action ties, so the
    first action is uniform whatever epsilon (drawn here as the greedy tie-break)."""
    batch = keys.shape[0]
    keys, draw = jax.vmap(lambda key: tuple(jax.random.split(key)))(keys)
    uniforms = jax.vmap(lambda key: jax.random.uniform(key, (UNIFORMS_PER_STEP + task.dim,)))(draw)
    shape = (batch, agent.num_actions, agent.n ** task.dim)
    states = jax.vmap(task.start)(uniforms[:, UNIFORMS_PER_STEP:])
    g = jax.vmap(lambda s: factors(agent, s))(states)
    zeros = jnp.zeros(agent.num_actions)
    actions = jax.vmap(lambda u: epsilon_greedy(zeros, 0.0, u))(uniforms[:, 3:6])
    carry = Carry(jnp.zeros(shape), jnp.zeros(shape), states, g, actions, jnp.zeros(batch),
                  jnp.zeros(batch, dtype=jnp.int32), jnp.zeros(batch, dtype=bool))
    return carry, keys


def make_block(task: PeerTask, agent: Agent, length: int = BLOCK):
    """`block(carry, keys, hyper) -> (carry, keys, episode_steps)`: `length` steps of every
    agent, `episode_steps` `(length, B)` the steps of each episode finished (0 elsewhere).
    Each agent's key is split once per block and the block's uniforms drawn in one call."""
    transition = jax.vmap(functools.partial(agent_transition, task, agent))
    restart_truncated = jax.vmap(functools.partial(agent_restart, task, agent))

    def block(carry, keys, hyper):
        keys, draw = jax.vmap(lambda key: tuple(jax.random.split(key)))(keys)
        width = UNIFORMS_PER_STEP + task.dim
        uniforms = jax.vmap(lambda key: jax.random.uniform(key, (length, width)))(draw)

        def body(carry, uniforms_t):
            carry, truncated, finished = transition(carry, hyper, uniforms_t)
            # a truncation is rare (at most one in `step_limit` steps of an agent): only on
            # those steps does the batch compute a second start's features and values
            carry = jax.lax.cond(truncated.any(),
                                 lambda c: restart_truncated(c, hyper, uniforms_t, truncated),
                                 lambda c: c, carry)
            return carry, finished

        carry, episode_steps = jax.lax.scan(body, carry, jnp.swapaxes(uniforms, 0, 1))
        return carry, keys, episode_steps

    return jax.jit(block, donate_argnums=(0, 1))


def peer_agents(task_name: str, agents: int, seed: int = 0):
    """The task's paper agent (`RunConfig` defaults) for the peer: `(Agent, hyper, keys)`,
    agent b keyed with `seed + b`."""
    config = RunConfig(task=task_name, agents=agents, seed=seed)
    settings, info = config.agent, config.task_info
    features_map = settings.feature_map(info.low, info.high)
    agent = Agent(tuple(features_map.low), tuple(features_map.high), features_map.n,
                  features_map.r2, settings.trace == "accumulating", len(TASKS[task_name].controls))
    if settings.trace not in ("replacing", "accumulating"):
        raise ValueError(f"the peer has replacing and accumulating traces; got {settings.trace}")
    hyper = tuple(jnp.full(agents, value, dtype=jnp.float64)
                  for value in (settings.alpha, settings.gamma, settings.lam, settings.epsilon))
    keys = jax.vmap(jax.random.key)(jnp.asarray(config.seeds))
    return agent, hyper, keys


def episodes_of(episode_steps: np.ndarray) -> list:
    """Per agent, the steps of its finished episodes in order, from `(T, B)` blocks."""
    return [column[column > 0] for column in episode_steps.T]


def learn_peer(task_name: str, agents: int, episodes: int, seed: int = 0, length: int = BLOCK):
    """The peer's agents for at least `episodes` episodes each: `(agents, episodes)` steps
    per episode (blocks of `length` steps until every agent has finished `episodes`)."""
    task = TASKS[task_name]
    agent, hyper, keys = peer_agents(task_name, agents, seed)
    carry, keys = initial_carry(task, agent, keys)
    block = make_block(task, agent, length)
    finished = [[] for _ in range(agents)]
    while min(len(f) for f in finished) < episodes:
        carry, keys, episode_steps = block(carry, keys, hyper)
        for b, steps in enumerate(episodes_of(np.asarray(episode_steps))):
            finished[b].extend(steps.tolist())
    return np.array([f[:episodes] for f in finished], dtype=np.float64)


def learning_check(agents: int = CHECK_AGENTS, episodes: int = CHECK_EPISODES) -> dict:
    """The paper's Mountain-Car protocol (the best agent, Fig. 3) for the peer and for lwrl
    (the compiled loop, seeds 0..agents-1): per-episode steps `(agents, episodes)` of each."""
    peer = learn_peer("mountain_car.cost_to_go", agents, episodes)
    _, results = run(RunConfig(task="mountain_car.cost_to_go", plant="analytic", agents=agents,
                               episodes=episodes))
    return {"JAX peer": peer, "lwrl": results.steps}


# --- Measuring -------------------------------------------------------------------------------

@dataclasses.dataclass
class Measurement:
    """Agent-steps done in a timed run, with its wall and CPU time (all threads)."""

    steps: int
    seconds: float
    cpu_seconds: float
    agents: int
    episodes: int
    """lwrl: episodes per agent; the peer: episodes finished by all agents in the run."""

    @property
    def rate(self) -> float:
        return self.steps / self.seconds

    @property
    def cpu_per_step(self) -> float:
        """CPU seconds (all threads) per agent-step."""
        return self.cpu_seconds / self.steps


def compile_peer(task_name: str, agents: int, seed: int = 0):
    """The peer's compiled block for `agents` agents and their first carry; returns
    `(block, carry, keys, hyper, seconds spent compiling)`."""
    task = TASKS[task_name]
    agent, hyper, keys = peer_agents(task_name, agents, seed)
    carry, keys = initial_carry(task, agent, keys)
    jax.block_until_ready((carry, keys))
    start = time.perf_counter()
    block = make_block(task, agent).lower(carry, keys, hyper).compile()
    return block, carry, keys, hyper, time.perf_counter() - start


def measure_peer(compiled, seconds: float) -> Measurement:
    """The peer's agents from zero weights: blocks of `BLOCK` steps until `seconds` have
    passed (at least one block)."""
    block, carry, keys, hyper, _ = compiled
    agents = keys.shape[0]
    calls = episodes = 0
    start, cpu_start = time.perf_counter(), time.process_time()
    while True:
        carry, keys, episode_steps = block(carry, keys, hyper)
        calls += 1
        episodes += int(np.count_nonzero(np.asarray(episode_steps)))  # waits for the block
        if time.perf_counter() - start >= seconds:
            break
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu_start
    return Measurement(calls * BLOCK * agents, elapsed, cpu, agents, episodes)


def run_lwrl(task_name: str, agents: int, episodes: int) -> Measurement:
    """One timed `run_compiled` of `agents` seeds of the task's paper agent (as
    `benchmarks.agent_speed.run_lwrl`, with CPU time)."""
    config = RunConfig(task=task_name, agents=agents, episodes=episodes, plant="analytic")
    agent = make_agent(config)
    start, cpu_start = time.perf_counter(), time.process_time()
    results = run_compiled(config.domain, config.task_name, agent, episodes, config.seeds,
                           integrator=config.integrator)
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu_start
    return Measurement(int(np.nansum(results.steps)), elapsed, cpu, agents, episodes)


def measure_lwrl(task_name: str, agents: int, seconds: float) -> Measurement:
    """As `benchmarks.agent_speed.measure_lwrl`: episodes grown (at most 4-fold a run) until
    a run lasts at least 3/4 of `seconds`; that run."""
    episodes = 1
    while True:
        measured = run_lwrl(task_name, agents, episodes)
        if measured.seconds >= 0.75 * seconds:
            return measured
        growth = min(4.0, 1.1 * seconds / max(measured.seconds, 1e-6))
        episodes = max(episodes + 1, math.ceil(episodes * growth))


def compile_lwrl(task_name: str) -> tuple[float, str]:
    """Seconds of lwrl's first call of the task's compiled loop (one agent, one episode),
    and what it did: compile, or load from the kernel cache, or nothing (already loaded)."""
    config = RunConfig(task=task_name, plant="analytic")
    kernel = compiled_loop(tasks.definition(config.domain, config.task_name),
                           learners.learner(config.learner))
    loaded = kernel._dispatcher is not None
    start = time.perf_counter()
    run_lwrl(task_name, 1, 1)
    seconds = time.perf_counter() - start
    if loaded:
        return seconds, "already loaded in this process"
    stats = kernel.dispatcher.stats
    compiled = sum(stats.cache_misses.values()) > 0
    return seconds, "compiled" if compiled else "loaded from the kernel cache"


@contextlib.contextmanager
def fresh_kernel_cache(enabled: bool):
    """lwrl's kernel cache in a new temporary directory (so that its first call compiles),
    unless `$LWRL_CACHE_DIR` is set or `enabled` is false."""
    if not enabled or os.environ.get("LWRL_CACHE_DIR"):
        yield
        return
    directory = tempfile.mkdtemp(prefix="lwrl-jax-peer-kernels-")
    os.environ["LWRL_CACHE_DIR"] = directory
    try:
        yield
    finally:
        del os.environ["LWRL_CACHE_DIR"]
        shutil.rmtree(directory, ignore_errors=True)


def parse_args(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description="Agent-steps/s of lwrl's compiled learner against the same algorithm "
                    "written in JAX (jit, vmap over agents, lax.scan over steps), for "
                    f"{', '.join(map(str, AGENTS))} agents on Mountain-Car and Cart-Pole; "
                    "prints Markdown tables.")
    parser.add_argument("--seconds", type=float, default=3.0,
                        help="time budget per measurement, in seconds (default: 3)")
    parser.add_argument("--quick", action="store_true",
                        help=f"smoke test: {QUICK_SECONDS} s per measurement, "
                             f"{' and '.join(map(str, QUICK_AGENTS))} agents, a short "
                             "learning check")
    parser.add_argument("--cached", action="store_true",
                        help="let lwrl load its kernels from its cache (default: compile them "
                             "in a fresh temporary cache, so that both compile times are "
                             "compiles)")
    args = parser.parse_args(argv)
    if not args.seconds > 0:
        parser.error(f"--seconds must be positive; got {args.seconds}")
    if args.quick:
        args.seconds = QUICK_SECONDS
    return args


def steps_cell(steps: np.ndarray) -> str:
    """Mean ± standard error over agents of each agent's mean steps per episode."""
    per_agent = np.nanmean(steps, axis=1)
    error = per_agent.std(ddof=1) / math.sqrt(len(per_agent)) if len(per_agent) > 1 else math.nan
    return f"{per_agent.mean():.1f} ± {error:.1f}"


def main(argv=None) -> None:
    args = parse_args(argv)
    script_start = time.perf_counter()
    agent_counts = QUICK_AGENTS if args.quick else AGENTS
    check_agents, check_episodes = (3, 4) if args.quick else (CHECK_AGENTS, CHECK_EPISODES)
    rows, compiles, runs = [], [], []
    with fresh_kernel_cache(not args.cached):
        for task_name in TASKS:
            seconds, how = compile_lwrl(task_name)
            compiles.append(f"- {task_name}, lwrl: {seconds:.1f} s ({how}; one loop for every "
                            "batch size)")
        for task_name in TASKS:
            for agents in agent_counts:
                compiled = compile_peer(task_name, agents)
                compiles.append(f"- {task_name}, JAX peer, {plural(agents, 'agent')}: "
                                f"{compiled[-1]:.1f} s (jit: one compile per batch size)")
                lwrl = measure_lwrl(task_name, agents, args.seconds)
                peer = measure_peer(compiled, args.seconds)
                rows.append(f"| {task_name} | {agents} | {lwrl.rate:,.0f} | {peer.rate:,.0f} | "
                            f"x{lwrl.rate / peer.rate:.2f} | {1e9 * lwrl.cpu_per_step:,.0f} | "
                            f"{1e9 * peer.cpu_per_step:,.0f} | "
                            f"x{peer.cpu_per_step / lwrl.cpu_per_step:.2f} |")
                runs.append(f"- {task_name}, {plural(agents, 'agent')}: lwrl {agents} x "
                            f"{plural(lwrl.episodes, 'episode')}, {lwrl.steps:,} agent-steps in "
                            f"{lwrl.seconds:.2f} s; JAX peer {agents} x {peer.steps // agents:,} "
                            f"steps ({peer.episodes:,} episodes finished) in {peer.seconds:.2f} s")
        check_start = time.perf_counter()
        check = learning_check(check_agents, check_episodes)
        check_seconds = time.perf_counter() - check_start
    window = slice(max(0, check_episodes - 10), check_episodes)
    print("| task | agents | lwrl (agent-steps/s) | JAX peer (agent-steps/s) | lwrl / JAX "
          "| lwrl CPU ns per agent-step | JAX CPU ns per agent-step | JAX CPU / lwrl CPU |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    print("\n".join(rows))
    print(f"\nLearning check, the paper's best Mountain-Car agent ({check_agents} agents x "
          f"{check_episodes} episodes), mean ± standard error over agents of the steps per "
          f"episode:\n")
    print(f"| | episode 1 | episodes {window.start + 1}-{window.stop} |")
    print("|---|---:|---:|")
    for name, steps in check.items():
        print(f"| {name} | {steps_cell(steps[:, :1])} | {steps_cell(steps[:, window])} |")
    print("\n" + machine(f"{workers()} cores (lwrl's threads, agent.threads.workers()), JAX "
                         f"on {jax.default_backend()}", np, numba, jax))
    print("\nCompile times (in no rate):")
    print("\n".join(compiles))
    print("\nRuns measured (each from zero weights):")
    print("\n".join(runs))
    print(f"\nTotal {time.perf_counter() - script_start:.1f} s, of which {check_seconds:.1f} s "
          "the learning check.")


if __name__ == "__main__":
    main()
