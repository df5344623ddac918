"""lwrl's learner against the same algorithm written as JAX code (the PureJaxRL style).

The peer (written here, not project code) is lwrl's Sarsa(lambda) with NRBF features as a
JAX program: one agent's step is a pure function, `jax.vmap` maps it over a group of agents
(each with its own PRNG key and hyper-parameters), `jax.lax.scan` runs it over a fixed
number of steps and `jax.lax.map` runs the groups one after another, all under one
`jax.jit`, in float64 (`jax_enable_x64`). It follows lwrl's definitions, not its code:

- features: NRBF eq. 8 and 9 factorised per dimension as `agent/nrbf.py` computes them
  (each dimension's Gaussians normalised, then their outer product in C order, the last
  state variable fastest, each feature the very product lwrl forms), with its underflow
  guard (the smallest squared distance subtracted in the exponent, the normalised state
  clamped to [-400 n r^2, 1 + 400 n r^2]);
- Q(s, a) = w_a . phibar(s) with weights zero at the start; epsilon-greedy with ties broken
  uniformly at random; delta = r + gamma d Q(s', a') - Q(s, a), with d = 0 at a terminal
  state (no action drawn there) and every term from the weights before the update;
- traces as `agent/traces.py`: replacing (eq. 6) or accumulating (eq. 2), decayed by
  gamma lambda, values below 1e-100 flushed to 0, 0 at each episode's start; a delta that
  is not finite marks the agent diverged and freezes its weights;
- the tasks: `tasks/mountain_car.py`'s difference equation and `tasks/cartpole.py`'s
  equations with semi-implicit Euler (MuJoCo's; lwrl's default), their rewards, terminal
  states and starts, the time limit as a truncation (the agent bootstraps from the last
  state), and auto-reset inside the scan: the step that ends an episode also starts the
  next one, so every scanned step of every agent is one real plant transition.

Its design, for speed (`feature_factors`, `update`, `learner_step`, `make_block`):

- the features are kept as two factors whose outer product they are (`feature_factors`):
  the first dimension's normalised Gaussians, `head` `(n,)`, and the product of the others,
  `tail` `(n^(d-1),)` (6 and 216 for the cart-pole's 6^4 grid, 8 and 8 for Mountain-Car's
  8^2). Weights and traces are `(A, n, n^(d-1))`: Q is two matrix-vector products
  (`action_values`, W viewed as `(A n, n^(d-1))` times the tail, then `(A, n)` times the
  head), and the trace-and-weight update is elementwise over `(A, n, n^(d-1))` and forms
  each feature as `head[i] * tail[j]` on the way (`update`): the innermost loop of XLA's
  loops over the traces and the weights runs over the contiguous tail, which XLA
  vectorises, and no feature's index is taken apart into its d digits;
- the traces' reset at an episode's start is a flag applied in the next update's pass, not
  a pass of its own;
- epsilon-greedy is written out over the A actions (`epsilon_greedy`), a few scalar
  operations XLA fuses, where the maximum, count and cumulative sum of the ties are
  reductions;
- the random numbers come from JAX's `rbg` PRNG (`PRNG`, XLA's random-bit generator), which
  costs a fraction of the default threefry per uniform: each agent's key is split once per
  block and the block's uniforms drawn in one call for all the agents (so that an agent's
  numbers do not depend on its group), six a step for the actions and the start's own (none
  for the cart-pole's fixed start);
- the auto-reset after a terminal state is branch-free: the state observed next is the
  start where the step was terminal, else s' (Q at a terminal state is never needed: its
  bootstrap is 0), so one set of features and one Q serve both cases; only the rare steps
  where some agent's episode is truncated (it needs both s' and a start) run a group-level
  `lax.cond` (`agent_restart`);
- Q(s', a') under the updated weights is carried to the next step, where it is Q(s, a) of
  the TD error: each step evaluates Q twice (before the update at s' for the choice and the
  bootstrap, after it for the carried value and, after a terminal state, the next episode's
  first action, chosen from the updated weights as lwrl's learner does);
- a call runs `BLOCK_AGENT_STEPS` agent-steps (`block_length`: 30,000 steps of one agent,
  1,000 of each of 30 or 300), the carry donated, so that the call's fixed cost is no
  part of the rate;
- the agents run side by side (`vmap`) in groups whose weights and traces fit in
  `GROUP_BYTES` (`group_size`: one cart-pole agent, 15 or 20 Mountain-Car agents), the
  groups one after another (`lax.map`), so that a group's arrays stay in cache over the
  block, as lwrl runs each agent's episodes one after another; vmapped over the whole
  batch, every step streams all the agents' arrays through memory;
- `main` compiles the scans with XLA:CPU's `xla_cpu_small_while_loop_byte_threshold` raised
  (`XLA_SMALL_LOOPS`, in `XLA_FLAGS`), so that XLA compiles each loop as one function:
  otherwise its runtime dispatches a step's dozens of kernels one by one, with their
  bookkeeping and hand-offs between its threads, a fixed cost per kernel that one agent
  pays alone. The script prints the flags and whether they took effect.

What made the design before this one slow for one agent (the design it replaces: the
features kept as their d per-dimension factors, Q contracted factor by factor, the whole
batch vmapped, blocks of 1,000 steps, threefry): the fused trace-and-weight update formed
each feature from its index taken apart into d digits by integer divisions, scalar code
that ran twice a step (once for the weights' pass, once for the traces' with their reset)
over the A n^d entries; XLA turned the reshapes between the factor-by-factor contractions
into copy kernels; each scanned step ran dozens of kernels through the runtime, with ten
threefry uniforms drawn for it; and a call of 1,000 steps of one agent is short beside
its fixed cost. The design here serves every batch size, and raises the peer's rates at
30 and 300 agents too.

The peer draws its random numbers from JAX's PRNG, so its numbers differ from lwrl's; it
must learn the same, which `learning_check` measures on the paper's Mountain-Car protocol.
`tests/test_jax_peer.py` also checks its features and plant steps against lwrl's, and its
learner step on a fixed trajectory with fixed actions: features, Q, TD errors and weights
after every transition equal lwrl's learner's to round-off (the test allows 1e-12 of the
largest weight; the two-factor Q adds in another order than lwrl's dot products).

One run of this script measures, on Mountain-Car and Cart-Pole with the paper's agent of
each task (`agent.paper_settings`), for 1, 30 and 300 agents (`--tasks`, `--agents`
choose others):

1. **lwrl**: `runners.compiled.run_compiled`, as `benchmarks.agent_speed` measures it
   (episodes grown until a run lasts about `--seconds`; the default thread pool);
2. **JAX peer**: blocks of `block_length` scanned steps from zero weights, called until
   `--seconds` have passed (with its loops compiled as single functions, XLA runs a block
   on one thread);

and prints agent-steps per second of each (wall time), the ratio lwrl / JAX, the CPU time
per agent-step of each (all threads) and their ratio, the arithmetic bound of one agent-step
on one core (`benchmarks.arithmetic_bound`, its rates measured in the same run) and the
peer's CPU time over it (an implementation of the same arithmetic can be twice as fast as
the peer only where that ratio is at least 2), and each one's compile time, which no
rate includes (lwrl's kernels are compiled in a fresh cache directory unless `--cached`, so
that the time is a compile and not a load from `~/.cache/lwrl`), with the block length and
group size of each peer, the machine and its load average at the end. An agent-step is one
plant transition: for the peer, the scanned steps of all agents. Ratios compare rates
measured in the same run. On a machine that other jobs keep busy the wall-time ratio
understates lwrl, whose threads find no free core, and the CPU-time ratio is the fairer
one; `docs/guide/speed.md` quotes one run's table with the host, its load and the command.

Where the peer's time goes now: one agent-step of one agent is the work lwrl's is, in
float64 (two passes of Q over the weights, one over weights and traces together, the
features' exponentials, the plant), in one compiled function; XLA runs a block on one
core, where lwrl spreads a batch over the cores.

Also tried, and not kept: Q as a dot with the feature vector formed (XLA computed the
features twice, once into a copy for the dot with their index taken apart), or as an
elementwise product summed (XLA's reductions add one element after another); the features
split after two dimensions (36 x 36 for the cart-pole: XLA unrolled the update's 36-long
inner loop and did not vectorise it); `jnp.einsum` for the contractions (the same dot in
XLA's optimised HLO); a specialised path for one agent without `vmap` (no faster than a
group of one); the whole batch vmapped as one group, or groups of other sizes; the scan's
restart under a `lax.cond` that also passes the weights or traces (XLA copies them around
it every step); and, with the loops compiled as single functions,
`--xla_cpu_multi_thread_eigen=false` (no difference beyond the noise). float64 is kept:
it is lwrl's precision, and the step-by-step check needs it.

Run from the repository root (needs the `jax` extra, `pip install -e .[jax]`; CPU only):

    python -m benchmarks.jax_peer              # about 3 s per measurement, a few minutes
    python -m benchmarks.jax_peer --quick      # smoke test
    python -m benchmarks.jax_peer --tasks cartpole.balance --agents 1 --no-learning-check
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
from benchmarks.arithmetic_bound import bound_seconds, measure_rates, task_counts
from lwrl import tasks
from lwrl.agent.threads import workers
from lwrl.agent.traces import FLUSH_THRESHOLD
from lwrl import agent as learners
from lwrl.runners.compiled import compiled_loop
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents, run, run_compiled
from lwrl.tasks import cartpole, mountain_car

jax.config.update("jax_enable_x64", True)

AGENTS = (1, 30, 300)
"""The batch sizes measured."""
BLOCK_AGENT_STEPS = 30_000
"""Agent-steps per jitted call of the peer: each agent scans `block_length(B)` steps."""
MIN_BLOCK = 1000
"""The fewest scanned steps per call."""
GROUP_BYTES = 64 * 1024
"""A group of agents run side by side (`vmap`) holds at most this many bytes of weights and
traces, so that they stay in a core's caches over a block (`group_size`)."""
PRNG = "rbg"
"""The peer's PRNG (`jax.random.key(..., impl=PRNG)`): XLA's random-bit generator for the
bits, a fraction of the default threefry's cost per float64 uniform on CPU."""
XLA_SMALL_LOOPS = "xla_cpu_small_while_loop_byte_threshold=1000000000"
"""The XLA:CPU backend option that compiles every while loop (the block's `lax.scan`) as one
function (`SmallWhileLoopHoistingPass`; its default limit is 1 KB of buffers an iteration
accesses) rather than as a sequence of thunks that XLA's runtime dispatches one by one:
`main` puts it in `XLA_FLAGS` (`--xla_backend_extra_options`) unless that is set."""
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
    """All zeros (the paper's start is deterministic: it draws no uniforms)."""
    return jnp.zeros(4)


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
    start_draws: int
    """Uniforms in [0, 1) a start draws (`start` maps them to a state)."""


