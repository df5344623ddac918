"""Normalised radial basis function (NRBF) features, Främling (2008), section 3.

The state `s` is mapped affinely from its range `[low, high]` to `[0, 1]` per variable (not
clipped: values outside the range are allowed). The network has `N = n^d` neurons whose
centroids form a regular grid with `n` points per dimension at the cell midpoints
`(i + 0.5) / n` (the author's kfnnet code; SPEC.md, "Agent").

- RBF (eq. 8): `phi_i(s) = exp(-||s - c_i||^2 / r^2)`.
- NRBF (eq. 9): `phibar_i = phi_i / sum_k phi_k`, so `Q(s, a) = sum_i w_ia phibar_i`.
  The features are >= 0 and sum to 1.

Neuron order: neuron `i` has the per-dimension grid indices `(i_0, ..., i_{d-1})` with
`i = np.ravel_multi_index((i_0, ..., i_{d-1}), (n,) * d)`, i.e. C (row-major) order: the last
state variable varies fastest.

Factorised evaluation: the squared distance is a sum over dimensions, so
`phi_i = prod_j g_j[i_j]` with `g_j[k] = exp(-(s_j - c_k)^2 / r^2)`, and `phibar` is the
outer product of the per-dimension normalised vectors `g_j / sum_k g_j[k]`: `n * d`
exponentials instead of `n^d` (24 instead of 1296 on the 6^4 cart-pole grid).

Underflow guard: far outside `[0, 1]` every `g_j[k]` underflows to 0 (e.g. pendulum speeds
beyond their range). Per dimension, the smallest squared distance is subtracted in the
exponent; that common factor cancels in the normalisation, so the result is exact, the
nearest centroid gets `g = 1` and the sum is never 0/0.
"""

import dataclasses

import numpy as np
from numba.extending import register_jitable

from lwrl.agent.features import FeatureMap, normalise
from lwrl.kernels import kernel
from lwrl.settings import check_count

DEFAULT_R2 = 0.01
"""r^2, the spread of eq. 8; the paper uses 0.01 in all tasks."""


@register_jitable
def clamp_margin(n, r2):
    """M = 400 n r^2: a normalised value is limited to [-M, 1 + M], which changes no feature.

    Beyond 1 + M the nearest centroid is the last, `(n - 0.5) / n`, at distance m > M; the
    next is 1/n farther, so its exponent is `(1/n)(2m + 1/n) / r^2 > 2M / (n r^2) = 800`,
    and exp(-800) is 0 in float64: the features are exactly those at the limit. The other
    centroids are farther still, and the low side is symmetric. Without the limit, values
    so large (about 1e14 and up) that float64 cannot tell the centroids' distances apart
    would spread the features evenly instead of onto the edge centroid.
    """
    return 400.0 * n * r2


@register_jitable
def centroid(index, n):
    """Grid point `index` of `n` in one dimension: the cell midpoint `(index + 0.5) / n`."""
    return (index + 0.5) / n


@register_jitable
def nrbf_features_into(state, low, high, n, r2, out, scratch):
    """Write the NRBF features (eq. 8 and 9) of one state into `out`; returns None.

    `state`, `low`, `high`: shape `(d,)`, in the task's units; `n`: centroids per dimension;
    `r2`: the spread r^2; `out`: shape `(n^d,)`, overwritten with the features in C order;
    `scratch`: shape `(d, n)`, overwritten with the per-dimension normalised factors
    `g_j / sum_k g_j[k]` (`nrbf_factors_into`), whose outer product the features are
    (`outer_product_into`). Allocates nothing; runs from Python and inside numba-compiled
    code.
    """
    d = state.shape[0]
    if low.shape[0] != d or high.shape[0] != d:
        raise ValueError("state, low and high must all have shape (d,)")
    if scratch.shape[0] != d or scratch.shape[1] != n:
        raise ValueError("scratch must have shape (d, n)")
    if out.shape[0] != n ** d:
        raise ValueError("out must have shape (n^d,)")
    nrbf_factors_into(state, low, high, n, r2, scratch)
    outer_product_into(scratch, out)


