"""Tests with a margin, and their power: how a benchmark shows that one learner is not worse
than another (non-inferiority), is as good within a margin (equivalence) or is better
(superiority) on the mean of a score, and how many agents a row needs for that.

The test is Welch's one-sided t test of the difference of two means, d = mean(x) - mean(y),
shifted by the margin m > 0 (Chow, Shao & Wang 2008, "Sample Size Calculations in Clinical
Research", 2nd ed., sections 3.2.2-3.2.4; Welch 1947):

- non-inferiority, H0: mu_x - mu_y <= -m against H1: mu_x - mu_y > -m, rejects where
  t = (d + m) / se > t(1 - alpha, nu);
- superiority is the same test with m = 0;
- equivalence, H0: |mu_x - mu_y| >= m, is two one-sided tests (Schuirmann 1987, "A comparison
  of the two one-sided tests procedure and the power approach for assessing the equivalence
  of average bioavailability", J. Pharmacokin. Biopharm. 15:657-680), each at alpha: it
  rejects where (d + m) / se > t(1 - alpha, nu) and (m - d) / se > t(1 - alpha, nu);

with se = sqrt(s_x^2 / n_x + s_y^2 / n_y) and Welch-Satterthwaite's degrees of freedom
nu = se^4 / ((s_x^2 / n_x)^2 / (n_x - 1) + (s_y^2 / n_y)^2 / (n_y - 1)).

Power, from the standard deviations of the rows (planned, or measured in an earlier
benchmark): under a true difference delta the statistic (d + m) / se follows a noncentral t
of nu degrees of freedom and noncentrality (delta + m) / se, so the power of the one-sided
test is 1 - F_nct(t(1 - alpha, nu); nu, (delta + m) / se) (Chow, Shao & Wang 2008, 3.2.2;
Faul et al. 2007, "G*Power 3", Behav. Res. Methods 39:175-191, whose two-sample t test it
reproduces where the standard deviations are equal). The power of the two one-sided tests is
the probability that both reject, P(t(1 - alpha) - ncp_low < T < ncp_high - t(1 - alpha)) for
a central T, ncp_low = (delta + m) / se, ncp_high = (m - delta) / se (the normal shift
approximation of Chow, Shao & Wang 2008, 3.2.4, with t quantiles; exact where se is known).

Holm's procedure over a family of k tests compares its smallest p-value with alpha / k
(Holm 1979): a comparison planned to be shown whatever the family's other p-values is
planned at alpha / k (`family`), the level at which Holm's first step, and Bonferroni's every
step, rejects.
"""

import dataclasses
import math

import numpy as np
from scipy import optimize, stats

POWER = 0.8
"""The power a benchmark plans for."""
MOST_AGENTS = 100_000
"""The most agents per row `agents_needed` searches up to."""


@dataclasses.dataclass(frozen=True)
class OneSided:
    """A one-sided test's outcome: the difference of the means, its standard error, the
    statistic, Welch's degrees of freedom and the p-value."""

    difference: float
    se: float
    t: float
    dof: float
    p_value: float


def standard_error(sd_x: float, sd_y: float, n_x: int, n_y: int) -> tuple:
    """`(se, nu)`: the standard error of mean(x) - mean(y) and Welch-Satterthwaite's degrees
    of freedom (the module's formulas), from the rows' standard deviations and sizes."""
    if min(n_x, n_y) < 2:
        raise ValueError(f"a row needs at least 2 agents for a standard error; got {n_x} and {n_y}")
    vx, vy = sd_x ** 2 / n_x, sd_y ** 2 / n_y
    se = math.sqrt(vx + vy)
    if se == 0:
        return 0.0, float(n_x + n_y - 2)
    return se, se ** 4 / (vx ** 2 / (n_x - 1) + vy ** 2 / (n_y - 1))


def non_inferiority(x, y, margin: float) -> OneSided:
    """Welch's one-sided test that mean(x) is not worse than mean(y) by `margin` or more
    (H0: mu_x - mu_y <= -margin; `margin` 0: superiority), NaN dropped. Where both rows
    have no spread the p-value is 0 if the difference is above -margin, else 1."""
    x, y = (np.asarray(v, dtype=float) for v in (x, y))
    x, y = x[~np.isnan(x)], y[~np.isnan(y)]
    check_margin(margin)
    d = float(np.mean(x) - np.mean(y))
    se, dof = standard_error(float(np.std(x, ddof=1)), float(np.std(y, ddof=1)), len(x), len(y))
    if se == 0:
        above = d + margin > 0
        return OneSided(d, se, math.inf if above else -math.inf, dof, 0.0 if above else 1.0)
    t = (d + margin) / se
    return OneSided(d, se, t, dof, float(stats.t.sf(t, dof)))


