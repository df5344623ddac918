"""The statistics a comparison of learners is judged by: scores normalised between the random
policy and the classical controller, a permutation test of two learners' means, Holm's
correction over a family of tests, the gate that leaves a comparison "not judged" where a
learner is not above the random policy, and the aggregates across tasks with their figures
(Agarwal et al. 2021, "Deep reinforcement learning at the edge of the statistical precipice",
NeurIPS; Holm 1979, "A simple sequentially rejective multiple test procedure", Scand. J.
Statist. 6:65-70).

The aggregates across tasks, their stratified bootstrap intervals and their figures follow the
definitions of Google's rliable 1.2.0 (the authors' library, github.com/google-research/rliable;
each function names the file and function it follows) but are computed here on numpy and
scipy, vectorised over the resamples: the second benchmark's report uses these. The third
benchmark's come from rliable itself (`analysis.aggregates`), which `tests/test_aggregates.py`
holds to these; `tests/test_verdicts.py` checks the point estimates against `rliable.metrics`
and the intervals against `rliable.library`.

Intervals, seeds and the confidence level are `analysis.statistics`'s (95 % percentile
intervals, 10 000 resamples, seed 0): every number is the same each time it is computed.
"""

import dataclasses
import math
from collections.abc import Mapping

import numpy as np
from scipy import stats
from statsmodels.stats.multitest import multipletests

from lwrl.analysis import statistics
from lwrl.analysis.statistics import Estimate

ALPHA = 0.05
"""The family-wise error rate Holm's correction holds."""
EXACT_SPLITS = 100_000
"""The permutation test enumerates every split of the pooled values where there are at most
this many; beyond, it draws `statistics.RESAMPLES` random splits (seed `statistics.SEED`)."""
AGGREGATES = ("IQM", "median", "mean", "optimality gap")
"""The aggregates across tasks (rliable's `metrics.aggregate_iqm`, `aggregate_median`,
`aggregate_mean`, `aggregate_optimality_gap`), in the order `aggregate_estimates` gives them."""
COLORS = ("#0173b2", "#de8f05", "#029e73", "#d55e00", "#cc78bc", "#ca9161", "#fbafe4",
          "#949494", "#ece133", "#56b4e9")
"""The learners' colours in the figures, in turn: seaborn's "colorblind" palette, rliable's
default (`plot_utils`, `color_palette='colorblind'`)."""
BATCH = 1000
"""Bootstrap resamples evaluated at once (scipy's `batch`): the memory of a resampled batch
of a matrix is BATCH times the matrix's."""


def normalised_score(values, random, classical, higher_is_better: bool):
    """(x - r) / (c - r) for each of `values`, with r the mean of the random policy's row
    `random` and c the mean of the classical controller's row `classical`: the random policy
    scores 0, the classical controller 1, and a higher normalised score is better whichever
    way the measure goes (the normalisation of the human-normalised Atari score, between the
    random and a reference score, that Agarwal et al. 2021 aggregate).

    The formula is direction-free because r and c are the reference rows' means: where lower
    is better (steps per episode) c < r, and both numerator and denominator change sign.
    `higher_is_better` says which way the measure goes, so that a classical row that is not
    better than the random one (a scale that would turn rankings round) is refused."""
    r, c = float(np.mean(random)), float(np.mean(classical))
    if c == r:
        raise ValueError(f"normalised_score needs the classical and random means to differ "
                         f"(both {r:g})")
    if (c > r) != higher_is_better:
        raise ValueError(f"normalised_score needs the classical mean ({c:g}) better than the "
                         f"random one ({r:g}) with higher_is_better={higher_is_better}")
    return (np.asarray(values, dtype=float) - r) / (c - r)


def _difference_of_means(x, y, axis=-1):
    """mean(x) - mean(y) along `axis` (vectorised for `scipy.stats.permutation_test`)."""
    return np.mean(x, axis=axis) - np.mean(y, axis=axis)


