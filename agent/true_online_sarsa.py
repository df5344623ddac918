"""True online Sarsa(lambda) with dutch traces (van Seijen and Sutton 2014; van Seijen,
Mahmood, Pilarski, Machado and Sutton 2016, "True online temporal-difference learning",
JMLR 17(145); Sutton and Barto 2018, section 12.8, the box "True online Sarsa(lambda)"), for a batch of independent agents over the same features as the paper's
Sarsa(lambda) (`agent.linear`: NRBF or CMAC).

Linear in features x(s, a): the feature map's phi(s) in the column of action a. Per
episode z = 0, Q_old = 0 and x = x(S, A); per step, after R and S' and the epsilon-greedy A'
(x' = x(S', A'), and x' = 0 at a terminal state):

    Q  = w^T x                 Q' = w^T x'               delta = R + gamma Q' - Q
    z  = gamma lambda z + (1 - alpha gamma lambda z^T x) x          (the dutch trace)
    w  = w + alpha (delta + Q - Q_old) z - alpha (Q - Q_old) x
    Q_old = Q'                 x = x'

With exact arithmetic its weights equal those of the online lambda-return algorithm, the
forward view (van Seijen et al. 2016, Theorem 1); at lambda = 0 it is one-step Sarsa.
Unlike the paper's traces, the dutch trace needs its own step sizes: alpha enters the trace
itself, and alpha gamma lambda z^T x above 1 reverses the trace (SPEC.md, "Other learners").

As the paper's traces do (`agent.traces.FLUSH_THRESHOLD`), trace entries below 1e-100 are
set to 0, so that long-decayed traces do not end as subnormal numbers. Divergence (a TD
error that is NaN or infinite) freezes an agent, as it does Sarsa(lambda)'s.
"""

import collections
import dataclasses

import numpy as np
from numba.extending import register_jitable

from lwrl.agent.arithmetic import Count, Counts, nrbf_counts
from lwrl.agent.learner_contract import Learner
from lwrl.agent.linear import (LinearAgents, LinearSettings, action_value, advance, choose,
                               linear_arrays, linear_memory)
from lwrl.agent.traces import FLUSH_THRESHOLD
from lwrl.settings import setting

DEFAULT_ALPHA = 1.0
"""The default step size: within the range where every task learns (README, learners)."""

Arrays = collections.namedtuple(
    "Arrays", "weights traces phi slot action streams diverged q delta scratch "
              "alpha gamma lam epsilon features q_old")
