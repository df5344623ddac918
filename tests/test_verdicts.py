"""The reproduction's rules on hand-made tables whose verdict is known, and the statistics
they rest on: intervals, the probability of improvement, the half-split choice of alpha; and
the comparison's statistics (`analysis.verdicts`) on cases whose answer is known by hand."""

import itertools
import sys

import numpy as np
import pandas as pd
import pytest

from lwrl.analysis import plots
from lwrl.analysis import statistics as st
from lwrl.analysis import verdicts
from lwrl.studies.paper import judging
from lwrl.studies.paper.items import fig5, table1, traces


def table(values, value="uptime_s", **cell):
    """A results table from an agents x episodes array, one run (`cell`), seeds 0..B-1."""
    values = np.asarray(values, dtype=float)
    agents, episodes = values.shape
    rows = pd.DataFrame({"agent": np.repeat(np.arange(agents), episodes),
                         "seed": np.repeat(np.arange(agents), episodes),
                         "episode": np.tile(np.arange(1, episodes + 1), agents),
                         value: values.ravel(), "diverged": False})
    cell = {"features": "nrbf", "trace": "replacing", "lam": 0.4, "alpha": 1.5, **cell}
    return rows.assign(run="run", **cell)


def test_a_mean_interval_holds_the_true_mean():
    sample = np.random.default_rng(0).normal(5.0, 1.0, 200)  # its mean 0.2 standard errors off
    estimate = st.mean_interval(sample)
    assert estimate.low < 5.0 < estimate.high
    assert 0.1 < estimate.high - estimate.low < 0.5  # about 4 standard errors of 0.07
    assert st.mean_interval(sample) == estimate  # a fixed seed: the same interval every time


def test_probability_of_improvement_and_its_interval():
    rng = np.random.default_rng(3)
    worse, better = rng.normal(0.0, 1.0, 50), rng.normal(3.0, 1.0, 50)
    assert st.probability_of_improvement(np.array([2.0, 2.0]), np.array([1.0, 2.0])) == 0.75
    ahead = st.improvement_interval(better, worse)
    assert ahead.value > 0.9 and st.outcome(ahead) == 1
    assert st.outcome(st.improvement_interval(better, worse, higher_is_better=False)) == -1
    level = st.improvement_interval(worse, rng.normal(0.0, 1.0, 50))
    assert st.outcome(level) == 0 and level.low < 0.5 < level.high


def test_a_stratified_range_keeps_each_run_apart():
    runs = [np.full(5, 10.0), np.full(5, 30.0), np.array([20.0, 21, 19, 20, 20])]
    estimate = st.range_interval(runs)
    assert estimate.value == 20.0 and 19.0 <= estimate.low <= estimate.high <= 21.0


def test_when_a_curve_stays_and_when_a_run_starts():
    condition = np.array([[1, 0, 1, 1, 1], [1, 1, 1, 1, 1], [1, 1, 1, 1, 0]], dtype=bool)
    assert st.first_from_which(condition).tolist() == [3, 1, 6]  # 6: never (5 episodes)
    assert st.first_run_of(condition, 3).tolist() == [3, 1, 1]
    assert st.first_run_of(condition, 5).tolist() == [6, 1, 6]


def test_touching_40_s_once_is_not_balancing():
    """Every agent is up 50 s in one episode of its own (5 to 14) and 20 s in the others: by
    the earlier rule (median first episode above 40 s: 9.5) that reproduced Fig. 5; the
    mean up-time over agents never stays above 40 s, so it does not."""
    uptime = np.full((10, 200), 20.0)
    uptime[np.arange(10), np.arange(4, 14)] = 50.0
    rows, verdict, *_ = fig5.judge(table(uptime))
    assert verdict == "no"
    assert dict((q, o) for q, o, _ in rows)[
        "episode from which the mean up-time over agents stays above 40 s to the end"].startswith("never")


@pytest.mark.parametrize("start, verdict", [(9, "yes"), (30, "partly"), (80, "no")])
def test_fig5_judges_the_episode_the_mean_stays_above_40_s(start, verdict):
    """Agents up 20 s until episode `start`, then 50 s but for one agent in one later
    episode (the mean stays above 40 s)."""
    uptime = np.full((10, 200), 20.0)
    uptime[:, start - 1:] = 50.0
    uptime[3, 150] = 10.0
    rows, judged, *_ = fig5.judge(table(uptime))
    assert judged == verdict
    assert rows[0][1].startswith(f"{start} [")


