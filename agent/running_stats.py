"""Running statistics of samples (Welford 1962), as pure JAX functions: the sample count,
mean and sum of squared deviations that the streaming learners' normalisations
(`agent.streaming`) and ARS V2's state normalisation (`agent.random_search`) keep, each
with its own variance and scaling. Float64. This module imports JAX."""

import jax.numpy as jnp

STATS_EPS = 1e-8
"""The normalisation wrappers' epsilon (`NormalizeObservation`, `ScaleReward`; SB3's
`VecNormalize`)."""


def stats_start(shape=()):
    """Running statistics of no sample (`SampleMeanStd`): mean 0, sum of squared
    deviations 0, count 0, float64."""
    zeros = jnp.zeros(shape, jnp.float64)
    return {"mean": zeros, "p": zeros, "count": jnp.zeros((), jnp.float64)}


def stats_add(stats, x):
    """The statistics with the sample `x` (Welford 1962; `SampleMeanStd.update`):
    n_t = n_tm1 + 1, mu_t = mu_tm1 + (x - mu_tm1) / n_t,
    p_t = p_tm1 + (x - mu_tm1)(x - mu_t). From no sample this gives mu = x, p = 0, as the
    authors' first update sets them."""
    count = stats["count"] + 1.0
    mean = stats["mean"] + (x - stats["mean"]) / count
    return {"mean": mean, "p": stats["p"] + (x - stats["mean"]) * (x - mean), "count": count}


def stats_variance(stats):
    """The sample variance p / (n - 1), 1 before two samples (`SampleMeanStd`)."""
    return jnp.where(stats["count"] < 2, 1.0, stats["p"] / jnp.maximum(stats["count"] - 1.0, 1.0))


def normalised(x, stats):
    """An observation normalised by the running statistics, (x - mu) / sqrt(var + 1e-8)
    (`NormalizeObservation.normalize`, after the statistics took x)."""
    return (x - stats["mean"]) / jnp.sqrt(stats_variance(stats) + STATS_EPS)
