"""The "faster" claim judged on learning curves, by the third benchmark's rule (docs/FINDINGS.md,
"The light-weight claim judged a third time", the rule's "'Faster', judged on curves"): the
area under the normalised-score curve over the budget, and the steps (or compute) to a level
with the agents that never reach it censored at the budget.

- The **area**: the trapezoid rule over the evaluation points, in steps, divided by the budget,
  sum_k (t_k - t_{k-1}) (s_{k-1} + s_k) / 2 / T over the points t_k <= T (the mean
  normalised score over the run; the span before the first evaluation adds nothing).
- The **time to the level** L: an agent's clock (steps, or its cumulative CPU) at its first
  evaluation with a score >= L; an agent that never reaches it (a diverged agent, whose
  scores are NaN, included) is right-censored at its clock's last point.
- The rows' distributions of that time by Kaplan-Meier (Kaplan & Meier 1958;
  `scipy.stats.ecdf` on `scipy.stats.CensoredData`), S(t) = prod_{t_i <= t} (1 - d_i / n_i),
  d_i the agents reaching the level at t_i, n_i those not yet reached nor censored before;
  the median, the first t with S(t) <= 1/2, with the 95 % interval of Brookmeyer & Crowley
  (1982): the times whose pointwise interval of S (log-log, Kalbfleisch & Prentice 2002)
  holds 1/2, from the first t where the band's lower end is <= 1/2 to the first where its
  upper end is (infinite where never: not reached within the clock).
- Two rows compared by the log-rank test (Mantel 1966; `scipy.stats.logrank`).
- The **restricted mean time** to tau, RMST = integral_0^tau S(t) dt (Royston & Parmar 2013,
  BMC Med. Res. Methodol. 13:152), and the ratio of two rows' RMST with a 95 % percentile
  bootstrap interval (`statistics.interval`: 10 000 resamples, seed 0, each row's agents
  resampled within the row).

The light-weight row is **faster** than a rival where its area is shown better (the
"better" hypothesis of `analysis.outcomes` rejected in the area's family) or its RMST ratio
to the rival's has an interval wholly below 1; **slower** where the area is shown worse
("worse" rejected) or that interval lies wholly above 1.
"""

import dataclasses
import math
import warnings

import numpy as np
from scipy import stats

from lwrl.analysis import statistics
from lwrl.analysis.statistics import Estimate

LEVEL = 0.5
"""The greedy normalised score whose first reaching is timed."""
FASTER, SLOWER, NOT_SHOWN, BOTH = "faster", "slower", "not shown", "faster and slower"


def _clock_and_scores(clock, scores, budget=None):
    """`(clock, scores)` as float arrays of shape agents x points (a clock of one row is
    every agent's), only the points with clock <= `budget` where it is given; a one-line
    ValueError where they do not fit or the clock does not rise."""
    scores, clock = np.asarray(scores, dtype=float), np.asarray(clock, dtype=float)
    if scores.ndim != 2 or scores.shape[1] == 0 or clock.shape not in (
            scores.shape[1:], scores.shape):
        raise ValueError(f"the curves need an agents x points array of scores and a clock of "
                         f"its points (shared, or per agent); got scores of shape "
                         f"{scores.shape} and a clock of shape {clock.shape}")
    clock = np.broadcast_to(clock, scores.shape)
    if np.any(np.diff(clock, axis=1) <= 0) or np.any(clock < 0) or not np.all(np.isfinite(clock)):
        raise ValueError("a curve's clock must be finite, >= 0 and rise from point to point")
    if budget is not None:
        inside = clock[0] <= budget
        if not np.all((clock <= budget) == inside):
            raise ValueError("the budget must cut every agent's clock at the same point")
        clock, scores = clock[:, inside], scores[:, inside]
        if clock.shape[1] == 0:
            raise ValueError(f"no evaluation point lies within the budget {budget}")
    return clock, scores


def area(steps, scores, budget: float):
    """Each agent's area under its normalised-score curve over the budget (the module's
    trapezoid over the points with steps <= `budget`, divided by `budget`): an array of one
    value per agent (NaN where a score is: a diverged agent's)."""
    if not budget > 0:
        raise ValueError(f"a budget must be a positive number of steps; got {budget}")
    steps, scores = _clock_and_scores(steps, scores, budget)
    return np.sum(np.diff(steps, axis=1) * (scores[:, 1:] + scores[:, :-1]) / 2, axis=1) / budget


def time_to_level(clock, scores, level: float = LEVEL):
    """`(times, reached)`: each agent's clock at its first evaluation with a score >= `level`
    and True, or its clock's last point and False where it never reaches it (censored). The
    clock is shared (steps) or per agent (cumulative CPU), agents x points; cut it at the
    budget first (the last point is where an agent is censored)."""
    clock, scores = _clock_and_scores(clock, scores)
    at = scores >= level  # NaN: never at the level
    reached = at.any(axis=1)
    first = np.where(reached, np.argmax(at, axis=1), scores.shape[1] - 1)
    return clock[np.arange(len(clock)), first], reached


def _censored(times, reached) -> stats.CensoredData:
    """The times as scipy's right-censored data."""
    times, reached = np.asarray(times, dtype=float), np.asarray(reached, dtype=bool)
    if times.ndim != 1 or times.shape != reached.shape or len(times) == 0:
        raise ValueError("a row's times and reached flags must be two vectors of one length")
    return stats.CensoredData(uncensored=times[reached], right=times[~reached])