def test_table1_needs_agents_that_keep_balancing():
    """Six of ten agents balance 240 s from episode 80 on: learned by 80, yes. Balancing
    once at episode 60 and falling again counts only under the earlier rule."""
    uptime = np.full((10, 200), 30.0)
    uptime[:6, 79:] = 240.0
    uptime[6:, 59] = 240.0
    cells = pd.DataFrame([{"features": "nrbf", "trace": "accumulating", "lam": 0.7, "alpha": 0.5}])
    rows, verdict, *_ = table1.judge(table(uptime, trace="accumulating", lam=0.7, alpha=0.5),
                                     cells)
    assert verdict == "yes" and rows[0][1].startswith("80 [") and "6 of 10 agents learn" in rows[0][1]
    once = np.full((10, 200), 30.0)
    once[:, 59] = 240.0
    rows, verdict, *_ = table1.judge(table(once, trace="accumulating", lam=0.7, alpha=0.5),
                                     cells)
    assert verdict == "no" and rows[0][1].startswith("never")
    assert rows[2][1].startswith("60 [60, 60]")  # the first touch, a secondary row


def test_the_best_alpha_is_chosen_on_one_half_and_judged_on_the_other():
    """At alpha 0.1 the first half of the seeds does best and the second half worst: the
    choice is 0.1 (on the first half), and its number is the second half's."""
    halves = {0.1: (50.0, 10.0), 0.3: (40.0, 45.0)}
    results = pd.concat([table(np.repeat([[first], [first], [first], [first], [first],
                                          [second], [second], [second], [second], [second]],
                                         3, axis=1), alpha=alpha)
                         for alpha, (first, second) in halves.items()], ignore_index=True)
    choice = judging.choose(judging.per_agent(results, "uptime_s"), "uptime_s", False,
                          ("features", "trace", "lam"), ("alpha",))
    assert choice.cells["alpha"].tolist() == [0.1]
    assert sorted(choice.measured["seed"].unique()) == [5, 6, 7, 8, 9]
    assert judging.at(choice.measured, choice.cells.iloc[0])["uptime_s"].tolist() == [10.0] * 5
    assert "first half" in choice.how and "seeds 5–9" in choice.how


@pytest.mark.parametrize("outcomes, verdict", [
    ([0, 1, 1, 1, 1, 0, 0], "yes"), ([0, 1, 0, 0, 0, 0, 0], "partly"), ([0] * 7, "partly"),
    ([0, 1, 1, 1, 1, 1, -1], "partly"), ([0, -1, -1, 1, 0, 0, 0], "no")])
def test_trace_verdict_counts_decided_comparisons(outcomes, verdict):
    assert judging.trace_verdict(outcomes)[0] == verdict


def test_confirmation_runs_are_fresh_agents_at_the_chosen_cells():
    configs = traces.fig8_configs("analytic", False, "semi_implicit")
    cells = pd.DataFrame([{"features": "nrbf", "trace": "accumulating", "lam": 0.7, "alpha": 0.5},
                          {"features": "nrbf", "trace": "replacing", "lam": 0.4, "alpha": 0.1}])
    chosen = judging.at_cells(configs, cells, 50)
    assert [(c.settings.trace, c.settings.lam, c.settings.alpha, c.agents, c.seeds[0]) for c in chosen] == [
        ("replacing", 0.4, 0.1, 50, 10), ("accumulating", 0.7, 0.5, 50, 10)]


def test_the_claims_figure_draws_each_judged_quantity_beside_the_claim(tmp_path):
    """Fig. 5's evidence is the judged episode with its interval and the paper's 10; a
    confirmation run adds its own row, labelled, to the same panel."""
    uptime = np.full((10, 200), 20.0)
    uptime[:, 8:] = 50.0
    section = fig5.analyse(table(uptime), str(tmp_path), confirmation=table(uptime))
    assert [item.label for item in section.evidence] == [
        "mean over 10 agents, paper-sized run", "mean over 10 agents, confirmation run"]
    assert [item.judged for item in section.evidence] == [False, True]
    first = section.evidence[0]
    assert first.estimate.value == 9 and first.accepted == (5, 20) and first.paper == 10
    figure = plots.plot_claims(section.evidence, "claims")
    assert len(figure.axes) == 1
    assert [label.get_text() for label in figure.axes[0].get_yticklabels()] == [
        item.label for item in section.evidence]