"""As `agent.sarsa.Arrays`, with the dutch traces in `traces` and Q_old per agent."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class TrueOnlineSettings(LinearSettings):
    """True online Sarsa(lambda): its trace (dutch), step sizes and features (None: the
    task's default)."""

    trace: str = setting("dutch", choices=("dutch",), per_agent=True)
    """Trace rule: `dutch`, its only one."""
    alpha: float = setting(DEFAULT_ALPHA, per_agent=True)
    """Learning rate alpha > 0 (its own: the paper's alpha suits its traces, not dutch ones)."""

    def label(self) -> str:
        return f"true_online-{super().label()}"

    def describe(self, dim: int) -> str:
        return f"true online Sarsa(lambda), {super().describe(dim)}"


@register_jitable
def dutch_update_(z, w, phi, action, gamma_lambda, scale, step, correction):
    """The dutch trace and the weight update of one agent, in place:
    `z <- gamma lambda z + scale x` and `w <- w + step z - correction x`, with `x` the
    features `phi` `(N,)` in `action`'s row and 0 elsewhere (`scale = 1 - alpha gamma lambda
    z^T x`, `step = alpha (delta + Q - Q_old)`, `correction = alpha (Q - Q_old)`)."""
    for a in range(z.shape[0]):
        if a == action:
            for i in range(z.shape[1]):
                value = gamma_lambda * z[a, i] + scale * phi[i]
                value = value if np.abs(value) >= FLUSH_THRESHOLD else 0.0
                z[a, i] = value
                w[a, i] += step * value - correction * phi[i]
        else:
            for i in range(z.shape[1]):
                value = gamma_lambda * z[a, i]
                value = value if np.abs(value) >= FLUSH_THRESHOLD else 0.0
                z[a, i] = value
                w[a, i] += step * value


@register_jitable
def agent_step(b, first, reward, discount, observation, learn, greedy, arrays):
    """Agent b sees `observation`; returns its next action (`Learner.step`): the module's
    update of the transition from its previous (state, action), then epsilon-greedy on Q."""
    phi_t, q_t, a_t, bootstrap = choose(b, first, discount, observation, greedy, arrays)
    if first:
        arrays.traces[b][:] = 0.0
        arrays.q_old[b] = 0.0
    elif learn and not arrays.diverged[b]:
        w, z = arrays.weights[b], arrays.traces[b]
        a_tm1 = arrays.action[b]
        x = arrays.phi[b, arrays.slot[b]]
        q = action_value(w, x, a_tm1)
        q_next = q_t[a_t] if bootstrap else 0.0
        gamma = arrays.gamma[b]
        delta = reward + gamma * discount * q_next - q
        arrays.delta[b] = delta
        if not np.isfinite(delta):
            arrays.diverged[b] = True
        else:
            alpha, gamma_lambda = arrays.alpha[b], gamma * arrays.lam[b]
            q_old = arrays.q_old[b]
            dutch_update_(z, w, x, a_tm1, gamma_lambda,
                          1.0 - alpha * gamma_lambda * action_value(z, x, a_tm1),
                          alpha * (delta + q - q_old), alpha * (q - q_old))
            arrays.q_old[b] = q_next
    advance(b, a_t, arrays)
    return a_t


class TrueOnlineAgents(LinearAgents):
    """B independent true online Sarsa(lambda) agents sharing one feature map and action
    count; `alpha`, `lam`, `epsilon` and `gamma` are scalars or one value per agent."""

    def __init__(self, features, num_actions: int, *, alpha, lam, epsilon, seeds, gamma=1.0,
                 settings=()):
        self.features = features
        self.dim = features.dim
        self.settings = tuple(settings)
        arrays = linear_arrays(features, num_actions, alpha=alpha, lam=lam, epsilon=epsilon,
                               gamma=gamma, seeds=seeds)
        self.arrays = Arrays(**arrays, q_old=np.zeros(len(arrays["slot"])))


def make(settings, task, seeds) -> TrueOnlineAgents:
    """The agents of `settings` (one `TrueOnlineSettings` per agent) on `task`."""
    base = settings[0]
    return TrueOnlineAgents(base.feature_map(task.ranges.low, task.ranges.high), task.action.n,
                            alpha=[s.alpha for s in settings], lam=[s.lam for s in settings],
                            epsilon=[s.epsilon for s in settings], gamma=base.gamma,
                            seeds=seeds, settings=settings)


def load(document, arrays) -> TrueOnlineAgents:
    """The agents `TrueOnlineAgents.saved` wrote."""
    return TrueOnlineAgents.loaded(document, arrays)


def true_online_update(dim: int, n: int, actions: int) -> Count:
    """The multiply-adds of `agent_step`'s update of one transition over an NRBF grid of
    N = n^d features and A actions (`dutch_update_`): N for Q(s, a), N for z^T x, and over
    the A N traces and weights two multiply-adds each in the action's row (z, w) and one
    each elsewhere, plus N for the correction in the action's row: (2 A + 4) N."""
    return Count((2 * actions + 4) * n ** dim)


def arithmetic(settings, task, steps=None) -> Counts:
    """Its counted arithmetic (`Learner.arithmetic`): an NRBF grid's greedy decision and, at
    every step, `true_online_update` (`agent.arithmetic.nrbf_counts`; CMAC features not
    counted)."""
    return nrbf_counts(settings, len(task.state_names), task.action.n, true_online_update)


LEARNER = Learner(
    name="true_online_sarsa", title="true online Sarsa(lambda) with dutch traces",
    source="van Seijen et al. (2016), JMLR 17(145); Sutton and Barto (2018), section 12.8",
    settings=TrueOnlineSettings, make=make, load=load, memory=linear_memory, step=agent_step,
    arithmetic=arithmetic)
"""The `true_online_sarsa` learner as the registry holds it (`agent.LEARNERS`)."""
TrueOnlineAgents.learner = LEARNER
