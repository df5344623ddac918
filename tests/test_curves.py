"""analysis/curves.py: areas under hand-drawn curves, times to the level with censoring, the
Kaplan-Meier median, restricted mean and log-rank test held to hand-worked cases and scipy,
and the bootstrap ratio and the rule's "faster" on rows whose answer is known."""

import math

import numpy as np
import pytest
from scipy import stats

from lwrl.analysis import curves
from lwrl.analysis.statistics import Estimate

BUDGET = 100_000
POINTS = BUDGET * 2.0 ** (np.arange(-1, 25) / 3 - 6)  # the rule's clock, to 4 times


def test_the_area_is_the_trapezoid_over_the_budget():
    ramp = np.linspace(0, 1, 11)
    assert curves.area(ramp * BUDGET, ramp[None], BUDGET) == pytest.approx([0.5])
    steps = np.array([0.25, 0.5, 1.0, 4.0]) * BUDGET  # the point past the budget is left out
    scores = np.array([[1.0, 1.0, 1.0, 0.0], [0.0, 0.0, 1.0, 1.0], [0.0, 1.0, np.nan, 1.0]])
    assert curves.area(steps, scores, BUDGET)[:2].tolist() == pytest.approx([0.75, 0.25])
    assert np.isnan(curves.area(steps, scores, BUDGET)[2])
    on_the_clock = curves.area(POINTS, np.ones((1, len(POINTS))), BUDGET)[0]
    assert on_the_clock == pytest.approx(1 - POINTS[0] / BUDGET)  # nothing before 1.2 %


def test_the_time_to_the_level_is_censored_where_it_is_not_reached():
    steps = np.array([10, 20, 40, 80])
    scores = np.array([[0.1, 0.6, 0.4, 0.9], [0.0, 0.2, 0.3, 0.49],
                       [np.nan] * 4, [0.5, 0.0, 0.0, 0.0]])
    times, reached = curves.time_to_level(steps, scores)
    assert times.tolist() == [20, 80, 80, 10] and reached.tolist() == [True, False, False, True]
    cpu = np.array([[1, 2, 3, 4], [10, 20, 30, 40], [5, 6, 7, 8], [2, 3, 4, 5]])
    times, _ = curves.time_to_level(cpu, scores)  # each agent's own clock
    assert times.tolist() == [2, 40, 8, 2]


def test_kaplan_meier_by_hand():
    """Times 1, 2, 3, 3 reached, two agents censored at 5: S = 5/6, 4/6, 2/6 after 1, 2, 3;
    the median is 3; the restricted mean to 5 is 1 + 5/6 + 4/6 + 2 x 2/6 = 19/6."""
    times, reached = np.array([1, 2, 3, 3, 5, 5]), np.array([1, 1, 1, 1, 0, 0], dtype=bool)
    curve = curves.kaplan_meier(times, reached)
    assert curve.times.tolist() == [1, 2, 3, 5]
    assert curve.survival == pytest.approx([5 / 6, 4 / 6, 2 / 6, 2 / 6])
    assert np.all(curve.low <= curve.survival) and np.all(curve.survival <= curve.high)
    median = curves.median(times, reached)
    assert median.value == 3 and median.low <= 3 <= median.high
    assert curves.restricted_mean(times, reached, 5) == pytest.approx(19 / 6)
    # a row that does not fall to 1/2 has no median within its clock
    assert curves.median([1, 5, 5], [True, False, False]).value == math.inf
    # 400 exponential times of median 50 ln 2 = 34.7, censored at 60: an interval around it
    drawn = np.random.default_rng(5).exponential(50.0, 400)
    large = curves.median(np.minimum(drawn, 60.0), drawn < 60.0)
    assert large.low < 50 * np.log(2) < large.high and large.high - large.low < 15


def test_the_restricted_mean_is_the_area_under_scipy_s_curve():
    rng = np.random.default_rng(0)
    times = rng.exponential(50.0, (30, 25)).round()  # ties among them
    reached = rng.uniform(size=times.shape) < 0.7
    tau = 60.0
    vectorised = curves.restricted_mean(times, reached, tau)
    for row in range(len(times)):
        sf = stats.ecdf(stats.CensoredData(uncensored=times[row][reached[row]],
                                           right=times[row][~reached[row]])).sf
        grid = np.concatenate([[0.0], sf.quantiles[sf.quantiles < tau], [tau]])
        area = np.sum(np.diff(grid) * sf.evaluate(grid[:-1]))
        assert vectorised[row] == pytest.approx(area, rel=1e-12)
    # censored only at the budget: the restricted mean is the plain mean of the times
    budgeted = np.minimum(times[0], tau)
    assert curves.restricted_mean(budgeted, budgeted < tau, tau) == pytest.approx(budgeted.mean())


def test_ratio_logrank_and_pace_on_rows_whose_answer_is_known():
    rng = np.random.default_rng(1)
    quick, slow = rng.uniform(5, 15, 100), np.minimum(rng.uniform(50, 150, 20), BUDGET)
    ratio = curves.restricted_mean_ratio(quick, np.ones(100, bool), slow, np.ones(20, bool),
                                         BUDGET, resamples=2000)
    assert ratio.value == pytest.approx(quick.mean() / slow.mean())
    assert ratio.high < 0.2 and curves.pace({"better": False, "worse": False}, ratio) == "faster"
    assert curves.logrank_p_value(quick, np.ones(100, bool), slow, np.ones(20, bool)) < 1e-6
    again = curves.restricted_mean_ratio(quick, np.ones(100, bool), slow, np.ones(20, bool),
                                         BUDGET, resamples=2000)
    assert again == ratio  # seed 0: the same interval every time
    # compute to the level: each row restricted to its own clock's end
    cpu = curves.restricted_mean_ratio(quick / 1000, quick > 12, slow, slow < 140, 0.015, 150.0,
                                       resamples=500)
    assert cpu.value == pytest.approx(curves.restricted_mean(quick / 1000, quick > 12, 0.015)
                                      / curves.restricted_mean(slow, slow < 140, 150.0))
    assert cpu.low < cpu.value < cpu.high < 0.001
    same = rng.uniform(5, 15, 20)
    level = curves.restricted_mean_ratio(same, np.ones(20, bool), same[::-1],
                                         np.ones(20, bool), BUDGET, resamples=2000)
    assert level.low < 1 < level.high
    assert curves.pace({"better": False, "worse": False}, level) == "not shown"
    assert curves.pace({"better": False, "worse": True}, level) == "slower"
    assert curves.pace({"better": True, "worse": False}, level) == "faster"
    assert curves.pace({"better": False, "worse": True}, Estimate(0.5, 0.3, 0.7)) == (
        "faster and slower")


@pytest.mark.parametrize("call, words", [
    (lambda: curves.area([1, 2], np.ones((2, 3)), 10), "agents x points"),
    (lambda: curves.area([2, 1, 3], np.ones((2, 3)), 10), "rise from point to point"),
    (lambda: curves.area([20, 30, 40], np.ones((2, 3)), 10), "no evaluation point"),
    (lambda: curves.area([1, 2, 3], np.ones((2, 3)), 0), "positive number of steps"),
    (lambda: curves.kaplan_meier([1, 2], [True]), "two vectors of one length"),
    (lambda: curves.restricted_mean_ratio([1, 2], [True] * 2, [1, 2], [True] * 2, 5, 0),
     "restriction time must be positive"),
])
def test_bad_input_gets_one_line(call, words):
    with pytest.raises(ValueError) as error:
        call()
    assert words in str(error.value) and "\n" not in str(error.value)
