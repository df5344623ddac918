"""How fast the paper's agent could step on this machine: an arithmetic model of one agent-step.

One agent-step of gradient-descent Sarsa(lambda) over NRBF features (Främling 2008, eq. 1,
2 or 6, 8 and 9), as lwrl's learner computes it (`agent/sarsa.py`), for d state variables,
n centroids per dimension, N = n^d features and A actions, costs at least:

- **exponentials**: d n (eq. 8 factorised per dimension, `agent/nrbf.py`);
- **multiply-adds**: n + n^2 + ... + n^d for the outer product of the per-dimension factors
  (the feature vector, eq. 9), A N for Q(s', .) (eq. 9, every action, for the epsilon-greedy
  choice), N for Q(s, a) under the current weights (the TD error, eq. 1), A N for the trace
  decay (gamma lambda e, eq. 2 or 6) and A N for the weight update (w + alpha delta e, eq. 1):
  `sum_m n^m + (3 A + 1) N` (these two are the learner's own counts of a learning step,
  `agent.arithmetic.nrbf_decision` and `agent.sarsa.sarsa_update`);
- **memory traffic** (bytes, float64): the weights read for Q(s', .) and Q(s, a) (A N + N)
  with the features (2 N), the traces and weights read and written by the update (4 A N) with
  the features (N), and the feature vector written (N): `8 (5 A N + 5 N)`.

The plant's step (a few dozen flops) and the random draws are left out: the model bounds
the learner's arithmetic only.

The machine's rates for each are measured in the same run (`measure_rates`), by numba
loops over arrays sized like the agent's: `exp` over d n values; a dot product of two
A N arrays (fastmath, so the compiler may vectorise and reorder it, which lwrl's fixed
order of additions does not allow); and the fused trace-and-weight update
(`e <- c e + b; w <- w + s e`, the values kept near 1) over two A N arrays, whose bytes (32 per element) over its time
is the bandwidth at the agent's working-set size. Each is the fastest of several repeats.
One core's bound on the time of an agent-step is

    t = max(exponentials / R_exp + multiply-adds / R_mac, bytes / R_mem)

(the compute and the memory traffic may overlap; the exponentials and the multiply-adds
share the floating-point units), so 1 / t agent-steps per second on one core bounds one
agent, and `cores / t` a batch spread over `cores` threads. A measured rate's fraction of
its bound says how far the implementation is from the machine's arithmetic limit; on a
machine other jobs keep busy the fraction understates it.
"""

import dataclasses
import time

import numba
import numpy as np

from lwrl.agent.arithmetic import nrbf_decision
from lwrl.agent.sarsa import sarsa_update
from lwrl.runners.config import RunConfig

REPEATS = 25
"""Timed repeats of each micro-benchmark; the fastest counts."""
TARGET_SECONDS = 0.002
"""About how long one repeat lasts: short repeats, so that some fall between the other
jobs' time slices on a busy machine."""


@dataclasses.dataclass(frozen=True)
class StepCounts:
    """What one agent-step of a task's paper agent costs in the model (module docstring)."""

    dim: int
    n: int
    actions: int
    exponentials: int
    multiply_adds: int
    bytes: int

    @property
    def features(self) -> int:
        return self.n ** self.dim


def step_counts(dim: int, n: int, actions: int) -> StepCounts:
    """The model's counts for NRBF features over `dim` variables with `n` centroids each
    and `actions` actions: the exponentials and multiply-adds of the learner's own count of
    a learning step (`agent.sarsa.arithmetic`: the greedy decision's, and the update's), and
    the bytes of the memory traffic."""
    features = n ** dim
    count = nrbf_decision(dim, n, actions) + sarsa_update(dim, n, actions)
    return StepCounts(dim, n, actions, exponentials=int(count.exps),
                      multiply_adds=int(count.macs),
                      bytes=8 * (5 * actions * features + 5 * features))


def task_counts(task: str) -> StepCounts:
    """The counts of `task`'s paper agent (`RunConfig` defaults), from its feature sizes."""
    config = RunConfig(task=task)
    features = config.settings.feature_map(config.task_spec.ranges.low, config.task_spec.ranges.high)
    if not hasattr(features, "r2"):
        raise ValueError(f"the model covers NRBF features; {task}'s paper agent has "
                         f"{type(features).__name__}")
    return step_counts(features.dim, features.n, config.task_spec.action.n)


@numba.njit(cache=False)
def _exps(values, rounds):
    total = 0.0
    for _ in range(rounds):
        for i in range(values.shape[0]):
            total += np.exp(-values[i])
        values[0] += 1e-300  # keeps the rounds from being folded into one
    return total


@numba.njit(fastmath=True, cache=False)
def _dots(a, b, rounds):
    total = 0.0
    for _ in range(rounds):
        s = 0.0
        for i in range(a.shape[0]):
            s += a[i] * b[i]
        total += s
        a[0] += 1e-300
    return total


@numba.njit(cache=False)
def _updates(e, w, rounds):
    for _ in range(rounds):
        for i in range(e.shape[0]):
            e[i] = 0.9 * e[i] + 0.1  # stays near 1: no subnormal numbers
            w[i] += 1e-3 * e[i]


def _fastest(kernel, size: int, *arrays) -> float:
    """Seconds per element-pass of `kernel(*arrays, rounds)`, the fastest of `REPEATS`."""
    kernel(*arrays, 1)  # compiles
    rounds = 1
    while True:
        start = time.perf_counter()
        kernel(*arrays, rounds)
        elapsed = time.perf_counter() - start
        if elapsed >= TARGET_SECONDS / 4:
            break
        rounds *= 4
    best = elapsed
    for _ in range(REPEATS - 1):
        start = time.perf_counter()
        kernel(*arrays, rounds)
        best = min(best, time.perf_counter() - start)
    return best / (rounds * size)


@dataclasses.dataclass(frozen=True)
class Rates:
    """One core's measured rates: exponentials, multiply-adds and bytes per second."""

    exp: float
    mac: float
    memory: float


def measure_rates(counts: StepCounts) -> Rates:
    """The machine's rates at the sizes of `counts`' agent (module docstring)."""
    rng = np.random.default_rng(0)
    exps = counts.dim * counts.n
    size = counts.actions * counts.features
    exp_seconds = _fastest(_exps, exps, rng.uniform(0.0, 5.0, exps))
    mac_seconds = _fastest(_dots, size, rng.uniform(size=size), rng.uniform(size=size))
    update_seconds = _fastest(_updates, size, rng.uniform(size=size), rng.uniform(size=size))
    return Rates(exp=1.0 / exp_seconds, mac=1.0 / mac_seconds, memory=32.0 / update_seconds)


def bound_seconds(counts: StepCounts, rates: Rates) -> float:
    """One core's lower bound on the seconds of one agent-step."""
    compute = counts.exponentials / rates.exp + counts.multiply_adds / rates.mac
    return max(compute, counts.bytes / rates.memory)
