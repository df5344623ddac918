"""analysis/graphical.py: the graphical procedure (Bretz et al. 2009) held to Holm's procedure
(statsmodels) where the graph is Holm's, to a hand-worked example, and the rule's graph of
margin tests to what the rule says it does."""

import gc

import numpy as np
import pytest
from statsmodels.stats.multitest import multipletests

from lwrl.analysis import graphical

# Two primary hypotheses H1, H2 at half the level each, each passing its level to a secondary
# one (H1 -> H3, H2 -> H4), each secondary passing on to the other primary (H3 -> H2,
# H4 -> H1): the graph of two primary and two secondary hypotheses of Bretz et al. 2009.
PAIRED_W = [0.5, 0.5, 0.0, 0.0]
PAIRED_G = [[0, 0, 1, 0], [0, 0, 0, 1], [0, 1, 0, 0], [1, 0, 0, 0]]


@pytest.mark.parametrize("m", [2, 3, 5, 10, 39])
def test_holm_s_graph_is_holm_s_procedure(m, monkeypatch):
    # statsmodels' Holm collects the garbage on every call (multitest.py, `gc.collect()`):
    # seconds a call in a test worker whose heap holds JAX's programs, nothing it computes
    monkeypatch.setattr(gc, "collect", lambda *generation: 0)
    rng = np.random.default_rng(m)
    weights, transitions = graphical.holm_graph(m)
    for _ in range(8):
        p = rng.uniform(0, 0.05, m) ** rng.uniform(0.5, 2)
        rejected, adjusted, _, _ = multipletests(p, alpha=0.05, method="holm")
        assert graphical.adjusted_p_values(p, weights, transitions) == pytest.approx(
            adjusted, rel=1e-9)
        assert graphical.rejected(p, weights, transitions, 0.05).tolist() == rejected.tolist()


def test_a_hand_worked_example():
    """p = (0.01, 0.005, 0.015, 0.022) on the paired graph. Algorithm 2: p / w is 0.02 for H1,
    0.01 for H2: H2 first, q = 0.01; its 1/2 passes to H4, and H3 -> H2 becomes H3 -> H4.
    Then H1 (0.02 against H4's 0.044), q = 0.02; its 1/2 to H3, H4 -> H1 becomes H4 -> H3.
    Then H3 at 0.015 / 0.5 = 0.03 (H4 0.044), q = 0.03; H4 takes the whole level: 0.022,
    q = max(0.022, 0.03) = 0.03. At alpha 0.025, Algorithm 1 rejects H2 (0.005 <= 0.0125)
    and H1 (0.01 <= 0.0125), not H3 (0.015 > 0.0125) nor H4 (0.022 > 0.0125)."""
    p = [0.01, 0.005, 0.015, 0.022]
    assert graphical.adjusted_p_values(p, PAIRED_W, PAIRED_G).tolist() == pytest.approx(
        [0.02, 0.01, 0.03, 0.03], abs=1e-15)
    assert graphical.rejected(p, PAIRED_W, PAIRED_G, 0.025).tolist() == [True, True, False, False]
    assert graphical.rejected(p, PAIRED_W, PAIRED_G, 0.03).tolist() == [True] * 4
    # the second order: H2 (0.03), H1 (0.04), then H3 (0.02 < 0.04) and H4 (0.023) at 0.04
    assert graphical.adjusted_p_values([0.02, 0.015, 0.010, 0.023], PAIRED_W, PAIRED_G).tolist(
        ) == pytest.approx([0.04, 0.03, 0.04, 0.04], abs=1e-15)


def test_algorithm_1_rejects_what_the_adjusted_p_values_reject():
    rng = np.random.default_rng(1)
    weights, transitions = graphical.margin_graph(5)
    for _ in range(200):
        p = rng.uniform(0, 0.03, 15) ** rng.uniform(0.3, 3)
        adjusted = graphical.adjusted_p_values(p, weights, transitions)
        assert graphical.rejected(p, weights, transitions, 0.05).tolist() == (
            adjusted <= 0.05).tolist()