def equivalence(x, y, margin: float) -> float:
    """The p-value of the two one-sided tests that |mu_x - mu_y| < `margin` (Schuirmann
    1987): the larger of the two one-sided p-values."""
    if margin <= 0:
        raise ValueError(f"an equivalence margin must be a positive number; got {margin}")
    lower = non_inferiority(x, y, margin)
    upper = non_inferiority(y, x, margin)
    return max(lower.p_value, upper.p_value)


def check_margin(margin: float) -> float:
    """`margin`, or a one-line ValueError: a margin is a finite number >= 0."""
    if not (math.isfinite(margin) and margin >= 0):
        raise ValueError(f"a margin must be a finite number >= 0; got {margin}")
    return margin


def level(alpha: float, family: int) -> float:
    """The level of a comparison planned to be shown in Holm's family of `family` tests at
    family-wise `alpha` whatever the other p-values: alpha / family (Holm's first step)."""
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must lie in (0, 1); got {alpha}")
    if family < 1:
        raise ValueError(f"a family holds at least 1 test; got {family}")
    return alpha / family


def power(sd_x: float, sd_y: float, n_x: int, n_y: int, margin: float = 0.0,
          difference: float = 0.0, alpha: float = 0.05, family: int = 1) -> float:
    """The power of the one-sided non-inferiority test (`non_inferiority`) with `margin`
    where the true difference of the means is `difference`, at `level(alpha, family)`:
    1 - F_nct(t(1 - a, nu); nu, (difference + margin) / se)."""
    se, dof = standard_error(sd_x, sd_y, n_x, n_y)
    shift = difference + check_margin(margin)
    if se == 0:
        return 1.0 if shift > 0 else 0.0
    critical = stats.t.ppf(1 - level(alpha, family), dof)
    return float(stats.nct.sf(critical, dof, shift / se))


def equivalence_power(sd_x: float, sd_y: float, n_x: int, n_y: int, margin: float,
                      difference: float = 0.0, alpha: float = 0.05, family: int = 1) -> float:
    """The power of the two one-sided tests with `margin` where the true difference is
    `difference` (the module's formula, clipped at 0 where the margin is too narrow for
    the standard error)."""
    se, dof = standard_error(sd_x, sd_y, n_x, n_y)
    if se == 0:
        return 1.0 if abs(difference) < margin else 0.0
    critical = stats.t.ppf(1 - level(alpha, family), dof)
    low, high = critical - (difference + margin) / se, (margin - difference) / se - critical
    return float(max(0.0, stats.t.cdf(high, dof) - stats.t.cdf(low, dof)))


def detectable_difference(sd_x: float, sd_y: float, n_x: int, n_y: int,
                          alpha: float = 0.05, family: int = 1, target: float = POWER) -> float:
    """The smallest shift delta + m that the one-sided test at `level(alpha, family)`
    detects with power `target`: the root of `power(..., margin=0, difference=s) = target`
    in s. For superiority it is the smallest true difference shown; for non-inferiority
    with margin m at a true difference 0, the smallest margin shown. Close to
    (t(1 - a, nu) + t(target, nu)) * se."""
    se, _ = standard_error(sd_x, sd_y, n_x, n_y)
    if se == 0:
        return 0.0
    def short(shift):
        return power(sd_x, sd_y, n_x, n_y, 0.0, shift, alpha, family) - target
    high = se
    while short(high) < 0:
        high *= 2
    return float(optimize.brentq(short, 0.0, high, xtol=1e-9 * se))


def agents_needed(sd_x: float, sd_y: float, margin: float, difference: float = 0.0,
                  alpha: float = 0.05, family: int = 1, target: float = POWER,
                  ratio: float = 1.0) -> int:
    """The fewest agents n of the row x (the row y with round(ratio * n), at least 2) for
    which the one-sided test with `margin` at a true `difference` has power `target` or
    more at `level(alpha, family)`; a ValueError where difference + margin <= 0 (no n
    does) or more than `MOST_AGENTS` would be needed."""
    if difference + check_margin(margin) <= 0:
        raise ValueError(f"no number of agents shows a difference of {difference} with margin "
                         f"{margin}: their sum must be positive")
    def enough(n):
        return power(sd_x, sd_y, n, max(2, round(ratio * n)), margin, difference, alpha,
                     family) >= target
    low, high = 2, 2
    while not enough(high):
        low, high = high, 2 * high
        if high > MOST_AGENTS:
            raise ValueError(f"more than {MOST_AGENTS} agents per row would be needed")
    while high - low > 1:  # power rises with n: the first n that is enough
        middle = (low + high) // 2
        low, high = (low, middle) if enough(middle) else (middle, high)
    return low if enough(low) else high
