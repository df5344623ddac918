"""analysis/outcomes.py: a comparison's outcome by the third benchmark's rule on rows whose
answer is known, its p-values held to scipy's Welch tests, and the family's size at work."""

import numpy as np
import pytest
from scipy import stats

from lwrl.analysis import outcomes, power


def row(mean, sd, n, seed):
    """n agents' normalised scores around `mean`, exactly that mean and standard deviation."""
    z = np.random.default_rng(seed).standard_normal(n)
    return mean + sd * (z - z.mean()) / z.std(ddof=1)


def test_p_values_are_welch_s_one_sided_tests():
    x, y = row(0.8, 0.2, 20, 0), row(0.85, 0.3, 30, 1)
    p = outcomes.hypothesis_p_values(x, y, 0.1)
    welch = lambda a, b: stats.ttest_ind(a, b, equal_var=False, alternative="greater").pvalue
    assert p["not worse"] == pytest.approx(welch(x + 0.1, y), rel=1e-10)
    assert p["better"] == pytest.approx(welch(x, y), rel=1e-10)
    assert p["worse"] == pytest.approx(welch(y, x), rel=1e-10)


def test_outcomes_on_rows_whose_answer_is_known():
    rival = row(0.7, 0.05, 20, 2)
    cases = {"better": row(0.9, 0.05, 20, 3), "tie": row(0.7, 0.05, 20, 4),
             "a little short": row(0.65, 0.02, 100, 5), "far short": row(0.3, 0.05, 20, 6),
             "noisy": row(0.7, 0.6, 20, 7)}
    judged = dict(zip(cases, outcomes.judge([(x, rival) for x in cases.values()])))
    assert judged["better"].outcome == "better"
    assert judged["tie"].outcome == "not worse" and judged["tie"].equivalence < 1e-6
    # 0.05 below the rival: "worse" shown too, but within the margin it reads "not worse"
    assert judged["a little short"].rejected == {"not worse": True, "worse": True,
                                                 "better": False}
    assert judged["a little short"].outcome == "not worse"
    assert judged["far short"].outcome == "worse"
    assert judged["noisy"].outcome == "undecided"
    assert all(np.isnan(judged[k].detectable) for k in cases if k != "noisy")
    # the detectable difference at the procedure's first level, alpha / (2 x 5 comparisons)
    assert judged["noisy"].detectable == pytest.approx(power.detectable_difference(
        0.6, 0.05, 20, 20, 0.05, 10), rel=1e-9)
    assert judged["far short"].difference == pytest.approx(-0.4)


def test_a_larger_family_asks_more():
    """Non-inferiority with a p-value of about 0.002 is shown alone (at 0.025) and not in a
    family of 39 comparisons (at 0.05 / 78 = 0.00064) where nothing else is shown."""
    x, y = row(0.7, 0.1, 20, 8), row(0.7, 0.1, 20, 9)
    assert 0.00064 < outcomes.hypothesis_p_values(x, y)["not worse"] < 0.025
    assert outcomes.judge([(x, y)])[0].outcome == "not worse"
    noisy = (row(0.7, 0.6, 20, 10), row(0.7, 0.6, 20, 11))  # nothing shown
    family = outcomes.judge([(x, y)] + [noisy] * 38)
    assert [o.outcome for o in family[:2]] == ["undecided", "undecided"]
    # where the 38 others show "worse", their levels pass in equal parts to the 40 "not worse"
    # and "worse" hypotheses still open: "not worse" is tested at 0.05 / 40
    far = (row(0.2, 0.05, 20, 12), row(0.7, 0.05, 20, 13))
    p = outcomes.hypothesis_p_values(x, y)["not worse"]
    assert outcomes.judge([(x, y)] + [far] * 38)[0].adjusted["not worse"] == pytest.approx(
        40 * p, rel=1e-9)
    assert outcomes.judge([(x, y)] + [noisy] * 38)[0].adjusted["not worse"] == pytest.approx(
        78 * p, rel=1e-9)


def test_a_diverged_agent_is_not_dropped_and_an_empty_family_refused():
    x = np.append(row(0.9, 0.05, 20, 12), np.nan)
    for call, words in ((lambda: outcomes.judge([(x, row(0.7, 0.05, 20, 13))]), "worst outcome"),
                        (lambda: outcomes.judge([]), "at least one comparison")):
        with pytest.raises(ValueError) as error:
            call()
        assert words in str(error.value) and "\n" not in str(error.value)


def test_a_family_larger_than_the_comparisons_run_keeps_the_others_levels():
    """Comparisons not run keep their share of the level (p 1, never shown): one run alone
    in a family of 5 has its "not worse" at 10 times its p value, as it would beside four
    comparisons of equal rows whose hypotheses nothing shows; a family smaller than the
    comparisons run is refused in one line."""
    rng = np.random.default_rng(3)
    x, y = rng.normal(0.9, 0.1, 30), rng.normal(0.7, 0.1, 30)
    raw = outcomes.hypothesis_p_values(x, y)["not worse"]
    alone = outcomes.judge([(x, y)], family=5)[0]
    assert alone.adjusted["not worse"] == pytest.approx(min(1.0, 10 * raw))
    assert outcomes.judge([(x, y)], family=1)[0].adjusted == outcomes.judge([(x, y)])[0].adjusted
    with pytest.raises(ValueError, match="family must be a whole number of comparisons at least"):
        outcomes.judge([(x, y), (y, x)], family=1)
