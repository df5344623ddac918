"""Gradient-descent Sarsa(lambda) (Främling 2008, eq. 1) for a batch of independent agents.

Each of B agents has its own weights `(N, A)` (zero at the start of a run, so every Q is 0),
traces `(N, A)` (zero at the start of every episode), hyper-parameters (alpha, lambda,
epsilon, gamma, trace rule) and random stream, so a whole alpha x lambda x seed grid is one
call over arrays, and an agent's numbers do not depend on the batch it runs in.

One transition of agent b, from (s, a) through reward r and discount d to s' (eq. 1):

    a'    = epsilon-greedy on Q(s', .) (not drawn when s' is terminal, d = 0)
    delta = r + gamma d Q(s', a') - Q(s, a)          (Q(terminal, .) = 0)
    e     = trace rule(e, grad Q(s, a) = phibar(s) in column a, gamma lambda)   (eq. 2, 5, 6)
    w     = w + alpha delta e

with Q(s, a) = sum_i w_ia phibar_i(s) (eq. 9) and every term computed with the weights before
the update. A delta that is NaN or infinite (accumulating traces with a large alpha do this)
marks the agent diverged and freezes its weights.

The per-agent step is numba-jitable (`agent_step`) so compiled loops that also step the
plant call the very same code as `BatchedSarsa.step`.
"""

import collections

import numpy as np
from numba.extending import register_jitable

from lwrl.agent.cmac import CMAC, cmac_features_into
from lwrl.agent.nrbf import NRBF, nrbf_features_into
from lwrl.agent.policy import epsilon_greedy
from lwrl.agent.streams import seed_streams
from lwrl.agent.threads import run_in_chunks
from lwrl.agent.traces import TRACES, update_
from lwrl.kernels import kernel

_NRBF, _CMAC = 0, 1

FeatureSpec = collections.namedtuple("FeatureSpec", "kind low high n r2 tilings")
"""A feature map as compiled code sees it (`n` is the CMAC's intervals)."""
Hyper = collections.namedtuple("Hyper", "alpha gamma lam epsilon trace")
"""Per-agent hyper-parameters, each an array `(B,)`."""
Memory = collections.namedtuple("Memory", "weights traces phi slot action streams diverged q delta scratch")
"""Per-agent learning state and scratch space, each with a leading axis B; weights and
traces are stored action-major, `(B, A, N)`; `phi` `(B, 2, N)` holds the features of the
last two observations, the latest in `phi[b, slot[b]]`; `q[b]` holds Q at the latest
observation and `delta[b]` the TD error of the latest update (NaN if it made none)."""


def feature_spec(features) -> FeatureSpec:
    """The compiled-code view of an `NRBF` or `CMAC`."""
    low, high = np.array(features.low), np.array(features.high)
    if isinstance(features, NRBF):
        return FeatureSpec(_NRBF, low, high, features.n, features.r2, 0)
    if isinstance(features, CMAC):
        return FeatureSpec(_CMAC, low, high, features.intervals, 0.0, features.tilings)
    raise ValueError(f"features must be an NRBF or a CMAC; got {type(features).__name__}")


@register_jitable
def features_into(spec, state, out, scratch):
    """The feature vector of one state, written into `out`."""
    if spec.kind == _NRBF:
        nrbf_features_into(state, spec.low, spec.high, spec.n, spec.r2, out, scratch)
    else:
        cmac_features_into(state, spec.low, spec.high, spec.n, spec.tilings, out)


@register_jitable
def action_value(w, phi, a):
    """Q(s, a) = sum_i w_ia phibar_i(s) (eq. 9), for weights `w` stored `(A, N)`.

    Summed in four interleaved partial sums, a fixed order that lets the CPU overlap the
    additions (a single running sum is 3 to 4 times slower), combined pairwise at the end.
    """
    n = phi.shape[0]
    s0, s1, s2, s3 = 0.0, 0.0, 0.0, 0.0
    for i in range(0, n - n % 4, 4):
        s0 += w[a, i] * phi[i]
        s1 += w[a, i + 1] * phi[i + 1]
        s2 += w[a, i + 2] * phi[i + 2]
        s3 += w[a, i + 3] * phi[i + 3]
    for i in range(n - n % 4, n):
        s0 += w[a, i] * phi[i]
    return (s0 + s1) + (s2 + s3)


@register_jitable
def agent_step(b, first, reward, discount, observation, learn, memory, hyper, spec):
    """Agent b sees `observation`; returns its next action.

    `first`: the observation starts an episode (traces reset, no update). Otherwise it ends
    the transition from the agent's previous (state, action) with `reward` and `discount`
    (0 at a terminal state, where no action is drawn and 0 is returned). `learn=False`
    acts without updating (evaluation).
    """
    phi_t = memory.phi[b, 1 - memory.slot[b]]
    features_into(spec, observation, phi_t, memory.scratch[b])
    w = memory.weights[b]
    q_t = memory.q[b]
    for a in range(q_t.shape[0]):
        q_t[a] = action_value(w, phi_t, a)
    bootstrap = first or discount > 0.0
    a_t = epsilon_greedy(q_t, hyper.epsilon[b], memory.streams, b) if bootstrap else 0
    memory.delta[b] = np.nan
    if first:
        memory.traces[b][:] = 0.0
    elif learn and not memory.diverged[b]:
        a_tm1 = memory.action[b]
        phi_tm1 = memory.phi[b, memory.slot[b]]
        delta = reward - action_value(w, phi_tm1, a_tm1)
        if bootstrap:
            delta += hyper.gamma[b] * discount * q_t[a_t]
        memory.delta[b] = delta
        if not np.isfinite(delta):
            memory.diverged[b] = True
        else:
            update_(hyper.trace[b], memory.traces[b], w, phi_tm1, a_tm1,
                    hyper.gamma[b] * hyper.lam[b], hyper.alpha[b] * delta)
    memory.slot[b] = 1 - memory.slot[b]
    memory.action[b] = a_t
    return a_t