def permutation_p_value(x, y) -> float:
    """The two-sided p-value of the difference of the means of `x` and `y` (NaN dropped: a
    diverged agent's) under the null hypothesis that the labels x and y are exchangeable
    (Fisher's permutation test; `scipy.stats.permutation_test`, independent samples).

    With n = len(x), m = len(y), there are C(n + m, n) distinct splits of the pooled values.
    Where C(n + m, n) <= `EXACT_SPLITS` the test enumerates them all (exact); otherwise it
    draws `statistics.RESAMPLES` random splits with seed `statistics.SEED` and the p-value is
    (k + 1) / (resamples + 1), k the splits at least as extreme. Two-sided is scipy's: twice
    the smaller one-sided p-value, capped at 1 ([1, 2, 3] against [4, 5, 6]: 2 / 20)."""
    x, y = (np.asarray(sample, dtype=float) for sample in (x, y))
    x, y = x[~np.isnan(x)], y[~np.isnan(y)]
    if x.ndim != 1 or y.ndim != 1 or len(x) == 0 or len(y) == 0:
        raise ValueError("permutation_p_value needs two one-dimensional samples, each with a "
                         "value that is not NaN")
    exact = math.comb(len(x) + len(y), len(x)) <= EXACT_SPLITS
    result = stats.permutation_test(
        (x, y), _difference_of_means, permutation_type="independent", vectorized=True,
        alternative="two-sided", n_resamples=np.inf if exact else statistics.RESAMPLES,
        rng=np.random.default_rng(statistics.SEED))
    return float(result.pvalue)


@dataclasses.dataclass(frozen=True)
class HolmCorrection:
    """Holm-adjusted p-values, in the order the p-values were given, and which hypotheses
    are rejected (adjusted p-value <= alpha)."""

    adjusted: np.ndarray
    rejected: np.ndarray


def holm(p_values, alpha: float = ALPHA) -> HolmCorrection:
    """Holm's (1979) step-down correction of a family of m p-values, holding the family-wise
    error rate at `alpha`. With p_(1) <= ... <= p_(m) the p-values sorted, the adjusted
    p-values are

        p~_(i) = min(1, max_{j <= i} (m - j + 1) p_(j)),

    monotone in i; H_(i) is rejected iff p~_(i) <= alpha, which is Holm's procedure: reject
    H_(1), H_(2), ... while p_(i) <= alpha / (m - i + 1), and stop at the first that is not.
    Computed by statsmodels (`statsmodels.stats.multitest.multipletests`, method "holm")."""
    p = np.asarray(p_values, dtype=float)
    if p.ndim != 1 or len(p) == 0 or not np.all((p >= 0) & (p <= 1)):
        raise ValueError("holm needs a non-empty one-dimensional family of p-values in [0, 1]")
    rejected, adjusted, _, _ = multipletests(p, alpha=alpha, method="holm")
    return HolmCorrection(adjusted, rejected)


@dataclasses.dataclass(frozen=True)
class GateVerdict:
    """Whether a comparison of learner A against learner B is judged; `reason` says why, and
    names the side (A, B, the random row) that failed where it is not."""

    judged: bool
    reason: str
    a: Estimate
    b: Estimate
    random: Estimate


def above_random_gate(a, b, random, names: tuple[str, str] = ("A", "B")) -> GateVerdict:
    """The gate a comparison of two learners on a task passes before it is judged (after
    Agarwal et al. 2021: a difference between learners that do no better than chance says
    nothing of them).

    `a`, `b` and `random` are normalised scores (`normalised_score`), one per agent, of the
    two learners and of the random policy's row. Each gets the mean over agents with its
    95 % percentile bootstrap interval (`statistics.mean_interval`: agents resampled, NaN
    dropped). The rule: the comparison is judged iff

        low(A) > high(random)  and  low(B) > high(random),

    each learner's interval lying entirely above the random row's upper end. Otherwise it is
    "not judged", and the reason names each learner whose interval reaches that end, or the
    random row where it has no interval (fewer than two agents)."""
    estimates = [statistics.mean_interval(values) for values in (a, b, random)]
    ceiling = estimates[2].high
    if math.isnan(ceiling):
        return GateVerdict(False, "not judged: the random row has no interval (fewer than two "
                           "agents)", *estimates)
    failing = [_below(name, estimate, ceiling) for name, estimate in zip(names, estimates[:2])
               if not estimate.low > ceiling]  # no interval (NaN) fails too
    if failing:
        return GateVerdict(False, "not judged: " + "; ".join(failing), *estimates)
    return GateVerdict(True, f"judged: the intervals of {names[0]} and {names[1]} lie above the "
                       f"random row's upper end {ceiling:.3f}", *estimates)


def _below(name: str, estimate: Estimate, ceiling: float) -> str:
    """Why learner `name` fails the gate."""
    if math.isnan(estimate.low):
        return f"{name} has no interval (fewer than two agents)"
    return (f"{name}'s interval {estimate.text(3)} does not lie above the random row's upper "
            f"end {ceiling:.3f}")


