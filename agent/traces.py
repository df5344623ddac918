"""Eligibility traces of gradient-descent Sarsa(lambda), Främling (2008), section 2.

One agent's traces `e` have shape `(A, N)`: one per weight `w_ia` of the network (neuron i,
action a), stored action-major so that each action's row is contiguous. The gradient of `Q(s, a) = sum_i w_ia phibar_i` (eq. 9) with respect to the
weights is `phibar` in the taken action's column and 0 elsewhere (SPEC.md, "Gradient"), so
the rules read the features `phi` `(N,)` and the taken `action` instead of a gradient array.

The rules, for one weight, with `decayed = gamma lambda e`:

- accumulating (eq. 2): `e <- decayed + grad`;
- replacing (eq. 6): `e <- max(decayed, grad)`; the other actions' traces only decay (the
  paper's "not resetting the traces of unused actions");
- replacing with reset (eq. 5, Singh and Sutton's, for binary CMAC features): as eq. 6 for
  the taken action, and 0 for the other actions of the active features.

`update_` applies a rule and the weight update of eq. 1 in one pass over the arrays, in
place: it is the inner loop of the learner, run inside numba-compiled code.
"""

import numpy as np
from numba.extending import register_jitable

TRACES = ("replacing", "accumulating", "replacing_reset")
"""Trace rules by name; `update_` takes the index of one."""
REPLACING, ACCUMULATING, REPLACING_RESET = range(3)
FLUSH_THRESHOLD = 1e-100
"""Traces below this magnitude are set to 0."""


@register_jitable
def accumulate(decayed, gradient):
    """Eq. 2 for one weight: the decayed trace plus the gradient."""
    return decayed + gradient


@register_jitable
def replace(decayed, gradient):
    """Eq. 6 for one weight: the larger of the decayed trace and the gradient."""
    return max(decayed, gradient)


@register_jitable
def _check(e, w, phi, action):
    """Raise ValueError unless `e` and `w` are `(A, N)`, `phi` is `(N,)`, `0 <= action < A`."""
    if e.ndim != 2 or phi.ndim != 1 or phi.shape[0] != e.shape[1] or w.shape != e.shape:
        raise ValueError("traces e and weights w must have shape (A, N) and features phi shape (N,)")
    if action < 0 or action >= e.shape[0]:
        raise ValueError("action must be an index in [0, A) for traces e of shape (A, N)")


@register_jitable
def _store(e, w, a, i, value, step):
    """Set trace (a, i) to `value` (0 if below FLUSH_THRESHOLD) and add `step` times it to
    the weight."""
    value = value if np.abs(value) >= FLUSH_THRESHOLD else 0.0
    e[a, i] = value
    w[a, i] += step * value


@register_jitable
def update_(rule, e, w, phi, action, gamma_lambda, step):
    """One update of one agent, in place: traces by `rule`, then `w <- w + step e` (eq. 1).

    `rule`: REPLACING, ACCUMULATING or REPLACING_RESET; `step`: alpha times the TD error
    (0 updates the traces only). Traces below FLUSH_THRESHOLD are set to 0 on the way: a
    trace decayed by gamma lambda each step otherwise ends, after a few thousand steps, as a
    subnormal number (below 2.2e-308), and arithmetic on subnormals is 15 to 100 times
    slower on common CPUs, a cost every later pass would pay. Entries that small change no
    weight measurably. Each action's row is one branch-free loop, which compilers vectorise.
    """
    _check(e, w, phi, action)
    for a in range(e.shape[0]):
        if a == action and rule == ACCUMULATING:
            for i in range(e.shape[1]):
                _store(e, w, a, i, accumulate(gamma_lambda * e[a, i], phi[i]), step)
        elif a == action:
            for i in range(e.shape[1]):
                _store(e, w, a, i, replace(gamma_lambda * e[a, i], phi[i]), step)
        elif rule == REPLACING_RESET:
            for i in range(e.shape[1]):
                _store(e, w, a, i, 0.0 if phi[i] > 0.0 else gamma_lambda * e[a, i], step)
        else:
            for i in range(e.shape[1]):
                _store(e, w, a, i, gamma_lambda * e[a, i], step)
