"""The equations of Augmented Random Search (Mania, Guy & Recht 2018, "Simple random search
provides a competitive approach to reinforcement learning", arXiv:1803.07055, NeurIPS 2018;
its Algorithm 1, V1-t and V2-t) as small pure JAX functions, apart from the learner's plumbing
(`agent.ars`); checked against the authors' code, `modestyachts/ARS` at commit 4c8e24e
(`code/ars.py`, `code/filter.py`). Time-indexed names as in rlax: `theta_j` the policy of
iteration j. This module imports JAX."""

import jax
import jax.numpy as jnp

STD_FLOOR = 1e-7
"""A state variable whose standard deviation is below this is set to 0 by the V2
normalisation (`filter.py`'s `MeanStdFilter.stats_increment`: its std becomes +inf)."""
STD_EPS = 1e-8
"""Added to the standard deviation before dividing (`MeanStdFilter.__call__`)."""


def direction(key, shape):
    """A direction delta of the policy's shape, its entries i.i.d. N(0, 1) (Algorithm 1)."""
    return jax.random.normal(key, shape, jnp.float64)


def perturbed(theta_j, delta, nu, sign):
    """The policy of one rollout, theta_j + sign nu delta, sign +1 or -1 (Algorithm 1)."""
    return theta_j + sign * nu * delta


def scores(theta, x):
    """The linear policy's outputs theta x `(..., p)` at states `(..., d)` (`theta` `(p, d)`)."""
    return x @ theta.T


def discrete_action(theta, x):
    """A discrete action: the argmax of the linear scores (one row of theta per action)."""
    return jnp.argmax(scores(theta, x), axis=-1).astype(jnp.int32)


def continuous_action(theta, x):
    """A continuous action in [-1, 1]: the linear output clipped, as an actuator saturates
    (sb3-contrib's `ARSLinearPolicy` with `squash_output=False` clips to the action space)."""
    return jnp.clip(scores(theta, x)[..., 0], -1.0, 1.0)


def v2_scale(stats):
    """`(mu, sigma)` of V2's normalisation from the running statistics of the states seen
    so far (Algorithm 1, V2,
    diagonal Sigma; `RunningStat.var`: p / (n - 1), or mu^2 from one sample),
    sigma = +inf where below `STD_FLOOR` (that variable then reads 0)."""
    count = stats["count"]
    var = jnp.where(count > 1, stats["p"] / jnp.maximum(count - 1.0, 1.0), stats["mean"] ** 2)
    std = jnp.sqrt(var)
    return stats["mean"], jnp.where(std < STD_FLOOR, jnp.inf, std)


def v2_state(x, mean, std):
    """A state as V2's policy reads it, diag(Sigma)^(-1/2) (x - mu) (Algorithm 1;
    `MeanStdFilter.__call__`: (x - mu) / (sigma + 1e-8))."""
    return (x - mean) / (std + STD_EPS)


def top_directions(r_plus, r_minus, top: int):
    """The indices of the `top` directions of largest max(r_plus, r_minus) (Algorithm 1, the "-t"
    of V1-t and V2-t), in decreasing order."""
    return jnp.argsort(-jnp.maximum(r_plus, r_minus))[:top]


def ars_step(theta_j, deltas, r_plus, r_minus, alpha, top: int):
    """theta_j+1 = theta_j + alpha / (b sigma_R) sum_k (r_plus,k - r_minus,k) delta_k over
    the b = `top` best directions k (Algorithm 1), sigma_R the standard deviation of their 2b
    returns (`ars.py`'s `np.std`, ddof 0). Where the 2b returns are all equal (sigma_R = 0,
    every difference 0) the policy stays as it is."""
    chosen = top_directions(r_plus, r_minus, top)
    plus, minus = r_plus[chosen], r_minus[chosen]
    sigma = jnp.std(jnp.concatenate([plus, minus]))
    weighted = jnp.tensordot(plus - minus, deltas[chosen], axes=1)
    step = jnp.where(sigma > 0, alpha / (top * jnp.where(sigma > 0, sigma, 1.0)), 0.0)
    return theta_j + step * weighted