TASKS = {
    "mountain_car.cost_to_go": PeerTask(
        "mountain_car.cost_to_go", mountain_car_step, mountain_car_outcome, mountain_car_start,
        mountain_car.THRUSTS, mountain_car.STEP_LIMIT, 2, 2),
    "cartpole.balance": PeerTask(
        "cartpole.balance", cartpole_step, cartpole_outcome, cartpole_start, cartpole.FORCES,
        round(cartpole.TIME_LIMIT / cartpole.TIMESTEP), 4, 0),
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


def feature_factors(agent: Agent, state):
    """The features of one state as two factors whose outer product they are, `(head,
    tail)`: the first dimension's factor `(n,)` and the outer product of the others
    `(n^(d-1),)` (`outer`), so that `head[i] * tail[j]` is feature `i n^(d-1) + j`, the
    very product `outer` forms."""
    g = factors(agent, state)
    return g[0], outer(g[1:]) if g.shape[0] > 1 else jnp.ones(1)


def joined(head, tail):
    """The feature vector `(n^d,)` of `feature_factors`' two factors."""
    return (head[:, None] * tail[None, :]).reshape(-1)


def action_values(weights, head, tail):
    """Q(s, .) = w phibar(s) (eq. 9) for weights `(A, n, n^(d-1))` and the features' two
    factors, without forming phibar: W viewed as `(A n, n^(d-1))` times the tail (a
    matrix-vector product), then the result `(A, n)` times the head."""
    num_actions, n, rest = weights.shape
    return (weights.reshape(num_actions * n, rest) @ tail).reshape(num_actions, n) @ head


def epsilon_greedy(q, epsilon, uniforms):
    """An action for Q `(A,)` from three uniforms: the exploration test, the random action,
    the tie-break among the greedy actions (NaN in Q: action 0, as lwrl). Written out over
    the A actions (a few scalar operations XLA fuses): the greedy action is the
    `floor(u * ties)`-th of the actions whose Q equals the largest."""
    num_actions = q.shape[0]
    values = [q[a] for a in range(num_actions)]
    best = values[0]
    for value in values[1:]:
        best = jnp.maximum(best, value)  # NaN if any is
    ties = [value == best for value in values]
    count = sum(tie.astype(jnp.int32) for tie in ties)
    pick = jnp.minimum((uniforms[2] * count).astype(jnp.int32), count - 1)
    greedy, rank = jnp.int32(0), jnp.int32(0)
    for a, tie in enumerate(ties):
        greedy = jnp.where(tie & (rank == pick), a, greedy)
        rank = rank + tie.astype(jnp.int32)
    random_action = jnp.minimum((uniforms[1] * num_actions).astype(jnp.int32), num_actions - 1)
    return jnp.where(uniforms[0] < epsilon, random_action, greedy).astype(jnp.int32)


ACTION_UNIFORMS = 3
"""Uniforms an action draws (`epsilon_greedy`). A step draws twice as many (the next
state's action, or the next episode's first after a terminal state; the next episode's first
after a truncation) and the task's `start_draws` for the next episode's start."""


class Carry(typing.NamedTuple):
    """One agent between two plant transitions (each field gains a leading axis B for a
    batch): its weights and traces `(A, n, n^(d-1))`, the state and its features' two
    factors (`feature_factors`), the action taken there and its value Q(s, a) under the
    current weights, the steps of the episode so far, whether the agent diverged, and
    whether the state starts an episode (the traces then count as 0: `update` applies the
    reset in its pass)."""

    weights: jax.Array
    traces: jax.Array
    state: jax.Array
    head: jax.Array
    tail: jax.Array
    action: jax.Array
    q_taken: jax.Array
    steps: jax.Array
    diverged: jax.Array
    reset: jax.Array


def update(agent: Agent, carry: Carry, gamma_lambda, step):
    """The trace rule (eq. 6 or 2, from `gamma_lambda` times the traces, or 0 after an
    episode's start, `agent/traces.py`'s flush below 1e-100) and `w <- w + step e` (eq. 1)
    for the carry's features in the taken action's row: elementwise over `(A, n, n^(d-1))`,
    the features formed in the pass as `head[i] * tail[j]`, so that the innermost loop runs
    over the contiguous `n^(d-1)` and vectorises. Returns `(weights, traces)`."""
    taken = (jnp.arange(agent.num_actions) == carry.action)[:, None, None]
    decayed = jnp.where(carry.reset, 0.0, gamma_lambda * carry.traces)
    gradient = jnp.where(taken, carry.head[None, :, None] * carry.tail[None, None, :], 0.0)
    updated = decayed + gradient if agent.accumulating else jnp.maximum(decayed, gradient)
    updated = jnp.where(jnp.abs(updated) >= FLUSH_THRESHOLD, updated, 0.0)
    return carry.weights + step * updated, updated


def learner_step(agent: Agent, carry: Carry, hyper, next_state, reward, terminal, truncated,
                 start, choose) -> tuple[Carry, dict]:
    """One agent's Sarsa(lambda) update for the transition from `carry`'s (s, a) to
    `next_state` (s'), branch-free: where s' is `terminal` the next episode begins at
    `start` in the same pass. `choose(q)` is the policy (the benchmark: epsilon-greedy on
    the step's uniforms). Returns the carry at the next observed state (s', or `start`
    after a terminal; `restart` moves it to a start after a truncation; the traces are
    reset in the next update) and what lwrl's learner exposes after the same transition
    (`diagnostics`)."""
    alpha, gamma, lam, _ = hyper
    observed = jnp.where(terminal, start, next_state)
    head, tail = feature_factors(agent, observed)
    q = action_values(carry.weights, head, tail)  # Q(s', .) before the update
    action = choose(q)
    bootstrap = jnp.where(terminal, 0.0, gamma * q[action])
    delta = reward - carry.q_taken + bootstrap
    finite = jnp.isfinite(delta)
    step = jnp.where(~carry.diverged & finite, alpha * delta, 0.0)
    weights, traces = update(agent, carry, gamma * lam, step)
    q_after = action_values(weights, head, tail)  # Q(observed, .) after the update
    # after a terminal state the next episode's first action is chosen from the updated
    # weights, as lwrl's learner does when it starts an episode
    action = jnp.where(terminal, choose(q_after), action)
    carry = carry._replace(weights=weights, traces=traces, state=observed, head=head,
                           tail=tail, action=action, q_taken=q_after[action],
                           diverged=carry.diverged | ~finite, reset=terminal | truncated)
    return carry, {"delta": delta, "q": jnp.where(terminal, q_after, q)}


def restart(agent: Agent, carry: Carry, start, choose) -> tuple[Carry, jax.Array]:
    """The next episode's start for one agent whose last episode was truncated: its
    features, and its first action from the current weights. Returns the carry and Q there."""
    head, tail = feature_factors(agent, start)
    q = action_values(carry.weights, head, tail)
    action = choose(q)
    return carry._replace(state=start, head=head, tail=tail, action=action,
                          q_taken=q[action]), q


def agent_transition(task: PeerTask, agent: Agent, carry: Carry, hyper, uniforms):
    """One plant transition of one agent and its update (`learner_step`), on the step's
    uniforms (`ACTION_UNIFORMS`). Returns the new carry, whether the episode was truncated
    (its restart is `make_block`'s) and the steps of the episode if it ended (else 0)."""
    epsilon = hyper[3]
    controls = jnp.array(task.controls)
    next_state = task.step(carry.state, controls[carry.action])
    reward, terminal = task.outcome(next_state)
    steps = carry.steps + 1
    truncated = ~terminal & (steps >= task.step_limit)
    last = terminal | truncated
    start = task.start(uniforms[2 * ACTION_UNIFORMS:])
    carry, _ = learner_step(agent, carry, hyper, next_state, reward, terminal, truncated,
                            start, lambda q: epsilon_greedy(q, epsilon, uniforms))
    return carry._replace(steps=jnp.where(last, 0, steps)), truncated, jnp.where(last, steps, 0)


def agent_restart(task: PeerTask, agent: Agent, carry: Carry, hyper, uniforms, truncated):
    """Where `truncated`, the next episode's start (`restart`, on the step's start uniforms,
    which a truncated step did not use, and its restart's action uniforms); elsewhere the
    carry as is."""
    start = task.start(uniforms[2 * ACTION_UNIFORMS:])
    restarted, _ = restart(agent, carry, start, lambda q: epsilon_greedy(
        q, hyper[3], uniforms[ACTION_UNIFORMS:2 * ACTION_UNIFORMS]))
    return jax.tree.map(lambda new, old: jnp.where(truncated, new, old), restarted, carry)


def initial_carry(task: PeerTask, agent: Agent, keys):
    """The agents' state before their first episode: zero weights and traces, each agent's
    first start and first action, and its key. At zero weights every action ties, so the
    first action is uniform whatever epsilon (drawn here as the greedy tie-break)."""
    batch = keys.shape[0]
    keys, draw = jax.vmap(lambda key: tuple(jax.random.split(key)))(keys)
    uniforms = jax.vmap(
        lambda key: jax.random.uniform(key, (2 * ACTION_UNIFORMS + task.start_draws,)))(draw)
    shape = (batch, agent.num_actions, agent.n, agent.n ** (task.dim - 1))
    states = jax.vmap(task.start)(uniforms[:, 2 * ACTION_UNIFORMS:])
    head, tail = jax.vmap(lambda s: feature_factors(agent, s))(states)
    zeros = jnp.zeros(agent.num_actions)
    actions = jax.vmap(lambda u: epsilon_greedy(zeros, 0.0, u))(uniforms)
    carry = Carry(jnp.zeros(shape), jnp.zeros(shape), states, head, tail, actions,
                  jnp.zeros(batch), jnp.zeros(batch, dtype=jnp.int32),
                  jnp.zeros(batch, dtype=bool), jnp.zeros(batch, dtype=bool))
    return carry, keys


def block_length(agents: int) -> int:
    """Scanned steps per call for `agents` agents: `BLOCK_AGENT_STEPS` agent-steps, at least
    `MIN_BLOCK` steps, so that a call's fixed cost is no part of the rate."""
    return max(MIN_BLOCK, math.ceil(BLOCK_AGENT_STEPS / agents))


def group_size(agent: Agent, dim: int, agents: int) -> int:
    """Agents run side by side in a group: the largest divisor of `agents` whose weights and
    traces fit in `GROUP_BYTES` (one cart-pole agent, 41 KB; 15 of 30 or 20 of 300
    Mountain-Car agents, 3 KB each)."""
    per_agent = 2 * 8 * agent.num_actions * agent.n ** dim
    fits = max(1, GROUP_BYTES // per_agent)
    return max(size for size in range(1, min(fits, agents) + 1) if agents % size == 0)


def make_block(task: PeerTask, agent: Agent, agents: int, length: int | None = None,
               group: int | None = None):
    """`block(carry, keys, hyper) -> (carry, keys, episode_steps)`: `length` steps
    (`block_length`) of every agent, `episode_steps` `(length, B)` the steps of each
    episode finished (0 elsewhere). The agents run in groups of `group` (`group_size`) one
    group after another (`lax.map`), each group a `lax.scan` of its steps over the agents
    side by side (`vmap`), so that a group's weights and traces stay in cache over the
    block. Each agent's key is split once per block and the block's uniforms drawn in one
    call for all the agents, so that an agent's numbers do not depend on its group."""
    length = block_length(agents) if length is None else length
    group = group_size(agent, task.dim, agents) if group is None else group
    if agents % group:
        raise ValueError(f"{agents} agents do not split into groups of {group}")
    width = 2 * ACTION_UNIFORMS + task.start_draws
    transition = jax.vmap(functools.partial(agent_transition, task, agent))
    restart_truncated = jax.vmap(functools.partial(agent_restart, task, agent))

    def run_group(carry, hyper, uniforms):
        def body(carry, uniforms_t):
            carry, truncated, finished = transition(carry, hyper, uniforms_t)
            # a truncation is rare (at most one in `step_limit` steps of an agent): only on
            # those steps does the group compute a second start's features and values
            carry = jax.lax.cond(truncated.any(),
                                 lambda c: restart_truncated(c, hyper, uniforms_t, truncated),
                                 lambda c: c, carry)
            return carry, finished

        return jax.lax.scan(body, carry, jnp.swapaxes(uniforms, 0, 1))

    def block(carry, keys, hyper):
        keys, draw = jax.vmap(lambda key: tuple(jax.random.split(key)))(keys)
        uniforms = jax.vmap(lambda key: jax.random.uniform(key, (length, width)))(draw)
        if group == agents:
            carry, episode_steps = run_group(carry, hyper, uniforms)
            return carry, keys, episode_steps
        split = lambda x: x.reshape((agents // group, group) + x.shape[1:])  # noqa: E731
        carry, episode_steps = jax.lax.map(
            lambda args: run_group(*args), jax.tree.map(split, (carry, hyper, uniforms)))
        merge = lambda x: x.reshape((agents,) + x.shape[2:])  # noqa: E731
        return (jax.tree.map(merge, carry), keys,
                jnp.swapaxes(episode_steps, 0, 1).reshape(length, agents))

    return jax.jit(block, donate_argnums=(0, 1))


def peer_agents(task_name: str, agents: int, seed: int = 0):
    """The task's paper agent (`RunConfig` defaults) for the peer: `(Agent, hyper, keys)`,
    agent b keyed with `seed + b` (`PRNG` keys)."""
    config = RunConfig(task=task_name, agents=agents, seed=seed)
    settings, ranges = config.settings, config.task_spec.ranges
    features_map = settings.feature_map(ranges.low, ranges.high)
    agent = Agent(tuple(features_map.low), tuple(features_map.high), features_map.n,
                  features_map.r2, settings.trace == "accumulating", len(TASKS[task_name].controls))
    if settings.trace not in ("replacing", "accumulating"):
        raise ValueError(f"the peer has replacing and accumulating traces; got {settings.trace}")
    hyper = tuple(jnp.full(agents, value, dtype=jnp.float64)
                  for value in (settings.alpha, settings.gamma, settings.lam, settings.epsilon))
    keys = jax.vmap(lambda seed: jax.random.key(seed, impl=PRNG))(jnp.asarray(config.seeds))
    return agent, hyper, keys


def episodes_of(episode_steps: np.ndarray) -> list:
    """Per agent, the steps of its finished episodes in order, from `(T, B)` blocks."""
    return [column[column > 0] for column in episode_steps.T]


def learn_peer(task_name: str, agents: int, episodes: int, seed: int = 0,
               length: int = MIN_BLOCK):
    """The peer's agents for at least `episodes` episodes each: `(agents, episodes)` steps
    per episode (blocks of `length` steps until every agent has finished `episodes`)."""
    task = TASKS[task_name]
    agent, hyper, keys = peer_agents(task_name, agents, seed)
    carry, keys = initial_carry(task, agent, keys)
    block = make_block(task, agent, agents, length)
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
    block = make_block(task, agent, agents).lower(carry, keys, hyper).compile()
    return block, carry, keys, hyper, time.perf_counter() - start


def measure_peer(compiled, seconds: float) -> Measurement:
    """The peer's agents from zero weights: blocks of `block_length` steps until `seconds`
    have passed (at least one block)."""
    block, carry, keys, hyper, _ = compiled
    agents = keys.shape[0]
    calls = episodes = steps = 0
    start, cpu_start = time.perf_counter(), time.process_time()
    while True:
        carry, keys, episode_steps = block(carry, keys, hyper)
        episode_steps = np.asarray(episode_steps)  # waits for the block
        calls += 1
        steps += episode_steps.size
        episodes += int(np.count_nonzero(episode_steps))
        if time.perf_counter() - start >= seconds:
            break
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu_start
    return Measurement(steps, elapsed, cpu, agents, episodes)


def run_lwrl(task_name: str, agents: int, episodes: int) -> Measurement:
    """One timed `run_compiled` of `agents` seeds of the task's paper agent (as
    `benchmarks.agent_speed.run_lwrl`, with CPU time)."""
    config = RunConfig(task=task_name, agents=agents, episodes=episodes, plant="analytic")
    agent = make_agents(config)
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
                    "written in JAX (jit, lax.scan over steps, vmap over a group of agents), "
                    f"for {', '.join(map(str, AGENTS))} agents on Mountain-Car and Cart-Pole; "
                    "prints Markdown tables.")
    parser.add_argument("--seconds", type=float, default=3.0,
                        help="time budget per measurement, in seconds (default: 3)")
    parser.add_argument("--quick", action="store_true",
                        help=f"smoke test: {QUICK_SECONDS} s per measurement, "
                             f"{' and '.join(map(str, QUICK_AGENTS))} agents, a short "
                             "learning check")
    parser.add_argument("--tasks", nargs="+", choices=list(TASKS), default=list(TASKS),
                        metavar="TASK", help="the tasks measured (default: both, "
                                             f"{' '.join(TASKS)})")
    parser.add_argument("--agents", nargs="+", type=int, metavar="B",
                        help="the batch sizes measured (default: "
                             f"{' '.join(map(str, AGENTS))}; with --quick, "
                             f"{' '.join(map(str, QUICK_AGENTS))})")
    parser.add_argument("--no-learning-check", dest="learning_check", action="store_false",
                        help="skip the learning check (default: run it)")
    parser.add_argument("--cached", action="store_true",
                        help="let lwrl load its kernels from its cache (default: compile them "
                             "in a fresh temporary cache, so that both compile times are "
                             "compiles)")
    args = parser.parse_args(argv)
    if not args.seconds > 0:
        parser.error(f"--seconds must be positive; got {args.seconds}")
    if args.agents is not None and min(args.agents) < 1:
        parser.error(f"--agents must be positive; got {args.agents}")
    if args.quick:
        args.seconds = QUICK_SECONDS
    return args


def use_small_loops() -> str:
    """`XLA_SMALL_LOOPS` in `XLA_FLAGS`, unless they already pass backend options; it takes
    effect if JAX has not started its CPU backend yet. Returns `XLA_FLAGS`."""
    flags = os.environ.get("XLA_FLAGS", "")
    if "xla_backend_extra_options" not in flags:
        flags = f"{flags} --xla_backend_extra_options={XLA_SMALL_LOOPS}".strip()
        os.environ["XLA_FLAGS"] = flags
    return flags


def single_function_loops(compiled_block) -> bool:
    """Whether XLA compiled the block's loops as single functions (`XLA_SMALL_LOOPS`)."""
    return "xla_cpu_small_call" in compiled_block.as_text()


def steps_cell(steps: np.ndarray) -> str:
    """Mean ± standard error over agents of each agent's mean steps per episode."""
    per_agent = np.nanmean(steps, axis=1)
    error = per_agent.std(ddof=1) / math.sqrt(len(per_agent)) if len(per_agent) > 1 else math.nan
    return f"{per_agent.mean():.1f} ± {error:.1f}"


def main(argv=None) -> None:
    args = parse_args(argv)
    xla_flags = use_small_loops()
    script_start = time.perf_counter()
    agent_counts = args.agents or (QUICK_AGENTS if args.quick else AGENTS)
    check_agents, check_episodes = (3, 4) if args.quick else (CHECK_AGENTS, CHECK_EPISODES)
    rows, compiles, runs, designs = [], [], [], set()
    with fresh_kernel_cache(not args.cached):
        for task_name in args.tasks:
            seconds, how = compile_lwrl(task_name)
            compiles.append(f"- {task_name}, lwrl: {seconds:.1f} s ({how}; one loop for every "
                            "batch size)")
        for task_name in args.tasks:
            counts = task_counts(task_name)
            bound = bound_seconds(counts, measure_rates(counts))
            for agents in agent_counts:
                compiled = compile_peer(task_name, agents)
                designs.add(single_function_loops(compiled[0]))
                agent = peer_agents(task_name, 1)[0]
                group = group_size(agent, TASKS[task_name].dim, agents)
                compiles.append(f"- {task_name}, JAX peer, {plural(agents, 'agent')}: "
                                f"{compiled[-1]:.1f} s (jit: one compile per batch size; "
                                f"{block_length(agents):,} steps a call, groups of "
                                f"{plural(group, 'agent')})")
                lwrl = measure_lwrl(task_name, agents, args.seconds)
                peer = measure_peer(compiled, args.seconds)
                rows.append(f"| {task_name} | {agents} | {lwrl.rate:,.0f} | {peer.rate:,.0f} | "
                            f"x{lwrl.rate / peer.rate:.2f} | {1e9 * lwrl.cpu_per_step:,.0f} | "
                            f"{1e9 * peer.cpu_per_step:,.0f} | "
                            f"x{peer.cpu_per_step / lwrl.cpu_per_step:.2f} | "
                            f"{1e9 * bound:,.0f} | x{peer.cpu_per_step / bound:.2f} |")
                runs.append(f"- {task_name}, {plural(agents, 'agent')}: lwrl {agents} x "
                            f"{plural(lwrl.episodes, 'episode')}, {lwrl.steps:,} agent-steps in "
                            f"{lwrl.seconds:.2f} s; JAX peer {agents} x {peer.steps // agents:,} "
                            f"steps ({peer.episodes:,} episodes finished) in {peer.seconds:.2f} s")
        check_start = time.perf_counter()
        check = learning_check(check_agents, check_episodes) if args.learning_check else {}
        check_seconds = time.perf_counter() - check_start
    window = slice(max(0, check_episodes - 10), check_episodes)
    print("| task | agents | lwrl (agent-steps/s) | JAX peer (agent-steps/s) | lwrl / JAX "
          "| lwrl CPU ns per agent-step | JAX CPU ns per agent-step | JAX CPU / lwrl CPU "
          "| bound, ns per agent-step | JAX CPU / bound |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    print("\n".join(rows))
    print("\nThe bound: one core's least time for the learner's arithmetic of one agent-step "
          "(`benchmarks.arithmetic_bound`, its rates measured in this run). An implementation "
          "of the same arithmetic twice as fast as the peer in CPU time is possible only "
          "where the peer takes at least twice the bound (JAX CPU / bound >= x2).")
    if check:
        print(f"\nLearning check, the paper's best Mountain-Car agent ({check_agents} agents x "
              f"{check_episodes} episodes), mean ± standard error over agents of the steps per "
              f"episode:\n")
        print(f"| | episode 1 | episodes {window.start + 1}-{window.stop} |")
        print("|---|---:|---:|")
        for name, steps in check.items():
            print(f"| {name} | {steps_cell(steps[:, :1])} | {steps_cell(steps[:, window])} |")
    print("\n" + machine(f"{workers()} cores (lwrl's threads, agent.threads.workers()), JAX "
                         f"on {jax.default_backend()}", np, numba, jax))
    single = {True: "yes", False: "no (JAX had started before main set XLA_FLAGS)"}
    print(f"\nJAX peer: XLA_FLAGS={xla_flags!r}; its scans compiled as single functions: "
          f"{', '.join(single[d] for d in sorted(designs, reverse=True)) or '-'}.")
    print("\nCompile times (in no rate):")
    print("\n".join(compiles))
    print("\nRuns measured (each from zero weights):")
    print("\n".join(runs))
    print(f"\nTotal {time.perf_counter() - script_start:.1f} s, of which {check_seconds:.1f} s "
          "the learning check.")


if __name__ == "__main__":
    main()