def test_normalised_scores_put_random_at_0_and_classical_at_1_either_way():
    """Up-time (higher is better) and steps per episode (lower is better): the same formula."""
    uptime = verdicts.normalised_score([10.0, 60.0, 110.0, 160.0], random=[5.0, 15.0],
                                       classical=[100.0, 120.0], higher_is_better=True)
    np.testing.assert_allclose(uptime, [0.0, 0.5, 1.0, 1.5])
    steps = verdicts.normalised_score([500.0, 300.0, 100.0, 50.0], random=[450.0, 550.0],
                                      classical=[100.0], higher_is_better=False)
    np.testing.assert_allclose(steps, [0.0, 0.5, 1.0, 1.125])
    with pytest.raises(ValueError, match="classical and random means to differ"):
        verdicts.normalised_score([1.0], random=[2.0], classical=[2.0], higher_is_better=True)
    with pytest.raises(ValueError, match=r"classical mean \(100\) better than the random one"):
        verdicts.normalised_score([1.0], random=[500.0], classical=[100.0], higher_is_better=True)


def exact_two_sided_p(x, y):
    """By hand: every split of the pooled values into len(x) and len(y); twice the smaller
    one-sided share of splits at least as extreme as the observed difference of means."""
    pooled, observed = x + y, np.mean(x) - np.mean(y)
    differences = [np.mean([pooled[i] for i in chosen])
                   - np.mean([pooled[i] for i in range(len(pooled)) if i not in chosen])
                   for chosen in itertools.combinations(range(len(pooled)), len(x))]
    below = np.mean([d <= observed + 1e-12 for d in differences])
    above = np.mean([d >= observed - 1e-12 for d in differences])
    return min(1.0, 2 * min(below, above))


def test_the_permutation_test_is_exact_on_small_samples():
    assert verdicts.permutation_p_value([1, 2, 3], [4, 5, 6]) == pytest.approx(2 / 20)
    assert exact_two_sided_p([1, 2, 3], [4, 5, 6]) == pytest.approx(2 / 20)
    x, y = [1.0, 2.0, 4.0], [3.0, 5.0, 6.0, 7.0]  # 35 splits
    assert verdicts.permutation_p_value(x, y) == pytest.approx(exact_two_sided_p(x, y))


def test_the_permutation_test_rejects_separated_samples_with_a_fixed_seed():
    """C(60, 30) splits: Monte Carlo, 10 000 of them; none as extreme gives a one-sided
    1 / 10 001, two-sided twice that."""
    rng = np.random.default_rng(0)
    low, high = rng.normal(0.0, 1.0, 30), rng.normal(3.0, 1.0, 30)
    p = verdicts.permutation_p_value(low, high)
    assert p == pytest.approx(2 / (st.RESAMPLES + 1)) and p < 0.001
    assert verdicts.permutation_p_value(low, high) == p
    assert verdicts.permutation_p_value(low, rng.normal(0.0, 1.0, 30)) > 0.05
    with pytest.raises(ValueError, match="two one-dimensional samples"):
        verdicts.permutation_p_value([np.nan], [1.0])


def test_holm_on_the_textbook_case():
    corrected = verdicts.holm([0.01, 0.04, 0.03, 0.005])
    np.testing.assert_allclose(corrected.adjusted, [0.03, 0.06, 0.06, 0.02])
    assert corrected.rejected.tolist() == [True, False, False, True]
    np.testing.assert_allclose(verdicts.holm([0.5, 0.4]).adjusted, [0.8, 0.8])
    np.testing.assert_allclose(verdicts.holm([0.3, 0.9, 0.6]).adjusted, [0.9, 1.0, 1.0])  # capped
    with pytest.raises(ValueError, match=r"p-values in \[0, 1\]"):
        verdicts.holm([0.5, 1.5])


def agents(mean, seed, count=20):
    """`count` agents' normalised scores around `mean`."""
    return np.random.default_rng(seed).normal(mean, 0.1, count)


