"""The third benchmark's report judged by its rule (studies/paper/benchmark/third/report.py,
judging.py): on a tiny benchmark of two rows, it names every task and row, gives a verdict
per task at each budget point and the family's size, and is written again the same; the CPU
to the level is read from the runs' records at each agent's first evaluation at the level,
censored at the budget where never; a budget point's family spans every task; every row's
prior tuning is named."""

import pathlib

import numpy as np
import pandas as pd
import pytest
from test_aggregates import needs_rliable
from test_benchmark3 import TASK, shrink

from lwrl import outputs
from lwrl.analysis import task_verdict
from lwrl.runners import store
from lwrl.runners.store import RunStore
from lwrl.studies.paper.benchmark.third import benchmark, clock, figures, judging, rule, study

RIVAL = "true_online_sarsa"
"""The tiny benchmark's rival: a linear row, cheap, standing in for the rule's rivals."""


def two_rows(patch) -> None:
    """The tiny benchmark (test_benchmark3's `tiny`) with the paper's agent and `RIVAL`,
    judged as a rival, by `patch` (a `pytest.MonkeyPatch`)."""
    every_row = rule.rows
    shrink(patch)
    patch.setattr(rule, "rows", lambda task: [row for row in every_row(task)
                                              if row.label in ("paper", RIVAL)])
    patch.setattr(judging, "rivals", lambda task: [RIVAL])


@pytest.fixture(scope="module")
def computed(tmp_path_factory):
    """A directory of the `two_rows` benchmark, run once for the module."""
    out = str(tmp_path_factory.mktemp("b3"))
    with pytest.MonkeyPatch.context() as patch:
        two_rows(patch)
        benchmark.benchmark([TASK], out, "lwrl bench run", sweep={"workers": 1})
    return out


@pytest.fixture
def judged(computed, monkeypatch):
    """`computed`, with the `two_rows` patches held for the test that reads it (and only
    for it: the module's other tests see the rule as it is)."""
    two_rows(monkeypatch)
    return computed


def report_of(out: str) -> list:
    """The report `lwrl bench report` writes of `out`, its lines but the first paragraph's
    (which says how long the writing took)."""
    with open(benchmark.rebuild(out, "lwrl bench report")) as file:
        return file.read().splitlines()[3:]


@pytest.fixture(scope="module")
def reported(computed):
    """`report_of(computed)` under the `two_rows` patches, written once for the module (its
    figures beside it in `computed`), for the tests that read the report."""
    with pytest.MonkeyPatch.context() as patch:
        two_rows(patch)
        return report_of(computed)


def test_the_report_names_every_task_and_row_a_verdict_per_task_and_the_familys_size(judged,
                                                                                       reported):
    text = "\n".join(reported)
    assert f"## {TASK}" in reported
    for label in ("paper", RIVAL):
        assert any(line.startswith(f"| {label} | 3 |") for line in reported), label
    runs = study.read_longer(study.read_task(TASK, judged, partial=True), judged)
    found = judging.judge([runs], judged)
    allowed = (*task_verdict.VERDICTS, "not run", judging.NOT_ALL_RUN)
    summary = next(line for line in reported if line.startswith(f"| {TASK} |"))
    words = [cell.strip().strip("*") for cell in summary.split("|")[2:-1]]
    assert words == [found[name][0][0].verdict[0] for name in judging.POINTS]
    assert all(word in allowed for word in words)
    assert sum(line.startswith("Verdict: **") for line in reported) == len(judging.POINTS)
    # one comparison run at each point, in the rule's whole family (here the two rows' rule)
    family = judging.family_size()
    assert {size for _, size in found.values()} == {1}
    assert text.count(f"1 comparison run, of the rule's family of {family}") == len(judging.POINTS)
    assert f"start at 0.05 / {2 * family} each" in text
    at_one = reported.index("### At 1 times the budget")
    comparison = next(line for line in reported[at_one:] if line.startswith(f"| {RIVAL} | "))
    assert found["1"][0][0].comparisons[0].final.outcome in comparison
    assert "## The rows' centres: their prior tuning" in reported
    assert "## Provenance" in reported and "## Aggregates across tasks (rliable)" in reported


