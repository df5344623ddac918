"""Statistics that several studies share: interval estimates over agents, the probability of
improvement, and the episode from which a learning curve stays where it got to.

Intervals are percentile bootstrap intervals computed by `scipy.stats.bootstrap` (95 %,
10 000 resamples, a fixed random seed, so a report is the same every time it is written).
Agents are the unit that is resampled: an agent's episodes are not independent of each
other, agents are. A statistic of several samples (the agents of several runs) resamples
each sample within itself, so every run keeps its number of agents: the stratified
bootstrap of Agarwal et al. (2021, rliable), with runs as strata. Needs the 'paper' extra.
"""

import dataclasses
import math

import numpy as np
from scipy import stats

CONFIDENCE = 0.95
RESAMPLES = 10_000
SEED = 0
"""The bootstrap's random seed: intervals are reproducible."""


@dataclasses.dataclass(frozen=True)
class Estimate:
    """A statistic and its interval (`low`, `high` NaN where there is none: one agent)."""

    value: float
    low: float
    high: float

    def text(self, digits: int = 1, unit: str = "") -> str:
        """`34.2 [32.9, 35.4] s`, or the value alone where there is no interval."""
        def number(x):
            return "—" if not math.isfinite(x) else f"{x:.{digits}f}"
        interval = "" if math.isnan(self.low) else f" [{number(self.low)}, {number(self.high)}]"
        return f"{number(self.value)}{interval}{(' ' + unit) if unit else ''}"

    def side(self, middle: float) -> int:
        """+1 if the whole interval lies above `middle`, -1 if below, 0 if it holds it."""
        if math.isnan(self.low):
            return 0
        return 1 if self.low > middle else -1 if self.high < middle else 0


def interval(statistic, *samples, seed: int = SEED, resamples: int = RESAMPLES) -> Estimate:
    """`statistic(*samples, axis=-1)` (vectorised: it reduces the last axis of each sample)
    with its percentile bootstrap interval, each sample resampled within itself. A sample of
    one value has no interval."""
    samples = [np.asarray(sample, dtype=float) for sample in samples]
    value = float(statistic(*samples, axis=-1))
    if min(len(sample) for sample in samples) < 2:
        return Estimate(value, math.nan, math.nan)
    result = stats.bootstrap(samples, statistic, n_resamples=resamples, vectorized=True,
                             confidence_level=CONFIDENCE, method="percentile", batch=1000,
                             rng=np.random.default_rng(seed))
    return Estimate(value, float(result.confidence_interval.low),
                    float(result.confidence_interval.high))


def mean_interval(values, seed: int = SEED) -> Estimate:
    """The mean of `values` (NaN dropped: a diverged agent's) with its interval."""
    values = np.asarray(values, dtype=float)
    values = values[~np.isnan(values)]
    if len(values) == 0:
        return Estimate(math.nan, math.nan, math.nan)
    return interval(np.mean, values, seed=seed)


def probability_of_improvement(x, y, axis=-1):
    """P(X > Y) + P(X = Y) / 2 for X drawn from the agents `x` and Y from `y`, over every
    pair (Agarwal et al. 2021; the Mann-Whitney U statistic divided by the pairs): 0.5 when
    neither is ahead. Vectorised over leading axes; `axis` must be the last."""
    assert axis in (-1, np.ndim(x) - 1)
    x, y = np.asarray(x)[..., :, None], np.asarray(y)[..., None, :]
    return np.mean((x > y) + 0.5 * (x == y), axis=(-2, -1))


def improvement_interval(x, y, higher_is_better: bool = True, seed: int = SEED) -> Estimate:
    """The probability that an agent of `x` does better than one of `y`, with its interval
    (each group's agents resampled within the group); NaN dropped."""
    x, y = (np.asarray(v, dtype=float) for v in (x, y))
    x, y = x[~np.isnan(x)], y[~np.isnan(y)]
    if len(x) == 0 or len(y) == 0:
        return Estimate(math.nan, math.nan, math.nan)
    if not higher_is_better:
        x, y = -x, -y
    return interval(probability_of_improvement, x, y, seed=seed)


