"""The aggregates across tasks computed by rliable itself (Agarwal et al. 2021, "Deep
reinforcement learning at the edge of the statistical precipice", NeurIPS; Google's rliable
1.2.0, github.com/google-research/rliable), as the third benchmark's rule asks
(docs/FINDINGS.md, "Aggregates across tasks by rliable itself"): the interquartile mean, the
median and mean of the task means and the optimality gap (`rliable.metrics`), the
performance profiles and the probability of improvement, each with its 95 % percentile
interval from rliable's stratified bootstrap (`rliable.library.get_interval_estimates`,
`create_performance_profile`: runs resampled within each task).

rliable draws its resamples from numpy's global generator (`np.random.choice` in its
`StratifiedBootstrap.update_indices`), whatever `random_state` it is given: each learner is
resampled from the global generator seeded with `statistics.SEED`, which is restored after,
so that every number is the same each time and a learner's intervals do not depend on the
learners beside it (as `verdicts.aggregate_estimates`, lwrl's own computation of the same
definitions, which the tests hold these to).

rliable's library imports arch's bootstrap; rliable 1.2.0, the newest, needs arch < 8, and
arch 7 does not import with pandas 3: these run where pandas is below 3 (2.3.3 checked).
"""

import contextlib
from collections.abc import Mapping

import numpy as np

from lwrl.analysis import statistics, verdicts
from lwrl.analysis.statistics import Estimate
from lwrl.analysis.verdicts import Profile


def _rliable():
    """`(library, metrics)` of rliable, or a one-line RuntimeError saying why not."""
    try:
        from rliable import library, metrics
    except Exception as error:  # arch 7 with pandas 3 fails with a TypeError
        reason = str(error).splitlines()[0] if str(error) else ""
        raise RuntimeError(
            f"the aggregates across tasks are rliable's, and rliable.library does not import "
            f"here ({type(error).__name__}: {reason}); rliable 1.2.0 needs arch < 8, which "
            f"needs pandas < 3: pip install 'pandas<3' 'arch>=7,<8' rliable==1.2.0") from None
    return library, metrics


@contextlib.contextmanager
def _seeded(seed: int):
    """numpy's global generator seeded with `seed`, its state restored after."""
    state = np.random.get_state()
    np.random.seed(seed)
    try:
        yield
    finally:
        np.random.set_state(state)


def _checked(matrix, learner: str) -> np.ndarray:
    """A learner's runs x tasks matrix, checked as `verdicts` checks it."""
    return np.stack(verdicts.task_columns(matrix, learner), axis=1)


def _estimates(values, intervals) -> list:
    """`Estimate`s from rliable's point estimates and its 2 x k intervals."""
    values, intervals = np.ravel(values), np.reshape(intervals, (2, -1))
    return [Estimate(float(v), float(low), float(high))
            for v, low, high in zip(values, intervals[0], intervals[1])]


def aggregate_estimates(scores: Mapping[str, np.ndarray], seed: int = statistics.SEED,
                        resamples: int = statistics.RESAMPLES) -> dict:
    """For each learner of `scores` (learner -> runs x tasks matrix of normalised scores),
    `verdicts.AGGREGATES` by rliable (`metrics.aggregate_iqm`, `aggregate_median`,
    `aggregate_mean`, `aggregate_optimality_gap`) with their intervals
    (`library.get_interval_estimates`, percentile, `resamples` resamples)."""
    library, metrics = _rliable()

    def aggregates(matrix):
        return np.array([metrics.aggregate_iqm(matrix), metrics.aggregate_median(matrix),
                         metrics.aggregate_mean(matrix), metrics.aggregate_optimality_gap(matrix)])
    estimates = {}
    for learner, matrix in scores.items():
        with _seeded(seed):
            values, intervals = library.get_interval_estimates(
                {learner: _checked(matrix, learner)}, aggregates, reps=resamples,
                confidence_interval_size=statistics.CONFIDENCE)
        estimates[learner] = dict(zip(verdicts.AGGREGATES,
                                      _estimates(values[learner], intervals[learner])))
    return estimates


def _fractions_above(scores, thresholds):
    """The fraction of all of `scores` strictly above each of `thresholds`."""
    return np.mean(np.ravel(scores)[None, :] > np.asarray(thresholds)[:, None], axis=1)


def performance_profiles(scores: Mapping[str, np.ndarray], thresholds,
                         seed: int = statistics.SEED,
                         resamples: int = statistics.RESAMPLES) -> dict:
    """For each learner of `scores`, its score distribution (the fraction of runs' scores
    above each of `thresholds`, over all tasks) by rliable
    (`library.create_performance_profile`) with its intervals, as a `verdicts.Profile`. The
    profile is rliable's default, `library.run_score_deviation` (np.mean(scores > tau)),
    given to it as its `custom_profile_func` over all thresholds at once: rliable's own
    calls it once per threshold (`np.vectorize`), a hundred times slower, for the same
    numbers."""
    library, _ = _rliable()
    thresholds = np.asarray(thresholds, dtype=float)
    if thresholds.ndim != 1 or len(thresholds) == 0 or not np.all(np.isfinite(thresholds)):
        raise ValueError("performance_profiles needs a one-dimensional list of finite thresholds")
    profiles = {}
    for learner, matrix in scores.items():
        with _seeded(seed):
            fractions, intervals = library.create_performance_profile(
                {learner: _checked(matrix, learner)}, thresholds,
                custom_profile_func=_fractions_above, reps=resamples,
                confidence_interval_size=statistics.CONFIDENCE)
        low, high = np.reshape(intervals[learner], (2, -1))
        profiles[learner] = Profile(thresholds, np.asarray(fractions[learner], dtype=float),
                                    low, high)
    return profiles


def probability_of_improvement(scores_x, scores_y) -> float:
    """rliable's `metrics.probability_of_improvement` (rliable 1.2.0), P(X_m > Y_m) averaged
    over the tasks m, with each task's Mann-Whitney U counted over the pairs of runs,
    U = #{x > y} + #{x = y} / 2, where rliable asks `scipy.stats.mannwhitneyu` for it: the
    same numbers (U is a count of halves, exact in floating point either way; tested), a
    hundred times faster than scipy's per task and per resample."""
    probabilities = []
    runs = scores_x.shape[0] * scores_y.shape[0]
    for task in range(scores_x.shape[1]):
        x, y = scores_x[:, task], scores_y[:, task]
        if np.array_equal(x, y):
            probabilities.append(0.5)
            continue
        above, tied = np.sum(x[:, None] > y[None, :]), np.sum(x[:, None] == y[None, :])
        probabilities.append((above + 0.5 * tied) / runs)
    return np.mean(probabilities)


def improvement(x, y, seed: int = statistics.SEED,
                resamples: int = statistics.RESAMPLES) -> Estimate:
    """P(X > Y) averaged over tasks of the runs x tasks matrices `x` and `y` (the same tasks)
    by rliable (`probability_of_improvement`, its metric counted faster), with its interval
    (`library.get_interval_estimates` of the pair: each learner's runs resampled within each
    task)."""
    library, _ = _rliable()
    x, y = _checked(x, "x"), _checked(y, "y")
    if x.shape[1] != y.shape[1]:
        raise ValueError(f"improvement needs the same tasks of x and y (x has {x.shape[1]}, "
                         f"y {y.shape[1]})")
    with _seeded(seed):
        values, intervals = library.get_interval_estimates(
            {"x,y": [x, y]}, probability_of_improvement, reps=resamples,
            confidence_interval_size=statistics.CONFIDENCE)
    return _estimates(values["x,y"], intervals["x,y"])[0]
