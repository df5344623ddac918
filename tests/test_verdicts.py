"""The reproduction's rules on hand-made tables whose verdict is known, and the statistics
they rest on: intervals, the probability of improvement, the half-split choice of alpha."""

import numpy as np
import pandas as pd
import pytest

from lwrl.analysis import plots
from lwrl.analysis import statistics as st
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
    assert [(c.agent.trace, c.agent.lam, c.agent.alpha, c.agents, c.seeds[0]) for c in chosen] == [
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