def test_learners_drawn_like_the_random_row_are_not_judged():
    verdict = verdicts.above_random_gate(agents(0.0, 1), agents(0.0, 2), agents(0.0, 0))
    assert not verdict.judged
    assert verdict.reason.startswith("not judged: ") and "A's interval" in verdict.reason
    assert "B's interval" in verdict.reason


def test_a_learner_beside_a_random_one_is_not_judged_naming_the_random_side():
    verdict = verdicts.above_random_gate(agents(1.0, 1), agents(0.0, 2), agents(0.0, 0),
                                         names=("nrbf", "dqn"))
    assert not verdict.judged
    assert "dqn's interval" in verdict.reason and "nrbf" not in verdict.reason
    assert verdict.a.low > verdict.random.high >= verdict.b.low


def test_learners_well_above_random_are_judged():
    verdict = verdicts.above_random_gate(agents(0.8, 1), agents(1.0, 2), agents(0.0, 0))
    assert verdict.judged and verdict.reason.startswith("judged: ")
    one_agent = verdicts.above_random_gate(agents(0.8, 1), agents(1.0, 2), [0.0])
    assert not one_agent.judged and "the random row has no interval" in one_agent.reason


def test_aggregates_of_known_matrices():
    """Task means 0, 1 and 5: median 1, mean 2; the IQM drops the lowest and the highest of
    the six scores (a quarter of six, rounded down, at each end): (0 + 1 + 1 + 4) / 4; the
    optimality gap 1 - mean(min(x, 1)) = 1 - 4/6. One outlier among eight scores moves the
    mean (and the median of two task means) and not the IQM, the middle four, all 1."""
    known = np.array([[0.0, 1.0, 4.0], [0.0, 1.0, 6.0]])
    outlier = np.array([[0.0, 1.0], [1.0, 1.0], [1.0, 1.0], [1.0, 10.0]])
    estimates = verdicts.aggregate_estimates({"known": known, "outlier": outlier}, resamples=200)
    assert list(estimates["known"]) == list(verdicts.AGGREGATES)
    assert [e.value for e in estimates["known"].values()] == pytest.approx([1.5, 1.0, 2.0, 1 / 3])
    assert [e.value for e in estimates["outlier"].values()] == pytest.approx([1.0, 2.0, 2.0, 0.125])
    for estimate in [*estimates["known"].values(), *estimates["outlier"].values()]:
        assert estimate.low <= estimate.value <= estimate.high
    assert estimates["outlier"]["IQM"].value == 1.0 and estimates["outlier"]["mean"].value == 2.0


def test_equal_scores_give_degenerate_intervals_and_one_run_none():
    half = np.full((10, 3), 0.5)
    for estimate in verdicts.aggregate_estimates({"half": half}, resamples=200)["half"].values():
        assert estimate.value == estimate.low == estimate.high == 0.5
    profile = verdicts.performance_profiles({"half": half}, [0.0, 0.5], resamples=200)["half"]
    assert profile.low.tolist() == profile.high.tolist() == profile.fraction.tolist() == [1.0, 0.0]
    improvement = verdicts.improvement_across_tasks(half, half, resamples=200)
    assert improvement.value == improvement.low == improvement.high == 0.5
    one_run = verdicts.aggregate_estimates({"one": np.array([[0.2, 0.4]])})["one"]["mean"]
    assert one_run.value == pytest.approx(0.3) and np.isnan(one_run.low) and np.isnan(one_run.high)


def test_intervals_are_reproducible_and_each_learner_s_own():
    rng = np.random.default_rng(5)
    scores = {"a": rng.normal(0.6, 0.3, (8, 3)), "b": rng.normal(0.9, 0.3, (8, 3))}
    state = np.random.get_state()
    estimates = verdicts.aggregate_estimates(scores, resamples=500)
    assert verdicts.aggregate_estimates(scores, resamples=500) == estimates  # the same numbers
    assert verdicts.aggregate_estimates({"b": scores["b"]}, resamples=500) == {"b": estimates["b"]}
    assert estimates["a"]["IQM"].low < estimates["a"]["IQM"].value < estimates["a"]["IQM"].high
    profiles = [verdicts.performance_profiles(scores, [0.5, 1.0], resamples=500)["a"]
                for _ in range(2)]
    assert all(np.array_equal(getattr(profiles[0], side), getattr(profiles[1], side))
               for side in ("fraction", "low", "high"))
    assert verdicts.improvement_across_tasks(scores["a"], scores["b"], resamples=500) == \
        verdicts.improvement_across_tasks(scores["a"], scores["b"], resamples=500)
    assert all(a == b for a, b in zip(np.random.get_state()[1], state[1]))  # global untouched