def test_each_stage_costs_the_ledgers_cpu_of_its_runs_and_the_rest_is_named(judged, reported):
    """The tiny benchmark ran its task's searches and rows (stage 1; stage 3 where a row
    still rose): every run the ledger names is a stage's, and the report's table gives each
    stage, what no stage holds yet, and the whole."""
    from lwrl.runners.store import ledger_lines, ledger_runs
    from lwrl.studies.paper.benchmark.third import disclosure

    runs = study.read_longer(study.read_task(TASK, judged, partial=True), judged)
    keys = disclosure.stage_keys([runs])
    assert keys[0] and not keys[1] and not keys[3]
    assert set(ledger_runs(ledger_lines(judged))) == set().union(*keys)
    table = reported[reported.index("## What each stage cost"):]
    names = [line.split(" | ")[0][2:] for line in table[6:12]]
    assert names == [*disclosure.STAGES, "the runs of rows not all written yet", "all"]


def test_the_report_is_written_again_the_same(judged, reported):
    """Written a second time, after `reported`: the same lines."""
    assert report_of(judged) == reported


def test_the_report_draws_each_tasks_rows_on_the_fine_clock(judged, reported):
    """A curve per row over the clock's points, the figure linked under the task's table;
    a curve's points are the row's means at its points, in their order."""
    image = f"![{TASK}-clock.png](figures/{TASK}-clock.png)"
    assert image in reported and reported.index(image) < reported.index("### At 1 times the budget")
    for suffix in ("png", "svg"):
        assert (pathlib.Path(judged) / "figures" / f"{TASK}-clock.{suffix}").stat().st_size > 0
    runs = study.read_task(TASK, judged, partial=True)
    fractions, estimates = figures.row_curve(runs.rows["paper"])
    assert list(fractions) == [clock.fraction(point) for point in sorted(runs.rows["paper"].scores)]
    assert [e.value for e in estimates] == [
        float(np.mean(runs.rows["paper"].scores[point])) for point in sorted(runs.rows["paper"].scores)]


def test_the_cpu_to_the_level_is_read_at_the_first_evaluation_at_it_censored_where_never():
    """Agents x points: the first reaches 0.5 at the second point, the second never (censored
    at the last point, its CPU there), the third (diverged at first: NaN) at the second."""
    scores = np.array([[0.1, 0.6, 0.7], [0.2, 0.3, 0.4], [np.nan, 0.5, 0.9]])
    cpu = np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 4.0], [1.5, 5.0, 6.0]])
    steps, seconds, reached = judging.to_level([10, 20, 40], scores, cpu)
    assert steps.tolist() == [20, 40, 20] and seconds.tolist() == [2.0, 4.0, 5.0]
    assert reached.tolist() == [True, False, True]


def test_the_report_reads_each_agents_cpu_to_the_level_from_its_runs_records(judged):
    """The paper's agents in the tiny benchmark: each agent's CPU and multiply-adds to the
    level are its record's `cpu_s` and `multiply_adds` in the run that ends at its first
    evaluation at 0.5, or at the budget's run where it never reaches it; the row's hosts are
    those its records name."""
    row = study.read_task(TASK, judged).rows["paper"]
    row_curve = judging.curve(TASK, row, judged, clock.POINTS[-1])
    pace = judging.pace_of(row_curve)
    for agent in range(len(pace.cpu)):
        at = [j for j in clock.POINTS if row.scores[j][agent] >= 0.5]
        run = row.trainings[at[0] if at else clock.POINTS[-1]]
        record = outputs.read_table(RunStore.records_file(judged, run.key))
        assert pace.cpu[agent] == record.cpu_s[record.agent == agent].item()
        assert pace.macs[agent] == record.multiply_adds[record.agent == agent].item() > 0
        assert pace.reached[agent] == bool(at) and pace.steps[agent] == run.budget
        assert record.host_cpu.iloc[0] in row_curve.hosts
    assert row_curve.hosts == (store.cpu(),)  # the tiny benchmark ran here


