"""Thresholds applied to intervals, not to point estimates, by the third benchmark's rule
(docs/FINDINGS.md, "The light-weight claim judged a third time", the rule's "Intervals, and
thresholds applied to them"): a ratio's threshold holds only where its whole 95 % interval is
past it ("1/100 of the compute" only where the interval's upper end is below 1/100), and a
share of agents that reach a task carries its exact interval (Clopper & Pearson 1934,
"The use of confidence or fiducial limits illustrated in the case of the binomial",
Biometrika 26:404-413: the p with P(X >= k; n, p) = 0.025 and P(X <= k; n, p) = 0.025, from
the beta quantiles; `scipy.stats.binomtest(...).proportion_ci("exact")`).
"""


import numpy as np
from scipy import stats

from lwrl.analysis import statistics
from lwrl.analysis.statistics import Estimate


def wholly_below(estimate: Estimate, threshold: float) -> bool:
    """Whether the whole interval of `estimate` lies below `threshold` (its upper end below
    it); never where there is no interval."""
    return estimate.side(threshold) == -1


def wholly_above(estimate: Estimate, threshold: float) -> bool:
    """Whether the whole interval of `estimate` lies above `threshold` (its lower end above
    it); never where there is no interval."""
    return estimate.side(threshold) == 1


def success_share(successes) -> Estimate:
    """The share of agents that reach the task (`successes`, one truth value per agent: it
    reached the goal in every final greedy episode) with its exact Clopper-Pearson 95 %
    interval; a one-line ValueError where there is no agent."""
    successes = np.asarray(successes)
    if successes.ndim != 1 or len(successes) == 0 or successes.dtype != bool:
        raise ValueError("a success share needs a non-empty vector of truth values, one per "
                         "agent")
    k, n = int(successes.sum()), len(successes)
    interval = stats.binomtest(k, n).proportion_ci(statistics.CONFIDENCE, method="exact")
    return Estimate(k / n, float(interval.low), float(interval.high))


def every_episode(reached) -> np.ndarray:
    """Per agent, whether it reached the task in every one of its episodes (`reached`, agents
    x episodes truth values; a NaN, a diverged agent's episode, is not reached)."""
    reached = np.asarray(reached, dtype=float)
    if reached.ndim != 2 or reached.shape[1] == 0:
        raise ValueError("every_episode needs an agents x episodes array")
    return np.all(reached == 1, axis=1)