def test_performance_profiles_count_scores_strictly_above_each_threshold():
    half, thresholds = np.full((10, 3), 0.5), np.linspace(0.0, 1.0, 11)
    profiles = verdicts.performance_profiles({"half": half, "one": half + 0.5}, thresholds,
                                             resamples=200)
    assert profiles["half"].fraction.tolist() == [1.0] * 5 + [0.0] * 6  # above tau <= 0.4
    assert profiles["one"].fraction.tolist() == [1.0] * 10 + [0.0]
    mixed = np.array([[0.2, 0.8], [0.6, 1.2]])  # any order of thresholds; a score at tau: not above
    profile = verdicts.performance_profiles({"mixed": mixed}, [1.0, 0.0, 0.5, 0.2, 0.8],
                                            resamples=200)["mixed"]
    assert profile.fraction.tolist() == [0.25, 1.0, 0.75, 0.75, 0.25]
    assert np.all(profile.low <= profile.fraction) and np.all(profile.fraction <= profile.high)


def test_improvement_across_tasks_of_known_matrices():
    """Task 1: x {1, 2} against y {2, 2, 2}, the three pairs with x = 2 tied (1/2 each), the
    others below: 1.5 / 6; task 2: x {2, 3} above y {0, 0, 0}: 1; the mean over tasks 0.625."""
    x, y = np.array([[1.0, 2.0], [2.0, 3.0]]), np.array([[2.0, 0.0], [2.0, 0.0], [2.0, 0.0]])
    assert verdicts.improvement_across_tasks(x, y, resamples=200).value == 0.625
    half = np.full((10, 3), 0.5)
    improvement = verdicts.improvement_across_tasks(half + 0.5, half, resamples=200)
    assert (improvement.value, improvement.low, improvement.high) == (1.0, 1.0, 1.0)
    rng = np.random.default_rng(2)
    same = rng.normal(0.5, 0.2, (10, 3))
    level = verdicts.improvement_across_tasks(same, same, resamples=500)
    assert level.value == 0.5 and level.low < 0.5 < level.high
    with pytest.raises(ValueError, match="the same tasks"):
        verdicts.improvement_across_tasks(half, half[:, :2])
    with pytest.raises(ValueError, match="a score is NaN"):
        verdicts.aggregate_estimates({"diverged": np.array([[0.5, np.nan], [0.5, 0.5]])})


def test_aggregates_need_no_rliable(monkeypatch):
    for module in ("rliable", "rliable.library", "rliable.metrics", "rliable.plot_utils"):
        monkeypatch.setitem(sys.modules, module, None)  # an import of it fails
    assert verdicts.aggregate_estimates({"a": np.full((4, 2), 0.5)}, resamples=100)["a"][
        "IQM"].value == 0.5
    assert not hasattr(verdicts, "RLIABLE_NEEDED")


def test_aggregate_and_profile_figures_are_written(tmp_path):
    rng = np.random.default_rng(4)
    scores = {"half": rng.normal(0.5, 0.2, (10, 3)), "one": rng.normal(1.0, 0.2, (10, 3)),
              "single run": np.array([[0.7, 0.8, 0.9]])}  # no interval: a tick, no bar
    estimates = verdicts.aggregate_estimates(scores, resamples=200)
    profiles = verdicts.performance_profiles(scores, np.linspace(0.0, 1.5, 31), resamples=200)
    written = (verdicts.plot_aggregates(estimates, str(tmp_path), "aggregates")
               + verdicts.plot_profiles(profiles, str(tmp_path), "profiles"))
    assert [path.rsplit("/", 1)[1] for path in written] == [
        "aggregates.png", "aggregates.svg", "profiles.png", "profiles.svg"]
    assert all((tmp_path / name).stat().st_size > 1000 for name in
               ("aggregates.png", "aggregates.svg", "profiles.png", "profiles.svg"))


