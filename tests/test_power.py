"""analysis/power.py against a textbook case and a simulation: the sample sizes G*Power 3
(Faul et al. 2007) gives for Cohen's d = 0.5 at 80 % power, and the rejection rates of
Welch's one-sided test (scipy's) on seeded normal samples beside the power the formulas
predict; the tests' own outcomes on data whose answer is known."""

import numpy as np
import pytest
from scipy import stats

from lwrl.analysis import power

SIMULATIONS = 4000


def test_textbook_sample_sizes_and_powers():
    # G*Power 3, t test of two independent means, d = 0.5, power 0.80, alpha 0.05: one tail
    # 51 a group (actual power 0.8059), two tails 64 a group (0.8015)
    assert power.agents_needed(1.0, 1.0, margin=0.0, difference=0.5) == 51
    assert power.power(1.0, 1.0, 51, 51, difference=0.5) == pytest.approx(0.8059, abs=5e-4)
    assert power.agents_needed(1.0, 1.0, margin=0.0, difference=0.5, alpha=0.025) == 64
    assert power.power(1.0, 1.0, 64, 64, difference=0.5, alpha=0.025) == pytest.approx(0.8015, abs=5e-4)
    # a margin shifts the difference: non-inferiority at margin 0.2 of a true 0.3 is d = 0.5
    assert power.agents_needed(1.0, 1.0, margin=0.2, difference=0.3) == 51
    # Holm over a family of 2 plans at alpha / 2: the two-tailed case's n
    assert power.agents_needed(1.0, 1.0, margin=0.0, difference=0.5, family=2) == 64


def rejections(sd_x, sd_y, n_x, n_y, shift, margin, alpha, seed):
    """How often Welch's one-sided test of mean(x) - mean(y) > -margin (scipy's) rejects on
    normal samples whose true difference is `shift`."""
    rng = np.random.default_rng(seed)
    x = shift + sd_x * rng.standard_normal((SIMULATIONS, n_x))
    y = sd_y * rng.standard_normal((SIMULATIONS, n_y))
    p = stats.ttest_ind(x + margin, y, axis=1, equal_var=False, alternative="greater").pvalue
    return float(np.mean(p < alpha))


@pytest.mark.parametrize("sd_x, sd_y, n_x, n_y, difference, margin, family", [
    (0.55, 0.34, 20, 20, 0.0, 0.4, 1),     # the second benchmark's pendulum spreads
    (0.55, 0.34, 40, 20, -0.05, 0.3, 10),  # unequal rows, a family
    (0.3, 0.3, 20, 20, 0.2, 0.0, 1),       # superiority
])
def test_power_matches_simulated_rejections(sd_x, sd_y, n_x, n_y, difference, margin, family):
    predicted = power.power(sd_x, sd_y, n_x, n_y, margin, difference, 0.05, family)
    simulated = rejections(sd_x, sd_y, n_x, n_y, difference, margin, 0.05 / family, seed=1)
    # 4000 draws: a binomial standard error of at most 0.008
    assert simulated == pytest.approx(predicted, abs=0.03)
    assert 0.1 < predicted < 0.95  # a case where the power says something


def test_detectable_difference_is_detected_with_the_power():
    shift = power.detectable_difference(0.55, 0.34, 20, 20, 0.05, 10)
    assert power.power(0.55, 0.34, 20, 20, 0.0, shift, 0.05, 10) == pytest.approx(power.POWER, abs=1e-6)
    simulated = rejections(0.55, 0.34, 20, 20, shift, 0.0, 0.005, seed=2)
    assert simulated == pytest.approx(power.POWER, abs=0.03)
    # the normal approximation (z(1 - a) + z(0.8)) * se lies just below the t test's
    se, _ = power.standard_error(0.55, 0.34, 20, 20)
    assert (stats.norm.ppf(0.995) + stats.norm.ppf(0.8)) * se < shift < 1.1 * (
        stats.norm.ppf(0.995) + stats.norm.ppf(0.8)) * se
    # more agents, a smaller detectable difference
    assert power.detectable_difference(0.55, 0.34, 80, 80, 0.05, 10) < shift / 1.9


def test_equivalence_power_matches_simulation():
    predicted = power.equivalence_power(0.3, 0.3, 30, 30, margin=0.25, difference=0.05)
    rng = np.random.default_rng(3)
    x = 0.05 + 0.3 * rng.standard_normal((SIMULATIONS, 30))
    y = 0.3 * rng.standard_normal((SIMULATIONS, 30))
    low = stats.ttest_ind(x + 0.25, y, axis=1, equal_var=False, alternative="greater").pvalue
    high = stats.ttest_ind(y + 0.25, x, axis=1, equal_var=False, alternative="greater").pvalue
    simulated = float(np.mean(np.maximum(low, high) < 0.05))
    assert simulated == pytest.approx(predicted, abs=0.03)
    assert 0.3 < predicted < 0.95


def test_tests_on_data_whose_answer_is_known():
    rng = np.random.default_rng(4)
    x, y = 0.9 + 0.05 * rng.standard_normal(20), 0.92 + 0.05 * rng.standard_normal(20)
    # x a little below y: not worse by 0.1, not better, equivalent within 0.1
    assert power.non_inferiority(x, y, 0.1).p_value < 0.001
    assert power.non_inferiority(x, y, 0.0).p_value > 0.5
    assert power.equivalence(x, y, 0.1) < 0.001
    # far below: non-inferiority not shown
    assert power.non_inferiority(x - 0.3, y, 0.1).p_value > 0.99
    # scipy's Welch test gives the same p-value
    expected = stats.ttest_ind(x + 0.1, y, equal_var=False, alternative="greater").pvalue
    assert power.non_inferiority(x, y, 0.1).p_value == pytest.approx(expected, rel=1e-12)
    # rows without spread (at a ceiling): decided by the difference alone
    assert power.non_inferiority(np.ones(20), np.ones(20), 0.1).p_value == 0.0
    assert power.non_inferiority(np.ones(20), np.ones(20), 0.0).p_value == 1.0


@pytest.mark.parametrize("call, words", [
    (lambda: power.non_inferiority([1.0, 2.0], [1.0, 2.0], -0.1), "margin must be a finite number >= 0"),
    (lambda: power.power(1.0, 1.0, 1, 20), "at least 2 agents"),
    (lambda: power.power(1.0, 1.0, 20, 20, alpha=1.5), "alpha must lie in (0, 1)"),
    (lambda: power.power(1.0, 1.0, 20, 20, family=0), "at least 1 test"),
    (lambda: power.agents_needed(1.0, 1.0, margin=0.0, difference=-0.1), "must be positive"),
    (lambda: power.equivalence([1.0, 2.0], [1.0, 2.0], 0.0), "positive number"),
])
def test_bad_input_gets_one_line(call, words):
    with pytest.raises(ValueError) as error:
        call()
    assert words in str(error.value) and "\n" not in str(error.value)