def _batch_step(start, stop, first, reward, discount, observation, active, learn, memory, hyper,
                spec, actions):
    """`agent_step` for agents `start..stop-1` that are `active`: the `BATCH_STEP` kernel."""
    for b in range(start, stop):
        if active[b]:
            actions[b] = agent_step(b, first[b], reward[b], discount[b], observation[b], learn,
                                    memory, hyper, spec)


BATCH_STEP = kernel("agent_batch_step", _batch_step)


def _per_agent(name, value, batch_size, low, high, closed_low=True):
    """`value` broadcast to `(batch_size,)` float64, every entry checked against its range."""
    array = np.broadcast_to(np.asarray(value, dtype=np.float64), (batch_size,)).copy()
    above_low = array >= low if closed_low else array > low
    if not np.all(above_low & (array <= high)):
        bad = array[~(above_low & (array <= high))][0]
        interval = f"{'[' if closed_low else '('}{low}, {high}]"
        raise ValueError(f"{name} must be in {interval}; got {bad}")
    return array


class BatchedSarsa:
    """B independent Sarsa(lambda) agents sharing one feature map and action count.

    `alpha`, `lam`, `epsilon`, `gamma` and `trace` are scalars or one value per agent;
    `seeds` (one non-negative integer per agent) fixes B and each agent's random stream.
    For a CMAC, alpha is multiplied by its `alpha_scale`.
    """

    def __init__(self, features, num_actions: int, *, alpha, lam, epsilon, trace, seeds,
                 gamma=1.0):
        self.features = features
        self.spec = feature_spec(features)
        streams = seed_streams(seeds)
        batch = len(streams)
        if isinstance(num_actions, bool) or not isinstance(num_actions, (int, np.integer)) or num_actions < 1:
            raise ValueError(f"num_actions must be an integer >= 1; got {num_actions!r}")
        traces = [str(t) for t in np.broadcast_to(np.asarray(trace), (batch,))]
        unknown = [t for t in traces if t not in TRACES]
        if unknown:
            raise ValueError(f"unknown trace {unknown[0]!r}; allowed: {', '.join(TRACES)}")
        alpha = _per_agent("alpha", alpha, batch, 0.0, np.inf, closed_low=False)
        self.hyper = Hyper(
            alpha=alpha * features.alpha_scale,
            gamma=_per_agent("gamma", gamma, batch, 0.0, 1.0),
            lam=_per_agent("lambda", lam, batch, 0.0, 1.0),
            epsilon=_per_agent("epsilon", epsilon, batch, 0.0, 1.0),
            trace=np.array([TRACES.index(t) for t in traces], dtype=np.int64),
        )
        n_features = features.num_features
        scratch_width = features.n if isinstance(features, NRBF) else 1
        self.memory = Memory(
            weights=np.zeros((batch, num_actions, n_features)),
            traces=np.zeros((batch, num_actions, n_features)),
            phi=np.zeros((batch, 2, n_features)),
            slot=np.zeros(batch, dtype=np.int64),
            action=np.zeros(batch, dtype=np.int64),
            streams=streams,
            diverged=np.zeros(batch, dtype=bool),
            q=np.zeros((batch, num_actions)),
            delta=np.full(batch, np.nan),
            scratch=np.zeros((batch, features.dim, scratch_width)),
        )

    @property
    def batch_size(self) -> int:
        return len(self.memory.streams)

    @property
    def num_actions(self) -> int:
        return self.memory.weights.shape[1]

    @property
    def weights(self) -> np.ndarray:
        """The weights w_ia as `(B, N, A)` (a view: it follows the agents as they learn)."""
        return self.memory.weights.transpose(0, 2, 1)

    @property
    def diverged(self) -> np.ndarray:
        """True for agents whose update went NaN or infinite; their weights are frozen."""
        return self.memory.diverged

    def step(self, first, reward, discount, observation, active=None, learn=True) -> np.ndarray:
        """Feed each agent its time step (arrays with a leading axis B); return the actions.

        `first`: bool, the observation starts an episode; `reward`, `discount`: of the
        transition into the observation (ignored where `first`); `observation` `(B, d)`.
        Agents where `active` is False are left untouched (their action is 0).
        """
        batch = self.batch_size
        observation = np.ascontiguousarray(observation, dtype=np.float64)
        if observation.shape != (batch, self.features.dim):
            raise ValueError(f"observation must have shape ({batch}, {self.features.dim}); "
                             f"got {observation.shape}")
        active = np.ones(batch, dtype=bool) if active is None else np.asarray(active, dtype=bool)
        actions = np.zeros(batch, dtype=np.int64)
        run_in_chunks(BATCH_STEP, batch, np.asarray(first, dtype=bool),
                      np.asarray(reward, dtype=np.float64), np.asarray(discount, dtype=np.float64),
                      observation, active, bool(learn), self.memory, self.hyper, self.spec, actions)
        return actions

    def q_values(self, states) -> np.ndarray:
        """Q `(B, ..., A)` of every agent at states `(..., d)` (task units)."""
        phi = self.features.features(states)
        return np.einsum("...n,ban->b...a", phi, self.memory.weights)