def test_the_rule_s_graph():
    weights, transitions = graphical.margin_graph(39)
    assert weights[0::3] == pytest.approx([0.05 / 78 / 0.05] * 39)  # alpha / 78 each
    assert weights[1::3] == pytest.approx([1 / 78] * 39) and not weights[2::3].any()
    assert transitions.sum(axis=1) == pytest.approx(np.ones(117))
    assert transitions[0, 2] == 1.0  # "not worse" to its own "better", nothing else
    assert transitions[1, 3] == transitions[2, 4] == pytest.approx(1 / 77)


def test_better_is_tested_only_after_not_worse():
    weights, transitions = graphical.margin_graph(2)  # "not worse" and "worse" at 0.0125
    # not worse shown (0.001): "better" takes its 0.0125 and 0.012 is rejected
    p = [0.001, 0.99, 0.012, 0.5, 0.5, 0.5]
    assert graphical.rejected(p, weights, transitions, 0.05).tolist() == [
        True, False, True, False, False, False]
    # "better" at p 0.0001 with "not worse" not shown (its p 0.02 > 0.0125): nothing
    p = [0.02, 0.5, 0.0001, 0.5, 0.5, 0.5]
    assert not graphical.rejected(p, weights, transitions, 0.05).any()
    # a rejected "worse" passes a third of its level to each other primary: 0.0125 + 0.0042
    p = [0.016, 0.001, 0.99, 0.5, 0.5, 0.5]
    assert graphical.rejected(p, weights, transitions, 0.05).tolist()[:2] == [True, True]
    assert graphical.adjusted_p_values(p, weights, transitions)[0] == pytest.approx(0.016 / (
        0.25 + 0.25 / 3))


def test_the_family_wise_error_rate_holds_where_every_hypothesis_is_true():
    """Every comparison at d = -margin ("not worse" true at its boundary) gets p-values of
    one-sided tests on normal statistics: the share of simulated families with any
    rejection of a true hypothesis stays at or below 0.05."""
    rng = np.random.default_rng(2)
    comparisons, families = 6, 4000
    weights, transitions = graphical.margin_graph(comparisons)
    from scipy import stats
    z = rng.standard_normal((families, comparisons))  # (d + margin) / se, its null at 0
    shift = 2.0  # margin / se: "worse" and "better" tests see d = -margin
    p = np.stack([stats.norm.sf(z), stats.norm.sf(shift - z), stats.norm.sf(z - shift)],
                 axis=-1).reshape(families, -1)
    errors = np.mean([graphical.rejected(row, weights, transitions)[0::3].any() or
                      graphical.rejected(row, weights, transitions)[2::3].any() for row in p])
    assert 0.02 < errors <= 0.05 + 3 * np.sqrt(0.05 * 0.95 / families)


@pytest.mark.parametrize("call, words", [
    (lambda: graphical.rejected([0.1, 0.2], [0.6, 0.6], [[0, 1], [1, 0]]), "sum is at most 1"),
    (lambda: graphical.rejected([0.1, 0.2], [0.5, 0.5], [[0.5, 0.5], [1, 0]]), "zero diagonal"),
    (lambda: graphical.rejected([0.1], [0.5, 0.5], [[0, 1], [1, 0]]), "needs 2 p-values"),
    (lambda: graphical.rejected([0.1, 1.2], [0.5, 0.5], [[0, 1], [1, 0]]), "each in [0, 1]"),
    (lambda: graphical.rejected([0.1, 0.2], [0.5, 0.5], [[0, 1], [1, 0]], 2.0), "alpha must lie"),
    (lambda: graphical.margin_graph(0), "at least 1 comparison"),
])
def test_bad_input_gets_one_line(call, words):
    with pytest.raises(ValueError) as error:
        call()
    assert words in str(error.value) and "\n" not in str(error.value)
