"""The second benchmark's rule (studies/paper/benchmark/judging.py) on synthetic scores whose
verdict is known: two learners no better than random are not judged; a clearly better and
far cheaper paper's agent gets yes, a clearly worse one no, one better but not 100 times
cheaper partly; Holm's correction runs across the whole family; the compute to the level
counts the first evaluation that reaches it, and the whole budget where none does."""

import dataclasses
import time

import numpy as np

from lwrl.studies.paper.benchmark import judging, protocol

BUDGET = 1000
RNG = np.random.default_rng(0)


def rows(**means):
    """Normalised scores of 20 agents per row at every fraction, each row at its mean at the
    end and a quarter of it before."""
    scores = {}
    for label, mean in means.items():
        final = mean + 0.05 * RNG.standard_normal(20)
        for fraction in protocol.FRACTIONS:
            scores[label, fraction] = final if fraction == 1.0 else final * 0.25
    return scores


def judge(scores, cpu):
    random_scores = 0.05 * RNG.standard_normal(20)
    comparisons = judging.holm_family(
        [judging.compare("task", scores, random_scores, rival) for rival in ("dqn", "ppo")])
    computes = {label: judging.compute(scores, label, BUDGET, cpu[label])
                for label in ("paper", "dqn", "ppo")}
    return comparisons, judging.verdict(comparisons, scores, computes)


def test_learners_no_better_than_random_are_not_judged():
    comparisons, verdict = judge(rows(paper=0.0, dqn=0.0, ppo=0.0),
                                 {"paper": 1e-6, "dqn": 1e-3, "ppo": 1e-3})
    assert verdict == "not judged"
    assert all(not c.gate.judged and "not judged" in c.gate.reason for c in comparisons)


def test_a_random_rival_leaves_its_comparison_unjudged_naming_it():
    comparisons, verdict = judge(rows(paper=0.9, dqn=0.0, ppo=0.8),
                                 {"paper": 1e-6, "dqn": 1e-3, "ppo": 1e-3})
    dqn, ppo = comparisons
    assert not dqn.gate.judged and "dqn's interval" in dqn.gate.reason and ppo.gate.judged
    assert verdict == "yes"  # against the one judged rival: better and 1/1000 of its compute


def test_the_verdicts_yes_no_and_partly():
    cpu = {"paper": 1e-6, "dqn": 1e-3, "ppo": 1e-3}
    assert judge(rows(paper=0.9, dqn=0.6, ppo=0.6), cpu)[1] == "yes"
    assert judge(rows(paper=0.6, dqn=0.9, ppo=0.6), cpu)[1] == "no"  # worse than DQN
    dear = {"paper": 1e-4, "dqn": 1e-3, "ppo": 1e-3}  # 1/10 of theirs, not 1/100
    assert judge(rows(paper=0.9, dqn=0.6, ppo=0.6), dear)[1] == "partly"
    dearer = {"paper": 1e-2, "dqn": 1e-3, "ppo": 1e-3}
    assert judge(rows(paper=0.9, dqn=0.6, ppo=0.6), dearer)[1] == "no"


def test_holm_adjusts_across_the_family():
    comparisons, _ = judge(rows(paper=0.9, dqn=0.6, ppo=0.9), {"paper": 1.0, "dqn": 1.0, "ppo": 1.0})
    dqn, ppo = comparisons
    assert dqn.significant and not ppo.significant
    assert dqn.p_value < ppo.p_value  # Holm: 2 p(1), then max(2 p(1), p(2))
    assert dqn.adjusted == min(1.0, 2 * dqn.p_value)
    assert ppo.adjusted == min(1.0, max(dqn.adjusted, ppo.p_value))


def test_the_compute_counts_the_first_evaluation_that_reaches_the_level():
    scores = {("paper", f): np.array(values) for f, values in
              zip(protocol.FRACTIONS, ([0.6, 0.1, 0.1], [0.2, 0.7, 0.1], [0.2, 0.7, 0.2],
                                       [0.9, 0.9, 0.3]))}
    steps, reached = judging.steps_to_level(scores, "paper", BUDGET)
    np.testing.assert_array_equal(steps, [100, 250, 1000])
    np.testing.assert_array_equal(reached, [True, True, False])
    compute = judging.compute(scores, "paper", BUDGET, 2e-3)
    assert (compute.reached, compute.agents) == (2, 3)
    assert np.isclose(compute.cpu_s.value, np.mean([0.2, 0.5, 2.0]))
    assert compute.macs is None
    amortised = judging.compute(scores, "paper", BUDGET, macs_per_step=lambda steps: 10 + 1000 / steps)
    assert np.isclose(amortised.macs.value, np.mean([10 * 100 + 1000, 10 * 250 + 1000, 10 * 1000 + 1000]))


