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

One learner over two feature maps (`agent.linear`: the paper's NRBF network, or the CMAC
baseline's tile coding): the update rule is the same, and the paper's Fig. 2 compares the
two feature maps under it. The per-agent step is numba-jitable (`agent_step`), so compiled
loops that also step the plant call the very same code as `BatchedSarsa.step`; an agent
with NRBF features and replacing or accumulating traces is also C99 that goes on learning
on a device, with the same arithmetic (`agent.sarsa_c`, `BatchedSarsa.learner_form`).
"""

import collections
import dataclasses

import numpy as np
from numba.extending import register_jitable

from lwrl.agent import sarsa_c
from lwrl.agent.arithmetic import Count, Counts, nrbf_counts
from lwrl.agent.learner_contract import Learner, LearnerForm
from lwrl.agent.linear import (LinearAgents, LinearSettings, action_value, advance, choose,
                               linear_arrays, linear_memory)
from lwrl.agent.traces import TRACES, update_

Arrays = collections.namedtuple(
    "Arrays", "weights traces phi slot action streams diverged q delta scratch "
              "alpha gamma lam epsilon features trace")
"""One batch's learning state, scratch space and hyper-parameters, each with a leading axis
B, and its feature map as compiled code sees it (`features`, an `agent.linear.FeatureSpec`).
Weights and traces are stored action-major, `(B, A, N)`; `phi` `(B, 2, N)` holds the
features of the last two observations, the latest in `phi[b, slot[b]]`; `q[b]` holds Q at
the latest observation and `delta[b]` the TD error of the latest update (NaN if it made
none); `alpha`, `gamma`, `lam`, `epsilon` and `trace` (an index of `TRACES`) are per agent."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class SarsaSettings(LinearSettings):
    """Gradient-descent Sarsa(lambda): its trace rule and step sizes, then its features."""


@register_jitable
def agent_step(b, first, reward, discount, observation, learn, greedy, arrays):
    """Agent b sees `observation`; returns its next action (`Learner.step`).

    `first`: the observation starts an episode (traces reset, no update). Otherwise it ends
    the transition from the agent's previous (state, action) with `reward` and `discount`
    (0 at a terminal state, where no action is drawn and 0 is returned). `learn=False`
    acts without updating; `greedy=True` acts with epsilon 0 (evaluation).
    """
    phi_t, q_t, a_t, bootstrap = choose(b, first, discount, observation, greedy, arrays)
    if first:
        arrays.traces[b][:] = 0.0
    elif learn and not arrays.diverged[b]:
        w = arrays.weights[b]
        a_tm1 = arrays.action[b]
        phi_tm1 = arrays.phi[b, arrays.slot[b]]
        delta = reward - action_value(w, phi_tm1, a_tm1)
        if bootstrap:
            delta += arrays.gamma[b] * discount * q_t[a_t]
        arrays.delta[b] = delta
        if not np.isfinite(delta):
            arrays.diverged[b] = True
        else:
            update_(arrays.trace[b], arrays.traces[b], w, phi_tm1, a_tm1,
                    arrays.gamma[b] * arrays.lam[b], arrays.alpha[b] * delta)
    advance(b, a_t, arrays)
    return a_t


class BatchedSarsa(LinearAgents):
    """B independent Sarsa(lambda) agents sharing one feature map and action count.

    `alpha`, `lam`, `epsilon`, `gamma` and `trace` are scalars or one value per agent;
    `seeds` (one non-negative integer per agent) fixes B and each agent's random stream.
    For a CMAC, alpha is multiplied by its `alpha_scale`. `settings`: the agents'
    `SarsaSettings`, where they were made from settings (`make`).
    """

    def __init__(self, features, num_actions: int, *, alpha, lam, epsilon, trace, seeds,
                 gamma=1.0, settings=()):
        self.features = features
        self.dim = features.dim
        self.settings = tuple(settings)
        arrays = linear_arrays(features, num_actions, alpha=alpha, lam=lam, epsilon=epsilon,
                               gamma=gamma, seeds=seeds)
        traces = [str(t) for t in np.broadcast_to(np.asarray(trace), arrays["slot"].shape)]
        unknown = [t for t in traces if t not in TRACES]
        if unknown:
            raise ValueError(f"unknown trace {unknown[0]!r}; allowed: {', '.join(TRACES)}")
        self.arrays = Arrays(**arrays, trace=np.array([TRACES.index(t) for t in traces],
                                                      dtype=np.int64))

    def saved(self) -> tuple[dict, dict]:
        document, arrays = super().saved()
        return {**document, "trace": [TRACES[t] for t in self.arrays.trace]}, arrays

    def learner_form(self, b: int) -> LearnerForm:
        """Agent b as the C learner (`agent.sarsa_c`): NRBF features, replacing or
        accumulating traces."""
        return sarsa_c.learner_form(self, b)


def make(settings, task, seeds) -> BatchedSarsa:
    """The agents of `settings` (one `SarsaSettings` per agent, equal but in the per-agent
    fields) on `task` (`TaskSpec`), with zero weights."""
    base = settings[0]
    return BatchedSarsa(base.feature_map(task.ranges.low, task.ranges.high), task.action.n,
                        alpha=[s.alpha for s in settings], lam=[s.lam for s in settings],
                        epsilon=[s.epsilon for s in settings],
                        trace=[s.trace for s in settings], gamma=base.gamma, seeds=seeds,
                        settings=settings)


def load(document, arrays) -> BatchedSarsa:
    """The agents `BatchedSarsa.saved` wrote (a ValueError if its parts do not fit)."""
    return BatchedSarsa.loaded(document, arrays, trace=document["trace"])


def sarsa_update(dim: int, n: int, actions: int) -> Count:
    """The multiply-adds of `agent_step`'s update of one transition over an NRBF grid of
    N = n^d features and A actions (eq. 1 with the traces of eq. 2 or 6): N for Q(s, a)
    under the current weights, A N for the traces' decay and A N for the weights' update."""
    return Count((2 * actions + 1) * n ** dim)


def arithmetic(settings, task, steps=None) -> Counts:
    """Its counted arithmetic (`Learner.arithmetic`): an NRBF grid's greedy decision and, at
    every step, `sarsa_update` (`agent.arithmetic.nrbf_counts`; CMAC features not counted)."""
    return nrbf_counts(settings, len(task.state_names), task.action.n, sarsa_update)


LEARNER = Learner(
    name="sarsa", title="gradient-descent Sarsa(lambda) over NRBF or CMAC features",
    source="Främling (2008), eq. 1, 2, 5, 6 and 9; Singh and Sutton (1996) for the CMAC",
    settings=SarsaSettings, make=make, load=load, memory=linear_memory, step=agent_step,
    arithmetic=arithmetic)
"""The `sarsa` learner as the registry holds it (`agent.LEARNERS`)."""
BatchedSarsa.learner = LEARNER