def task_columns(matrix, learner: str) -> list:
    """The task columns of `learner`'s runs x tasks `matrix` of normalised scores (rliable's
    layout: `scores[n][m]` the score of run n on task m), each a sample of runs: the strata
    of the stratified bootstrap."""
    matrix = np.asarray(matrix, dtype=float)
    if matrix.ndim != 2 or matrix.size == 0:
        raise ValueError(f"{learner}: the aggregates across tasks need a runs x tasks matrix "
                         f"with a run and a task at least, not one of shape {matrix.shape}")
    if np.isnan(matrix).any():
        raise ValueError(f"{learner}: the aggregates across tasks need every run's score on "
                         f"every task, and a score is NaN (a diverged agent's)")
    return list(matrix.T)


def _stratified_bootstrap(statistic, columns: list, seed: int, resamples: int):
    """`statistic(*columns, axis=-1)` (it maps task columns of shape `(..., runs)` to values
    of shape `(k, ...)`) with the 95 % percentile interval of each of its k values, from the
    stratified bootstrap: each task's runs resampled within the task, tasks as strata, every
    value computed on the same resamples (rliable `library.py`, `StratifiedBootstrap` with
    `task_bootstrap=False`, as `get_interval_estimates` uses it with `method='percentile'`).
    It is `statistics.interval` (the same confidence, method and seed) for a statistic of
    several values, which that one's scalar `value` does not take: `(value, low, high)`,
    arrays of k; no interval (NaN) where a task has one run."""
    value = np.asarray(statistic(*columns, axis=-1), dtype=float)
    if min(len(column) for column in columns) < 2:
        return value, np.full(value.shape, math.nan), np.full(value.shape, math.nan)
    result = stats.bootstrap(columns, statistic, n_resamples=resamples, vectorized=True,
                             confidence_level=statistics.CONFIDENCE, method="percentile",
                             batch=BATCH, rng=np.random.default_rng(seed))
    return (value, np.asarray(result.confidence_interval.low, dtype=float),
            np.asarray(result.confidence_interval.high, dtype=float))


def _aggregates(*columns, axis=-1):
    """`AGGREGATES` of the runs x tasks matrices whose task columns are `columns` (each
    `(..., runs)`): an array `(4, ...)`. As rliable `metrics.py` defines them:
    `aggregate_iqm`, `scipy.stats.trim_mean(scores, proportiontocut=0.25, axis=None)` over
    all runs and tasks; `aggregate_median` and `aggregate_mean`, the median and the mean over
    tasks of the task means over runs; `aggregate_optimality_gap` with gamma = 1,
    1 - mean(min(scores, 1)) over all runs and tasks."""
    assert axis == -1
    scores = np.stack(columns, axis=-1)  # (..., runs, tasks)
    task_means = np.mean(scores, axis=-2)
    return np.stack([
        stats.trim_mean(scores.reshape(*scores.shape[:-2], -1), proportiontocut=0.25, axis=-1),
        np.median(task_means, axis=-1), np.mean(task_means, axis=-1),
        1.0 - np.mean(np.minimum(scores, 1.0), axis=(-2, -1))])


def aggregate_estimates(scores: Mapping[str, np.ndarray], seed: int = statistics.SEED,
                        resamples: int = statistics.RESAMPLES) -> dict[str, dict[str, Estimate]]:
    """For each learner of `scores` (learner -> runs x tasks matrix of normalised scores, a
    run an agent), the `AGGREGATES` across tasks (Agarwal et al. 2021, Sec. 4.3): the
    interquartile mean (the mean of the middle 50 % of all runs' scores), the median over
    tasks of the task means, the mean of the task means, and the optimality gap
    1 - mean(min(x, 1)) (how far below the classical controller), each with its 95 %
    percentile interval from the stratified bootstrap (Sec. 4.1: runs resampled within each
    task). The definitions are rliable 1.2.0's: `metrics.aggregate_iqm`, `aggregate_median`,
    `aggregate_mean`, `aggregate_optimality_gap` (gamma = 1), their intervals as
    `library.get_interval_estimates` computes them (`StratifiedBootstrap`, percentile).

    Each learner is resampled by itself from the same `seed`, so that its intervals do not
    depend on which learners stand beside it. A task with one run gives no interval (NaN);
    a NaN score is refused (rliable's matrices are full)."""
    estimates = {}
    for learner, matrix in scores.items():
        value, low, high = _stratified_bootstrap(_aggregates, task_columns(matrix, learner),
                                                 seed, resamples)
        estimates[learner] = {aggregate: Estimate(float(value[i]), float(low[i]), float(high[i]))
                              for i, aggregate in enumerate(AGGREGATES)}
    return estimates


