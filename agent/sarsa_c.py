"""Sarsa(lambda) over NRBF features as C99 that learns on a device: its `LearnerForm`.

The template `export/templates/learner/lwrl_learner.c.in` computes what `agent.sarsa`'s
`agent_step` computes, operation for operation and in the same order (its comment says
which): the NRBF features of `agent.nrbf` with the clamp `clamp_margin` and the underflow
guard, Q in `agent.linear.action_value`'s order, `agent.policy.epsilon_greedy` on the
stream of `agent.streams`, the TD error with the weights before the update, and the trace
rule of `agent.traces.update_` with its flush threshold. This module gives the template its
values from one agent of a `BatchedSarsa`: its features, step sizes, trace rule, weights and
stream state.

Two of the learner's three traces: replacing (eq. 6) and accumulating (eq. 2). The third,
replacing with reset (eq. 5), is the CMAC baseline's, and CMAC features have no C form.

In float the flush threshold `FLUSH_THRESHOLD` (1e-100) is below float's range; float's
smallest normal number (1.2e-38) takes its place, which keeps the traces out of subnormal
arithmetic as the threshold does in double.
"""

import numpy as np

from lwrl.agent.learner_contract import LearnerForm
from lwrl.agent.linear import nrbf_check
from lwrl.agent.nrbf import NRBF, centroid, clamp_margin
from lwrl.agent.streams import SPLITMIX64
from lwrl.agent.traces import FLUSH_THRESHOLD, TRACES

TRACE_RULES = {
    "replacing": ("decayed > phi[i] ? decayed : phi[i]",
                  "replacing (eq. 6), e = max(gamma lambda e, phibar) for the taken action; "
                  "the other actions' traces only decay"),
    "accumulating": ("decayed + phi[i]",
                     "accumulating (eq. 2), e = gamma lambda e + phibar for the taken action; "
                     "the other actions' traces decay"),
}
"""The traces the C learner has: the C expression of the taken action's new trace from
`decayed` (gamma lambda e) and the feature `phi[i]`, and what it is in words."""
STATE_BYTES = 8 + 3 * 4
"""The C learner's integers: its stream's 64-bit state, and the slot, action and divergence
flag (ints)."""


def flush_threshold(real) -> float:
    """The traces' flush threshold in the NumPy type `real`: `FLUSH_THRESHOLD`, or the
    type's smallest normal number where that is larger."""
    return max(FLUSH_THRESHOLD, float(np.finfo(real).tiny))


def learner_form(agents, b: int) -> LearnerForm:
    """Agent b of `agents` (a `BatchedSarsa`) as the C learner's template takes it; a
    one-line ValueError for CMAC features or the trace with reset."""
    features = agents.features
    if not isinstance(features, NRBF):
        raise ValueError(f"only NRBF agents can learn in C; these have "
                         f"{type(features).__name__} features")
    arrays = agents.arrays
    trace = TRACES[int(arrays.trace[b])]
    if trace not in TRACE_RULES:
        raise ValueError(f"the C learner has {' and '.join(TRACE_RULES)} traces; agent {b} "
                         f"has {trace}")
    alpha, lam, epsilon, gamma = (float(values[b]) for values in
                                  (arrays.alpha, arrays.lam, arrays.epsilon, arrays.gamma))
    n, dim, neurons = features.n, features.dim, features.num_features
    actions = agents.action_space.n
    margin = clamp_margin(n, features.r2)
    grid = " x ".join([str(n)] * dim)
    rule, rule_text = TRACE_RULES[trace]

    def values(real) -> dict:
        flush = flush_threshold(real)
        return {"weights": arrays.weights[b], "seed": int(arrays.streams[b]),
                "n": n, "neurons": neurons,
                "centroids": centroid(np.arange(n), n), "r2": features.r2,
                "s_min": -margin, "s_max": 1.0 + margin, "alpha": alpha, "gamma": gamma,
                "gamma_lambda": gamma * lam, "flush": flush,
                "flush_text": f"{flush:g}", "epsilon": repr(epsilon),
                "trace_rule": rule, "trace_text": rule_text}

    return LearnerForm(
        template="learner/lwrl_learner", values=values,
        ram={"weights": (actions * neurons, 0), "traces": (actions * neurons, 0),
             "features": (2 * neurons, 0), "scratch": (dim * n + actions, 0),
             "state": (0, STATE_BYTES)},
        ranges=(features.low, features.high), stream=SPLITMIX64,
        check=lambda real: nrbf_check(features, real, alpha=alpha),
        summary=(f"{grid} grid x {actions} actions, {trace} traces, alpha {alpha:g}, lambda "
                 f"{lam:g}, epsilon {epsilon:g}, gamma {gamma:g}, r^2 {features.r2:g}"),
        name=f"the {grid} grid's learner", smaller="a coarser grid (--n)")