@dataclasses.dataclass(frozen=True)
class Survival:
    """A row's Kaplan-Meier distribution of the time to the level: the distinct times, S just
    after each, and its pointwise 95 % band."""

    times: np.ndarray
    survival: np.ndarray
    low: np.ndarray
    high: np.ndarray


def kaplan_meier(times, reached) -> Survival:
    """The Kaplan-Meier estimate of S(t) = P(time to the level > t) (`scipy.stats.ecdf`) with
    its log-log pointwise 95 % band (where S is 0 the band is 0)."""
    result = stats.ecdf(_censored(times, reached))
    with warnings.catch_warnings():  # the log-log band is undefined where S is 0
        warnings.simplefilter("ignore", RuntimeWarning)
        band = result.sf.confidence_interval(statistics.CONFIDENCE, method="log-log")
    survival = result.sf.probabilities
    low, high = (np.where(survival == 0, 0.0, bound.probabilities) for bound in band)
    return Survival(result.sf.quantiles, survival, low, high)


def _first_at_or_below(times, curve, value: float) -> float:
    """The first of `times` where the step function `curve` is <= `value`; inf if none."""
    below = np.flatnonzero(curve <= value)
    return float(times[below[0]]) if len(below) else math.inf


def median(times, reached) -> Estimate:
    """The Kaplan-Meier median time to the level with its 95 % interval (Brookmeyer & Crowley
    1982, the module's): inf where S does not fall to 1/2 within the clock."""
    curve = kaplan_meier(times, reached)
    return Estimate(_first_at_or_below(curve.times, curve.survival, 0.5),
                    _first_at_or_below(curve.times, curve.low, 0.5),
                    _first_at_or_below(curve.times, curve.high, 0.5))


def logrank_p_value(x_times, x_reached, y_times, y_reached) -> float:
    """The two-sided p-value of the log-rank test of two rows' times to the level."""
    return float(stats.logrank(_censored(x_times, x_reached), _censored(y_times, y_reached),
                               alternative="two-sided").pvalue)


def restricted_mean(times, reached, tau: float, axis: int = -1):
    """integral_0^tau S(t) dt of the Kaplan-Meier S of `times` and `reached` (the module's
    RMST), vectorised over leading axes; S is held at its last value past the last time (a
    censored last time) and events come before censorings at a tied time. Computed as
    min(t_(1), tau) + sum_k S(t_(k)) (min(t_(k+1), tau) - min(t_(k), tau)) + S(t_(n))
    (tau - min(t_(n), tau)) over the times in order, S multiplied by (1 - 1 / n_k) at each
    event, n_k the agents still at risk (ties of d events give (1 - d / n), as a product)."""
    assert axis in (-1, np.ndim(times) - 1)
    times, reached = np.asarray(times, dtype=float), np.asarray(reached, dtype=bool)
    order = np.lexsort((~reached, times), axis=-1)  # by time, events first at a tie
    t = np.minimum(np.take_along_axis(times, order, axis=-1), tau)
    event = np.take_along_axis(reached, order, axis=-1)
    at_risk = times.shape[-1] - np.arange(times.shape[-1])
    survival = np.cumprod(np.where(event, 1.0 - 1.0 / at_risk, 1.0), axis=-1)
    spans = np.diff(np.concatenate([t, np.full(t.shape[:-1] + (1,), float(tau))], axis=-1),
                    axis=-1)
    return t[..., 0] + np.sum(survival * spans, axis=-1)


def restricted_mean_ratio(x_times, x_reached, y_times, y_reached, tau: float,
                          y_tau: float | None = None, seed: int = statistics.SEED,
                          resamples: int = statistics.RESAMPLES) -> Estimate:
    """RMST(x) to `tau` / RMST(y) to `y_tau` (by default `tau`: the budget, for steps) with its
    95 % percentile bootstrap interval, each row's agents (their times with their flags)
    resampled within the row. Where the rows' clocks differ (compute to the level: each
    agent censored at its own CPU at the budget), each row is restricted to its own clock's
    end, the largest of its agents' clocks at the budget."""
    x = (np.asarray(x_times, dtype=float), np.asarray(x_reached, dtype=bool))
    y = (np.asarray(y_times, dtype=float), np.asarray(y_reached, dtype=bool))
    _censored(*x), _censored(*y)  # checked
    y_tau = tau if y_tau is None else y_tau
    if not (tau > 0 and y_tau > 0):
        raise ValueError(f"a restriction time must be positive; got {tau} and {y_tau}")

    def ratio(x_rows, y_rows, axis=-1):
        x_rows, y_rows = (np.asarray(rows, dtype=int) for rows in (x_rows, y_rows))
        return (restricted_mean(x[0][x_rows], x[1][x_rows], tau)
                / restricted_mean(y[0][y_rows], y[1][y_rows], y_tau))
    return statistics.interval(ratio, np.arange(len(x[0])), np.arange(len(y[0])), seed=seed,
                               resamples=resamples)


def pace(area_rejected: dict, ratio: Estimate) -> str:
    """"faster", "slower", "not shown" (or "faster and slower" where the area and the ratio
    disagree) from the area's rejected hypotheses (`outcomes.Outcome.rejected`, keyed
    "better" and "worse") and the RMST ratio of light to rival."""
    faster = bool(area_rejected["better"]) or ratio.side(1.0) == -1
    slower = bool(area_rejected["worse"]) or ratio.side(1.0) == 1
    return BOTH if faster and slower else FASTER if faster else SLOWER if slower else NOT_SHOWN
