"""analysis/thresholds.py: thresholds that hold only where the whole interval is past them
(the second benchmark's CPU ratios that straddle 100), and exact Clopper-Pearson intervals
held to the beta quantiles that define them."""

import numpy as np
import pytest
from scipy import stats

from lwrl.analysis import thresholds
from lwrl.analysis.statistics import Estimate


def test_a_threshold_holds_only_past_the_whole_interval():
    # the second benchmark's ratios of the rivals' CPU to the paper's agent's: 127 [77, 192]
    # and 82 [53, 123] both straddle its 100
    for ratio in (Estimate(127, 77, 192), Estimate(82, 53, 123)):
        assert not thresholds.wholly_above(ratio, 100) and not thresholds.wholly_below(ratio, 100)
    assert thresholds.wholly_below(Estimate(0.004, 0.002, 0.009), 0.01)
    assert not thresholds.wholly_below(Estimate(0.004, 0.002, 0.011), 0.01)
    assert thresholds.wholly_above(Estimate(1.5, 1.1, 2.0), 1.0)
    assert not thresholds.wholly_below(Estimate(0.004, np.nan, np.nan), 0.01)  # no interval


@pytest.mark.parametrize("successes, n", [(7, 20), (0, 20), (20, 20), (13, 100)])
def test_clopper_pearson_is_the_beta_quantiles(successes, n):
    share = thresholds.success_share(np.arange(n) < successes)
    low = stats.beta.ppf(0.025, successes, n - successes + 1) if successes else 0.0
    high = stats.beta.ppf(0.975, successes + 1, n - successes) if successes < n else 1.0
    assert (share.value, share.low, share.high) == pytest.approx((successes / n, low, high),
                                                                 rel=1e-9)


def test_clopper_pearson_by_hand():
    # none of 20: the upper end solves (1 - p)^20 = 0.025
    assert thresholds.success_share(np.zeros(20, bool)).high == pytest.approx(
        1 - 0.025 ** (1 / 20), rel=1e-9)
    assert thresholds.every_episode([[1, 1, 1], [1, 0, 1], [1, np.nan, 1]]).tolist() == [
        True, False, False]


@pytest.mark.parametrize("call, words", [
    (lambda: thresholds.success_share(np.array([], bool)), "non-empty vector of truth values"),
    (lambda: thresholds.success_share([0.5, 1.0]), "non-empty vector of truth values"),
    (lambda: thresholds.every_episode([1, 0]), "agents x episodes"),
])
def test_bad_input_gets_one_line(call, words):
    with pytest.raises(ValueError) as error:
        call()
    assert words in str(error.value) and "\n" not in str(error.value)
