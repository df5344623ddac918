"""analysis/aggregates.py: the aggregates across tasks that rliable computes, cross-checked
against lwrl's own (`analysis.verdicts`): the same point estimates to rounding, intervals
within Monte Carlo error of each other (rliable's resamples come from numpy's global
generator, lwrl's from scipy's bootstrap), the same every time and apart from the learners
beside.

rliable's library imports only where pandas is below 3 (rliable 1.2.0 needs arch < 8, and
arch 7 does not import with pandas 3): under pandas 3 these tests say so and skip; under
pandas 2 rliable's library must import."""

import numpy as np
import pandas as pd
import pytest

from lwrl.analysis import aggregates, statistics, verdicts

PANDAS_3 = int(pd.__version__.split(".")[0]) >= 3
needs_rliable = pytest.mark.skipif(PANDAS_3, reason=(
    f"rliable's library does not import with pandas {pd.__version__} (rliable 1.2.0 needs "
    f"arch < 8, arch 7 needs pandas < 3): pip install 'pandas<3' 'arch>=7,<8' rliable==1.2.0"))

RESAMPLES = 1000


def learners():
    """Three learners' runs x tasks matrices of normalised scores: 20, 15 and 100 runs."""
    rng = np.random.default_rng(7)
    return {"a": rng.gamma(2.0, 0.4, (20, 7)), "b": rng.normal(0.8, 0.4, (15, 7)),
            "c": np.minimum(rng.normal(0.95, 0.1, (100, 7)), 1.0)}


def close(ours, theirs):
    """Two intervals of one statistic within a fifth of the width of each other's ends."""
    width = max(theirs.high - theirs.low, 1e-9)
    return abs(ours.low - theirs.low) < 0.2 * width and abs(ours.high - theirs.high) < 0.2 * width


@needs_rliable
def test_the_aggregates_are_rliable_s_and_lwrl_s():
    scores = learners()
    theirs = aggregates.aggregate_estimates(scores, resamples=RESAMPLES)
    ours = verdicts.aggregate_estimates(scores, resamples=RESAMPLES)
    for learner in scores:
        for aggregate in verdicts.AGGREGATES:
            mine, rliable_s = ours[learner][aggregate], theirs[learner][aggregate]
            assert rliable_s.value == pytest.approx(mine.value, rel=1e-12, abs=1e-12)
            assert rliable_s.low < rliable_s.high and close(mine, rliable_s), (learner, aggregate)


@needs_rliable
def test_profiles_and_improvement_are_rliable_s_and_lwrl_s():
    scores = learners()
    thresholds = np.linspace(0.0, 2.0, 21)
    theirs = aggregates.performance_profiles(scores, thresholds, resamples=RESAMPLES // 2)
    ours = verdicts.performance_profiles(scores, thresholds, resamples=RESAMPLES // 2)
    library = pytest.importorskip("rliable.library")
    for learner in scores:
        assert theirs[learner].fraction.tolist() == pytest.approx(ours[learner].fraction.tolist())
        assert theirs[learner].fraction.tolist() == list(  # rliable's own profile function
            library.score_distributions(scores[learner], thresholds))
        width = np.maximum(theirs[learner].high - theirs[learner].low, 1e-9)
        assert np.all(np.abs(theirs[learner].low - ours[learner].low) <= 0.25 * width + 0.01)
        assert np.all(np.abs(theirs[learner].high - ours[learner].high) <= 0.25 * width + 0.01)
    rliable_s = aggregates.improvement(scores["a"], scores["b"], resamples=300)
    mine = verdicts.improvement_across_tasks(scores["a"], scores["b"], resamples=300)
    assert rliable_s.value == pytest.approx(mine.value, rel=1e-12) and close(mine, rliable_s)


@needs_rliable
def test_the_probability_of_improvement_counted_over_pairs_is_rliable_s_to_the_bit():
    """`aggregates.probability_of_improvement` gives rliable's `metrics.
    probability_of_improvement` to the bit, ties and equal tasks included, and so does the
    interval through rliable's bootstrap."""
    metrics = pytest.importorskip("rliable.metrics")
    library = pytest.importorskip("rliable.library")
    rng = np.random.default_rng(3)
    x, y = rng.integers(0, 5, (9, 7)) / 4.0, rng.integers(0, 5, (9, 7)) / 4.0  # many ties
    x[:, 0] = y[:, 0] = rng.normal(size=9)  # a task where both are equal: rliable's 0.5
    for a, b in ((x, y), (y, x), (x[:, :1], y[:, :1]), (rng.normal(size=(20, 3)),
                                                        rng.normal(size=(15, 3)))):
        assert aggregates.probability_of_improvement(a, b) == metrics.probability_of_improvement(
            a, b)
    ours = aggregates.improvement(x, y, resamples=40)
    with aggregates._seeded(statistics.SEED):
        values, intervals = library.get_interval_estimates(
            {"x,y": [x, y]}, metrics.probability_of_improvement, reps=40,
            confidence_interval_size=statistics.CONFIDENCE)
    assert (ours.value, ours.low, ours.high) == (*np.ravel(values["x,y"]),
                                                 *np.ravel(intervals["x,y"]))


@needs_rliable
def test_the_same_every_time_and_apart_from_the_learners_beside():
    scores = learners()
    np.random.seed(123)
    before = np.random.get_state()[1].copy()
    alone = aggregates.aggregate_estimates({"a": scores["a"]}, resamples=200)
    assert np.array_equal(np.random.get_state()[1], before)  # the global generator restored
    together = aggregates.aggregate_estimates(scores, resamples=200)
    assert together["a"] == alone["a"]
    assert aggregates.aggregate_estimates({"a": scores["a"]}, resamples=200) == alone


@needs_rliable
def test_bad_input_gets_one_line():
    half = np.full((10, 3), 0.5)
    for call, words in ((lambda: aggregates.improvement(half, half[:, :2]), "the same tasks"),
                        (lambda: aggregates.aggregate_estimates({"d": [[0.5, np.nan]]}),
                         "a score is NaN")):
        with pytest.raises(ValueError) as error:
            call()
        assert words in str(error.value) and "\n" not in str(error.value)


@pytest.mark.skipif(not PANDAS_3, reason="rliable's library imports under pandas 2")
def test_where_rliable_does_not_import_the_aggregates_say_why_in_one_line():
    with pytest.raises(RuntimeError) as error:
        aggregates.aggregate_estimates({"a": np.full((4, 2), 0.5)})
    assert "rliable.library does not import" in str(error.value)
    assert "pandas<3" in str(error.value) and "\n" not in str(error.value)
