"""Eligibility traces of gradient-descent Sarsa(lambda), Främling (2008), section 2.

One agent's traces `e` have shape `(N, A)`: one per weight `w_ia` of the NRBF network
(neuron i, action a). The gradient of `Q(s, a) = sum_i w_ia phibar_i` (eq. 9) with respect
to the weights is `phibar` in the taken action's column and 0 elsewhere (SPEC.md,
"Gradient"), so each rule below reads the features `phi` `(N,)` and the taken `action`
instead of a gradient array.

Each function updates `e` in place (the trailing `_` says so) and returns None: inside
numba-compiled loops this allocates nothing. Otherwise they are pure: the new `e` depends
only on the arguments, and nothing else is touched. A batch of agents `(B, N, A)` is updated
one agent at a time (`e[b]` is an `(N, A)` view). Traces built from features `phi >= 0`
stay >= 0.
"""

import numpy as np
from numba.extending import register_jitable

FLUSH_THRESHOLD = 1e-100
"""Traces below this magnitude are set to 0 by `flush_tiny_`."""


@register_jitable
def _check(e, phi, action):
    """Raise ValueError unless `e` is `(N, A)`, `phi` is `(N,)` and `0 <= action < A`."""
    if e.ndim != 2 or phi.ndim != 1 or phi.shape[0] != e.shape[0]:
        raise ValueError("traces e must have shape (N, A) and features phi shape (N,)")
    if action < 0 or action >= e.shape[1]:
        raise ValueError("action must be an index in [0, A) for traces e of shape (N, A)")


@register_jitable
def accumulating_(e, phi, action, gamma_lambda):
    """Accumulating trace (eq. 2), in place: `e <- gamma lambda e + grad Q(s, a)`."""
    _check(e, phi, action)
    e *= gamma_lambda
    for i in range(e.shape[0]):
        e[i, action] += phi[i]


@register_jitable
def replacing_(e, phi, action, gamma_lambda):
    """Replacing trace (eq. 6), in place: `e <- max(gamma lambda e, grad Q(s, a))` element-wise.

    The other actions' traces only decay (their gradient is 0 and traces are >= 0): they are
    not reset, the paper's "not resetting the traces of unused actions".
    """
    _check(e, phi, action)
    e *= gamma_lambda
    for i in range(e.shape[0]):
        e[i, action] = max(e[i, action], phi[i])


@register_jitable
def replacing_reset_unused_(e, phi, action, gamma_lambda):
    """Replacing trace with resetting (eq. 5, Singh and Sutton 1996), in place.

    For binary (CMAC) features: where a feature is active (`phi_i > 0`), the taken action's
    trace becomes `phi_i` (1 for binary features) and the other actions' traces become 0;
    inactive features' traces decay by `gamma lambda`.
    """
    _check(e, phi, action)
    e *= gamma_lambda
    for i in range(e.shape[0]):
        if phi[i] > 0.0:
            e[i, :] = 0.0
            e[i, action] = phi[i]


@register_jitable
def flush_tiny_(e):
    """Set trace entries with `|e| < FLUSH_THRESHOLD` (1e-100) to 0, in place; any shape.

    A trace decayed by `gamma lambda` each step ends, after a few thousand steps, as a
    subnormal number (below 2.2e-308); arithmetic on subnormals is 15 to 100 times slower
    on common CPUs, and every later pass over the traces and weights pays it. Entries this
    small change no weight measurably (`alpha delta e`), so zeroing them is harmless.
    """
    for index in np.ndindex(e.shape):
        if np.abs(e[index]) < FLUSH_THRESHOLD:
            e[index] = 0.0