def test_a_row_not_rising_stands_at_4_times_the_budget_with_its_score_and_cpu_at_1(judged):
    """Carried past the budget: its curve to 4 times it holds its agents' scores and CPU at 1
    at every point past it, marked as carried."""
    row = study.read_task(TASK, judged).rows["paper"]
    row.longer = {}
    carried = judging.curve(TASK, row, judged, clock.VERDICTS[-1])
    at_one = judging.curve(TASK, row, judged, clock.POINTS[-1])
    past = len(clock.LONGER)
    assert carried.carried and not at_one.carried
    assert carried.steps[-1] == 4 * at_one.steps[-1]
    assert np.array_equal(carried.scores[:, :-past], at_one.scores)
    assert np.array_equal(carried.cpu[:, :-past], at_one.cpu)
    assert all(np.array_equal(carried.scores[:, -k], at_one.scores[:, -1])
               and np.array_equal(carried.cpu[:, -k], at_one.cpu[:, -1])
               for k in range(1, past + 1))


def test_a_points_family_is_the_rules_whatever_is_run():
    """Comparisons judged in the rule's whole family (39: the light-weight row against every
    rival the rule names, stream-AC(lambda) on the discrete tasks among them): one run alone
    has its "not worse" at 78 times its p value (the level 0.05 / 78 it starts at), a second
    run can only lower it (a level passed on), and a comparison not run stays out."""
    from lwrl.analysis import outcomes
    assert judging.family_size() == 39
    rng = np.random.default_rng(0)
    pairs = [(rng.normal(0.8, 0.1, 20), rng.normal(0.5, 0.1, 20)),
             (rng.normal(0.8, 0.1, 20), rng.normal(0.8, 0.1, 20))]

    def comparisons(count):
        return [judging.Comparison(f"task {i}", "dqn", True, pairs=(pair, pair))
                for i, pair in enumerate(pairs[:count])] + [judging.Comparison("x", "ppo", False)]

    alone, together = comparisons(1), comparisons(2)
    assert judging.judge_families(alone) == 1 and judging.judge_families(together) == 2
    assert together[-1].final is None and together[-1].pace == ""
    raw = outcomes.hypothesis_p_values(*pairs[0], outcomes.MARGIN)["not worse"]
    assert alone[0].final.adjusted["not worse"] == pytest.approx(min(1.0, 78 * raw))
    for hypothesis in ("not worse", "worse", "better"):
        assert (together[0].final.adjusted[hypothesis]
                <= alone[0].final.adjusted[hypothesis])
    assert judging.verdict(together[-1:]) == ("not run",
                                              "no comparison has both its rows run this far")


def test_a_task_whose_rivals_are_not_all_run_waits_for_them_unless_it_is_shown_worse():
    """A task with one rival run and one not: not the verdict of the one (it is against
    every rival), but "not all run", naming the missing rival and what the run one gives;
    "no" stands, since no rival still to run can undo it."""
    from lwrl.analysis import outcomes

    def against(outcome):
        gate = type("Gate", (), {"judged": True})()
        final = type("Final", (), {"outcome": outcome})()
        return judging.Comparison("t", "dqn", True, gate=gate, final=final,
                                  cpu_ratio=judging.NO_ESTIMATE)

    waiting = judging.Comparison("t", "ppo", False)
    assert judging.verdict([against(outcomes.NOT_WORSE)])[0] == task_verdict.PARTLY
    word, why = judging.verdict([against(outcomes.NOT_WORSE), waiting])
    assert word == judging.NOT_ALL_RUN and "ppo not run this far" in why and "partly" in why
    word, why = judging.verdict([against(outcomes.WORSE), waiting])
    assert word == task_verdict.NO and "shown worse than dqn" in why and "ppo" in why


def test_every_rows_centre_names_its_prior_tuning():
    """The rule's list: the acrobot's defaults and their seeds, the actor-critic's second
    search, the zoo's sets, the new rivals' authors; the paper's Fig. 2 elsewhere."""
    from lwrl.studies.paper.benchmark.third import disclosure
    said = {(task, row.label): disclosure.prior_tuning(task, row)
            for task in (*rule.STAGE_1, rule.TASKS[-1]) for row in rule.rows(task)}
    assert "seeds 0 to 19" in said["acrobot.swingup", "paper"]
    assert "Fig. 2" in said[TASK, "paper"] and "Fig. 2" in said["cartpole.balance", "paper"]
    assert "second benchmark's search" in said[rule.TASKS[-1], "actor_critic"]
    assert "zoo" in said[TASK, "dqn"] and "zoo" in said[rule.TASKS[-1], "sac"]
    assert "Elsayed" in said[TASK, "stream_q"] and "Mania" in said["acrobot.swingup", "ars"]
    lines = disclosure.prior_tuning_lines([TASK, "acrobot.swingup+physics"])
    assert sum(line.startswith(f"| {TASK} |") for line in lines) == len(rule.rows(TASK))
    assert not any("+physics" in line for line in lines)  # a variant runs its task's