@dataclasses.dataclass(frozen=True)
class Profile:
    """A performance profile: at each threshold tau, the fraction of runs' scores (over all
    tasks) above tau, with its interval (`low`, `high`)."""

    thresholds: np.ndarray
    fraction: np.ndarray
    low: np.ndarray
    high: np.ndarray


def _fractions_above(thresholds: np.ndarray):
    """The statistic of task columns (each `(..., runs)`) that gives, for each of
    `thresholds`, the fraction of all the matrix's scores strictly above it: an array
    `(thresholds, ...)` (rliable `library.py`, `run_score_deviation`: `np.mean(scores > tau)`).

    Counted without a thresholds x scores array: with the thresholds sorted, a score is
    above the j-th iff more than j thresholds lie below it, so the scores above the j-th are
    all those but the ones with at most j thresholds below."""
    order = np.argsort(thresholds, kind="stable")
    ascending = thresholds[order]
    count = len(thresholds)

    def fractions(*columns, axis=-1):
        assert axis == -1
        scores = np.stack(columns, axis=-1)
        rows = scores.reshape(-1, scores.shape[-2] * scores.shape[-1])
        below = np.searchsorted(ascending, rows, side="left")  # thresholds below each score
        offsets = (count + 1) * np.arange(len(rows))[:, None]
        at_most = np.cumsum(np.bincount((below + offsets).ravel(), minlength=len(rows) * (
            count + 1)).reshape(len(rows), count + 1), axis=-1)[:, :count]
        above = np.empty((len(rows), count))
        above[:, order] = (rows.shape[-1] - at_most) / rows.shape[-1]
        return np.moveaxis(above.reshape(*scores.shape[:-2], count), -1, 0)
    return fractions


def performance_profiles(scores: Mapping[str, np.ndarray], thresholds, seed: int = statistics.SEED,
                         resamples: int = statistics.RESAMPLES) -> dict[str, Profile]:
    """For each learner of `scores` (learner -> runs x tasks matrix of normalised scores),
    its score distribution F(tau) = (1 / (N M)) sum_m sum_n [x_{n,m} > tau] at each of
    `thresholds` (Agarwal et al. 2021, Sec. 4.2; N runs, M tasks: the fraction of runs above
    tau averaged over tasks), with 95 % percentile intervals from the stratified bootstrap
    (runs resampled within each task; all thresholds on the same resamples). The definition
    is rliable 1.2.0's `library.create_performance_profile` with its default
    `use_score_distribution=True` (`run_score_deviation`). Each learner is resampled by
    itself from the same `seed`; a task with one run gives no interval (NaN)."""
    thresholds = np.asarray(thresholds, dtype=float)
    if thresholds.ndim != 1 or len(thresholds) == 0 or not np.all(np.isfinite(thresholds)):
        raise ValueError("performance_profiles needs a one-dimensional list of finite thresholds")
    profile = _fractions_above(thresholds)
    profiles = {}
    for learner, matrix in scores.items():
        profiles[learner] = Profile(thresholds, *_stratified_bootstrap(
            profile, task_columns(matrix, learner), seed, resamples))
    return profiles


def improvement_across_tasks(x, y, seed: int = statistics.SEED,
                             resamples: int = statistics.RESAMPLES) -> Estimate:
    """P(X > Y) averaged over tasks (Agarwal et al. 2021, Sec. 4.3: (1/M) sum_m P(X_m > Y_m),
    P(X_m > Y_m) = (1 / (N K)) sum_i sum_j S(x_{i,m}, y_{j,m}), S = 1 where x > y, 1/2 where
    equal, 0 below: the Mann-Whitney U statistic over N K; per task
    `statistics.probability_of_improvement`) of the runs x tasks matrices `x` and `y` of
    normalised scores (the same tasks; N and K runs), with its 95 % percentile interval:
    each learner's runs resampled within each task (`statistics.interval`, each learner's
    task columns a sample). The definition is rliable 1.2.0's
    `metrics.probability_of_improvement` (identical columns give U / (N K) = 1/2, rliable's
    special case) with its interval as `library.get_interval_estimates` computes it for a pair
    (`StratifiedIndependentBootstrap`, percentile). A task with one run of either learner
    gives no interval (NaN)."""
    xs, ys = task_columns(x, "x"), task_columns(y, "y")
    if len(xs) != len(ys):
        raise ValueError(f"improvement_across_tasks needs the same tasks of x and y (x has "
                         f"{len(xs)}, y {len(ys)})")
    tasks = len(xs)

    def across_tasks(*columns, axis=-1):
        return np.mean([statistics.probability_of_improvement(x_m, y_m, axis=axis)
                        for x_m, y_m in zip(columns[:tasks], columns[tasks:])], axis=0)
    return statistics.interval(across_tasks, *xs, *ys, seed=seed, resamples=resamples)