@pytest.fixture
def rliable_metrics():
    """rliable's metrics (the dev extra installs rliable 1.2.0): numpy and scipy only."""
    metrics = pytest.importorskip("rliable.metrics",
                                  reason="the cross-check needs rliable: pip install -e '.[dev]'")
    return metrics


@pytest.fixture
def rliable_library():
    """rliable's library, where it imports. It imports arch.bootstrap, and no arch imports
    beside rliable 1.2.0 (the newest rliable) with pandas 3 and numpy 2: rliable needs
    arch < 8; arch 7 does not import with pandas 3 (a TypeError: pandas 3's
    `deprecate_kwarg` takes other arguments), arch 6 and older are built against numpy 1,
    and pip refuses arch 8 beside rliable 1.2.0 (whose `random_state` arch 8 refuses)."""
    try:
        from rliable import library
    except Exception as error:  # arch 7 with pandas 3 fails with a TypeError, not an ImportError
        pytest.skip(f"the cross-check of the intervals needs rliable.library, which does not "
                    f"import here ({type(error).__name__}: {error}); rliable 1.2.0 needs "
                    f"arch < 8, and arch 7 does not import with pandas 3: run this file in a "
                    f"venv with rliable==1.2.0 and pandas < 3")
    state = np.random.get_state()  # rliable draws from numpy's global generator
    np.random.seed(0)
    yield library
    np.random.set_state(state)


def rliable_aggregates(metrics, scores):
    """rliable's `AGGREGATES` of a runs x tasks matrix `scores`, in `verdicts`' order."""
    return np.array([metrics.aggregate_iqm(scores), metrics.aggregate_median(scores),
                     metrics.aggregate_mean(scores), metrics.aggregate_optimality_gap(scores)])


def two_learners():
    """Two learners' runs x tasks matrices of normalised scores, of 20 and 15 runs."""
    rng = np.random.default_rng(7)
    return rng.gamma(2.0, 0.4, (20, 4)), rng.normal(0.8, 0.4, (15, 4))


def test_the_point_estimates_are_rliable_s(rliable_metrics):
    """The aggregates and the probability of improvement are rliable's to rounding."""
    a, b = two_learners()
    ours = verdicts.aggregate_estimates({"a": a, "b": b}, resamples=100)
    for learner, scores in (("a", a), ("b", b)):
        assert [estimate.value for estimate in ours[learner].values()] == pytest.approx(
            rliable_aggregates(rliable_metrics, scores), rel=1e-12, abs=1e-12)
    assert verdicts.improvement_across_tasks(a, b, resamples=100).value == pytest.approx(
        rliable_metrics.probability_of_improvement(a, b), rel=1e-12)


def test_the_intervals_are_rliable_s(rliable_metrics, rliable_library):
    """Intervals within a quarter of their width of rliable's (500 resamples, rliable's loop
    over them being slow; other resamples, drawn by another generator: the two differ by
    Monte Carlo error only), and the performance profiles' fractions rliable's."""
    metrics, library = rliable_metrics, rliable_library
    a, b = two_learners()
    _, intervals = library.get_interval_estimates(
        {"a": a, "b": b}, lambda scores: rliable_aggregates(metrics, scores), reps=500)
    ours = verdicts.aggregate_estimates({"a": a, "b": b}, resamples=500)
    for learner in ("a", "b"):
        for i, estimate in enumerate(ours[learner].values()):
            low, high = intervals[learner][:, i]
            assert abs(estimate.low - low) < 0.25 * (high - low)
            assert abs(estimate.high - high) < 0.25 * (high - low)
    thresholds = np.linspace(-0.5, 2.5, 31)
    profiles, _ = library.create_performance_profile({"a": a}, thresholds, reps=200)
    assert verdicts.performance_profiles({"a": a}, thresholds, resamples=200)[
        "a"].fraction.tolist() == list(profiles["a"])
    _, intervals = library.get_interval_estimates(
        {"a,b": [a, b]}, metrics.probability_of_improvement, reps=500)
    improvement = verdicts.improvement_across_tasks(a, b, resamples=500)
    low, high = np.ravel(intervals["a,b"])
    assert abs(improvement.low - low) < 0.25 * (high - low)
    assert abs(improvement.high - high) < 0.25 * (high - low)