@needs_rliable
def test_the_aggregates_come_with_their_figures(tmp_path, monkeypatch):
    """Across the aggregated tasks, the aggregates' and the profiles' figures are written
    beside their tables and linked, relative to the benchmark's directory (50 bootstrap
    resamples here: the figures, not the intervals, are tested)."""
    import functools
    from types import SimpleNamespace

    from lwrl.analysis import aggregates
    from lwrl.studies.paper.benchmark.third import verdict_tables
    for name in ("aggregate_estimates", "performance_profiles", "improvement"):
        monkeypatch.setattr(aggregates, name,
                            functools.partial(getattr(aggregates, name), resamples=50))
    rng = np.random.default_rng(0)
    tasks = [SimpleNamespace(task=task, curves={label: SimpleNamespace(
        scores=rng.uniform(0, 1, size=(5, 3))) for label in ("paper", RIVAL)})
        for task in verdict_tables.AGGREGATED]
    lines = verdict_tables.aggregate_lines({"1": (tasks, None)}, str(tmp_path))
    for name in ("aggregates-1", "profiles-1"):
        assert f"![{name}.png](figures/{name}.png)" in lines
        assert (tmp_path / "figures" / f"{name}.svg").stat().st_size > 0
    assert any(line.startswith("| paper | ") for line in lines)


def test_the_provenance_counts_the_tables_here_and_the_recorded_runs_that_keep_none(tmp_path):
    """Two runs' tables, one with records, and records of a training whose table is not
    kept: the provenance says so, and gives each run's commit and host."""
    from lwrl.studies.paper.benchmark.third import disclosure

    runs = tmp_path / "runs"
    (runs / "records").mkdir(parents=True)
    for key in ("a", "b"):
        pd.DataFrame({"run": [key], "steps": [1]}).to_csv(runs / f"{key}.csv.gz", index=False)
    for key in ("a", "c"):
        pd.DataFrame({"run": [key, key], "agent": [0, 1], "lwrl_version": "0.2.0",
                      "lwrl_commit": "abc", "host_cpu": "cpu", "python": "3.11.7",
                      "libraries": "numpy 2"}).to_csv(RunStore.records_file(tmp_path, key),
                                                       index=False)
    lines = disclosure.provenance_lines(str(tmp_path))
    assert lines[2] == ("2 runs have records (`runs/records/`): 1 of the 2 runs whose tables are "
                        "here, and 1 training whose tables are not kept here (their greedy "
                        "evaluations and records are what the rule reads); per commit, host and "
                        "libraries:")
    assert "| 2 | 0.2.0 | abc | cpu | 3.11.7 | numpy 2 |" in lines


def test_a_task_not_continued_carries_the_rows_not_rising_and_leaves_the_rising_unrun(
        judged, monkeypatch):
    """A task the plan does not continue past the budget (a variant, the continuous
    pendulum): a row still rising at 1 is not run at 4 times the budget, the others stand
    there with their scores at 1, carried. Here the paper's row is the one rising."""
    runs = study.read_task(TASK, judged)
    monkeypatch.setattr(clock, "rising", lambda scores: scores is runs.rows["paper"].scores)
    rising = {label: clock.rising(row.scores) for label, row in runs.rows.items()}
    assert sorted(rising.values()) == [False, True]
    study.carried(runs)
    for label, row in runs.rows.items():
        assert row.longer == (None if rising[label] else {}), label
        at_four = judging.curve(TASK, row, judged, clock.VERDICTS[-1])
        assert (at_four is None) == rising[label] and (at_four is None or at_four.carried)