def _decorate(ax, outward: float, labelsize: str):
    """rliable `plot_utils.py`, `_decorate_axis`: no top or right spine, the left and
    bottom ones thick and moved outward, ticks reduced to their labels."""
    ax.spines[["top", "right"]].set_visible(False)
    ax.spines[["left", "bottom"]].set_linewidth(2)
    ax.tick_params(length=0.1, width=0.1, labelsize=labelsize)
    ax.spines["left"].set_position(("outward", 10))
    ax.spines["bottom"].set_position(("outward", outward))


def plot_aggregates(estimates: Mapping[str, Mapping[str, Estimate]], figure_dir: str,
                    name: str) -> list:
    """The interval figure of `aggregate_estimates` in rliable's style (rliable 1.2.0
    `plot_utils.py`, `plot_interval_estimates`): a panel per aggregate, in each a horizontal
    bar per learner over its interval and a black tick at its value (no bar where there is
    no interval); saved as `figure_dir/name.png` and `.svg`; the paths."""
    from lwrl.analysis import plots  # sets matplotlib's backend before pyplot is imported
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    learners = list(estimates)
    aggregates = list(estimates[learners[0]])
    height, row = 0.6, 0.5  # rliable's interval_height; a learner's row, in inches
    figure, axes = plt.subplots(1, len(aggregates), squeeze=False,
                                figsize=(3.4 * len(aggregates), row * len(learners)))
    figure.subplots_adjust(left=0.0, right=1.0, bottom=0.0, top=1.0, wspace=0.11)
    for column, (ax, aggregate) in enumerate(zip(axes[0], aggregates)):
        for y, learner in enumerate(learners):
            estimate = estimates[learner][aggregate]
            if math.isfinite(estimate.low):
                ax.barh(y, estimate.high - estimate.low, height=height, left=estimate.low,
                        color=COLORS[y % len(COLORS)], alpha=0.75)
            ax.vlines(estimate.value, y - 7.5 * height / 16, y + 6 * height / 16, color="k",
                      alpha=0.5)
        ax.set_yticks(range(len(learners)), learners if column == 0 else [],
                      fontsize="x-large")
        ax.set_ylim(-0.5, len(learners) - 0.5)
        ax.xaxis.set_major_locator(MaxNLocator(4))
        ax.set_title(aggregate, fontsize="xx-large")
        _decorate(ax, outward=5, labelsize="xx-large")
        ax.spines["left"].set_visible(False)
        ax.grid(True, axis="x", alpha=0.25)
    # Below the tick labels, half an inch under the panels (the saved figure's tight box
    # takes in the titles and labels outside the panels).
    figure.text(0.5, -0.5 / (row * len(learners)), "normalised score", ha="center", va="top",
                fontsize="xx-large")
    return plots.save_figure(figure, figure_dir, name)


def plot_profiles(profiles: Mapping[str, Profile], figure_dir: str, name: str) -> list:
    """The figure of `performance_profiles` in rliable's style (rliable 1.2.0
    `plot_utils.py`, `plot_performance_profiles`, with its legend): each learner's fraction
    of scores above tau against tau, its interval shaded; saved as `figure_dir/name.png` and
    `.svg`; the paths."""
    from lwrl.analysis import plots  # sets matplotlib's backend before pyplot is imported
    import matplotlib.pyplot as plt

    figure, ax = plt.subplots(figsize=(10, 5))
    for i, (learner, profile) in enumerate(profiles.items()):
        color = COLORS[i % len(COLORS)]
        ax.plot(profile.thresholds, profile.fraction, color=color, linewidth=2, label=learner)
        if np.isfinite(profile.low).any():
            ax.fill_between(profile.thresholds, profile.low, profile.high, color=color,
                            alpha=0.15, linewidth=0)
    ax.set_yticks([0.0, 0.25, 0.5, 0.75, 1.0])
    ax.set_xlabel(r"normalised score ($\tau$)", fontsize="x-large")
    ax.set_ylabel(r"fraction of agents with score $> \tau$", fontsize="x-large")
    ax.grid(True, alpha=0.2)
    _decorate(ax, outward=10, labelsize="x-large")
    ax.legend(fontsize="x-large", frameon=False)
    return plots.save_figure(figure, figure_dir, name)