def test_the_multiply_adds_of_a_row_are_its_learners_counts():
    """A row's counted multiply-adds per step are its learner's (`Learner.arithmetic`, over
    the steps of its run); none for the CMAC, which the counts do not cover."""
    from lwrl import agent
    from lwrl.runners.config import RunConfig
    from lwrl.studies.paper.benchmark import report

    config = RunConfig(task="mountain_car.cost_to_go")
    per_step = report.macs_per_step(config)
    counts = agent.learner("sarsa").arithmetic(config.settings, config.task_spec, 500)
    assert per_step(500) == counts.step.macs > 0
    assert report.macs_per_step(RunConfig(task="mountain_car.cost_to_go", features="cmac")) is None
    assert report.macs_per_step(None) is None


def test_the_report_judges_every_task_with_holm_across_them_and_aggregates(tmp_path):
    """Two tasks of synthetic rows: four comparisons in one Holm family, the verdicts and
    the aggregates across tasks in the document, its figures written (each task's search's
    among them)."""
    import pandas as pd

    from lwrl.studies.paper.benchmark import report, study

    def task_runs(task, random, classical):
        scores = rows(paper=0.9, dqn=0.5, ppo=0.1)
        return study.TaskRuns(task, {"random": random, "classical": classical},
                              {(label, 0): scores[label, 1.0] for label in ("paper", "dqn", "ppo")},
                              {"paper": 0, "dqn": 0, "ppo": 0}, scores, {}, pd.DataFrame())
    runs = [task_runs("mountain_car.cost_to_go", 900 + RNG.standard_normal(20),
                      50 + RNG.standard_normal(20)),
            task_runs("pendulum.swingup", 10 + RNG.standard_normal(20),
                      59 + 0.1 * RNG.standard_normal(20))]
    cpu = {(r.task, label): seconds for r in runs
           for label, seconds in (("paper", 1e-6), ("dqn", 1e-3), ("ppo", 1e-3))}
    judged = report.judge(runs, cpu)
    assert [len(j.comparisons) for j in judged] == [2, 2]
    ps = [c.p_value for j in judged for c in j.comparisons]
    adjusted = [c.adjusted for j in judged for c in j.comparisons]
    np.testing.assert_allclose(adjusted, judging.verdicts.holm(ps).adjusted)
    assert [j.verdict for j in judged] == ["yes", "yes"]  # PPO at 0.1 is above random: judged
    text = report.document(judged, "lwrl bench ...", time.perf_counter(), str(tmp_path / "figures"),
                           str(tmp_path))
    assert "## Across tasks" in text and "| paper | " in text and "IQM" in text
    assert (tmp_path / "figures" / "aggregates.png").exists()
    assert (tmp_path / "figures" / "profiles.png").exists()
    for r in runs:  # each task's search drawn, as Jordan et al. (2020) look at it
        assert (tmp_path / "figures" / f"{r.task}-sensitivity.png").exists()
        assert f"figures/{r.task}-sensitivity.png" in text


def test_the_report_says_which_agents_diverged_in_the_rows_and_the_search():
    """Two of the paper's 20 agents at half the budget diverged: the rows' line names them
    at the cart-pole's worst outcome, 0 s up. In the search, one configuration lost one of
    its three agents and another all three."""
    import pandas as pd

    from lwrl.studies.paper.benchmark import report, study
    scores = rows(paper=0.9, dqn=0.5, ppo=0.1)
    search_scores = {("paper", 0): np.array([0.2, np.nan, 0.4]),
                     ("paper", 1): np.full(3, np.nan), ("paper", 2): np.array([0.1, 0.3, 0.5])}
    runs = study.TaskRuns("cartpole.balance", {}, search_scores, {"paper": 2}, scores, {},
                          pd.DataFrame(), {("paper", 0.5): 2, ("dqn", 1.0): 0})
    assert report.diverged_line(runs) == (
        "Agents that diverged in training (weights no longer finite: they act no more) count "
        "the worst outcome of every episode, 0 (mean up-time per episode (s)): paper at 0.5, "
        "2 of 20.")
    assert report.diverged_line(dataclasses.replace(runs, diverged={})) == (
        "No row's agent diverged in training.")
    table = report.search_lines(runs)
    assert "| paper | 0 | 0.30 [0.20, 0.40] (1 of 3 diverged) |  |" in table
    assert "| paper | 1 | — (3 of 3 diverged) |  |" in table
    assert "| paper | 2 | 0.30 [0.10, 0.50] | **yes** |" in table
    assert "ranks last" in table[0]