def outcome(improvement: Estimate) -> int:
    """+1 where the interval of the probability of improvement lies above 1/2 (better), -1
    below (worse), 0 where it holds 1/2 (the interval does not exclude a tie)."""
    return improvement.side(0.5)


def range_interval(cells, seed: int = SEED) -> Estimate:
    """The largest minus the smallest mean of `cells` (a list of agents' values, one per
    run), with its interval: each run's agents resampled within the run (stratified)."""
    cells = [np.asarray(cell, dtype=float) for cell in cells if len(cell)]

    def spread(*samples, axis=-1):
        means = np.stack([np.mean(sample, axis=axis) for sample in samples], axis=-1)
        return np.max(means, axis=-1) - np.min(means, axis=-1)
    return interval(spread, *cells, seed=seed)


def matrix_interval(statistic, matrix, seed: int = SEED) -> Estimate:
    """`statistic(matrix)` of an agents x episodes `matrix` (it maps `(..., agents, episodes)`
    to `(...)`), with its interval over agents: whole rows (an agent's episodes) resampled."""
    matrix = np.asarray(matrix, dtype=float)

    def of_rows(rows, axis=-1):
        return np.asarray(statistic(matrix[np.asarray(rows, dtype=int)]), dtype=float)
    return interval(of_rows, np.arange(len(matrix)), seed=seed)


def first_from_which(condition):
    """Along the last axis, the first position from which `condition` holds to the end,
    counted from 1; the length + 1 where it does not hold at the end (never)."""
    condition = np.asarray(condition, dtype=bool)
    length = condition.shape[-1]
    failing = ~condition
    last_failure = np.where(failing.any(axis=-1),
                            length - np.argmax(failing[..., ::-1], axis=-1), 0)
    return last_failure + 1


def first_run_of(condition, window: int):
    """Along the last axis, the first position (from 1) that starts `window` consecutive
    positions where `condition` holds; the length + 1 where there is none (never)."""
    condition = np.asarray(condition, dtype=bool)
    length = condition.shape[-1]
    if window > length:
        return np.full(condition.shape[:-1], length + 1)
    counts = np.cumsum(np.concatenate([np.zeros(condition.shape[:-1] + (1,), dtype=int),
                                       condition.astype(int)], axis=-1), axis=-1)
    full = (counts[..., window:] - counts[..., :-window]) == window  # starts 0..length-window
    return np.where(full.any(axis=-1), np.argmax(full, axis=-1) + 1, length + 1)


def rolling_mean(values, window: int):
    """Along the last axis, the mean of each position and the `window - 1` before it (fewer
    at the start)."""
    values = np.asarray(values, dtype=float)
    sums = np.cumsum(values, axis=-1)
    shifted = np.concatenate([np.zeros(values.shape[:-1] + (window,)), sums[..., :-window]],
                             axis=-1)[..., :values.shape[-1]]
    counts = np.minimum(np.arange(1, values.shape[-1] + 1), window)
    return (sums - shifted) / counts


def episode_intervals(values, seed: int = SEED, resamples: int = 2000):
    """The 95 % interval of the mean over agents of each episode of an agents x episodes
    array (agents resampled; NaN where an episode has one agent): `(low, high)` arrays."""
    values = np.asarray(values, dtype=float)
    if len(values) < 2:
        return np.full(values.shape[1], np.nan), np.full(values.shape[1], np.nan)
    result = stats.bootstrap((values,), np.mean, axis=0, n_resamples=resamples, vectorized=True,
                             confidence_level=CONFIDENCE, method="percentile",
                             rng=np.random.default_rng(seed))
    return result.confidence_interval.low, result.confidence_interval.high