@register_jitable
def nrbf_factors_into(state, low, high, n, r2, factors):
    """Row j of `factors` `(d, n)` := dimension j's normalised Gaussians `g_j / sum_k g_j[k]`
    of one state. The exponent `((s_j - c_k)^2 - min_k (s_j - c_k)^2) / r^2` is computed as
    `(|s_j - c_k| - m)(|s_j - c_k| + m) / r^2` (m the smallest distance), which does not
    overflow to inf - inf = NaN for huge finite states as the squares would. Each pass over
    a row is a loop of its own: the distances, the exponents and the division by the sum
    vectorise, and only the exponentials (calls) and the sum run one by one."""
    margin = clamp_margin(n, r2)
    for j in range(state.shape[0]):
        g = factors[j]
        s_j = min(max(normalise(state[j], low[j], high[j]), -margin), 1.0 + margin)
        for k in range(n):
            g[k] = np.abs(s_j - centroid(k, n))
        nearest = np.inf
        for k in range(n):
            nearest = min(nearest, g[k])
        for k in range(n):
            g[k] = -(g[k] - nearest) * (g[k] + nearest) / r2
        total = 0.0
        for k in range(n):
            g[k] = np.exp(g[k])
            total += g[k]
        for k in range(n):
            g[k] /= total


@register_jitable
def outer_product_into(factors, out):
    """`out` `(n^d,)` := the outer product of the rows of `factors` `(d, n)` in C order, each
    entry `g_0[i_0] (g_1[i_1] (... g_{d-1}[i_{d-1}]))`, multiplied from the last dimension
    to the first.

    The last dimension's factors are copied (each is itself times 1.0). Then in place,
    from the last dimension but one to the first: after dimension j, `out[:size]` holds
    the products of dimensions j..d-1 in C order, and dimension j's factor k scales that
    block into `out[k*size : (k+1)*size]`. Blocks k >= 1 lie past `out[:size]` and are
    written first, each through a view of its own so that its loop reads and writes
    different arrays (a compiler vectorises it); block 0 is scaled in place last."""
    d, n = factors.shape
    last = factors[d - 1]
    for k in range(n):
        out[k] = last[k]
    size = n
    for j in range(d - 2, -1, -1):
        g = factors[j]
        for k in range(n - 1, 0, -1):
            factor = g[k]
            block = out[k * size:(k + 1) * size]
            for r in range(size):
                block[r] = factor * out[r]
        factor = g[0]
        for r in range(size):
            out[r] *= factor
        size *= n


def _nrbf_features_batch(states, low, high, n, r2, out, scratch):
    """`nrbf_features_into` for each row of `states` (B, d) into the rows of `out` (B, N)."""
    for b in range(states.shape[0]):
        nrbf_features_into(states[b], low, high, n, r2, out[b], scratch)


FEATURES_BATCH = kernel("nrbf_features_batch", _nrbf_features_batch)
"""`_nrbf_features_batch` compiled: the NRBF features of a batch of states."""


@dataclasses.dataclass(frozen=True)
class NRBF(FeatureMap):
    """An NRBF network's features (eq. 8 and 9) over the state box `[low, high]`.

    Example: `NRBF(low=(-1.2, -0.07), high=(0.5, 0.07), n=10)` for Mountain-Car's 10 x 10 grid.
    """

    low: tuple
    """Lower end of each state variable's range (task units); maps to 0."""
    high: tuple
    """Upper end of each state variable's range (task units); maps to 1."""
    n: int
    """Centroids per dimension (>= 2); the network has `n^d` neurons."""
    r2: float = DEFAULT_R2
    """The spread r^2 of eq. 8, in normalised units (> 0)."""

    def __post_init__(self):
        super().__post_init__()
        object.__setattr__(self, "n", check_count("n (centroids per dimension)", self.n, 2))
        if not (np.isfinite(self.r2) and self.r2 > 0):
            raise ValueError(f"r2 (the spread r^2) must be finite and > 0; got {self.r2!r}")
        object.__setattr__(self, "r2", float(self.r2))

    @property
    def num_features(self) -> int:
        """N = n^d, the number of neurons."""
        return self.n ** self.dim

    @property
    def centroids(self) -> np.ndarray:
        """The centroids `(N, d)` in normalised units, in neuron (C) order."""
        grid = centroid(np.arange(self.n), self.n)
        axes = np.meshgrid(*[grid] * self.dim, indexing="ij")
        return np.stack(axes, axis=-1).reshape(self.num_features, self.dim)

    def _features_rows(self, rows, out):
        FEATURES_BATCH(rows, np.array(self.low), np.array(self.high), self.n, self.r2,
                             out, np.empty((self.dim, self.n)))
