"""The third benchmark's runs (studies/paper/benchmark/third): the clock's points and episodes,
the rows' seeds clear of every tuning seed, successive halving's choice on a fake scorer,
the acrobot's greedy starts that differ, a tiny benchmark resumed computing nothing twice, and
bad input refused with exit status 2."""

import dataclasses
import json
import pathlib

import numpy as np
import pandas as pd
import pytest

from lwrl import tasks
from lwrl.runners.store import RunStore
from lwrl.studies.paper.benchmark import compute_plan, evaluation, protocol
from lwrl.studies.paper.benchmark.third import clock, halving, rule, study

TASK = "mountain_car.cost_to_go"


def test_the_clock_has_twenty_points_log_spaced_to_the_budget_with_ten_episodes_at_the_verdicts():
    """2^(j/3 - 6) of the budget for j = -1 ... 18: 1.2 % to 100 %, 1/4 and 1/2 among them;
    10 greedy episodes at 1/4 and 1, one elsewhere; every run the row's whole run cut."""
    fractions = [clock.fraction(j) for j in clock.POINTS]
    assert len(fractions) == compute_plan.EVALUATIONS == 20
    assert fractions[0] == pytest.approx(0.0124, abs=1e-4) and fractions[-1] == 1.0
    assert {0.25, 0.5, 1.0} <= set(fractions)
    assert np.allclose(np.diff(np.log2(fractions)), 1 / 3)
    for task, budget in protocol.BUDGETS.items():
        steps = list(clock.budgets(budget).values())
        assert steps[-1] == budget and all(np.diff(steps) > 0), task
    row = rule.rows(TASK)[0]
    full = rule.training(TASK, row, {}, rule.SEED, 3)
    runs = clock.trainings(full)
    assert [run.budget for run in runs.values()] == list(clock.budgets(full.budget).values())
    assert all(dataclasses.replace(run, budget=full.budget) == full for run in runs.values())
    episodes = {j: clock.evaluation_at(run).episodes for j, run in runs.items()}
    assert {j for j, count in episodes.items() if count == 10} == {12, 18}
    assert {count for j, count in episodes.items() if j not in (12, 18)} == {1}
    greedy = clock.evaluation_at(runs[18])
    assert greedy.seed == rule.SEED + evaluation.EVALUATION_SEED and not greedy.learn
    assert greedy.trained == runs[18].key


def test_a_row_rises_at_the_budget_where_its_agents_rise_from_half_of_it_beyond_chance():
    """The rise from 1/2 to 1 of the budget, per agent, with an interval wholly above 0."""
    rng = np.random.default_rng(0)
    half = rng.uniform(0.2, 0.6, 20)
    assert clock.rising({clock.HALF: half, 18: half + 0.1 + rng.normal(0, 0.02, 20)})
    assert not clock.rising({clock.HALF: half, 18: half + rng.normal(0, 0.05, 20)})
    assert not clock.rising({clock.HALF: half, 18: half})
    full = rule.training(TASK, rule.rows(TASK)[0], {}, rule.SEED, 2)
    longer = clock.longer_trainings(full)
    assert list(longer) == list(range(19, 25)) and longer[24].budget == 4 * full.budget
    assert all(dataclasses.replace(run, budget=full.budget, episodes=full.episodes) == full
               for run in longer.values())
    assert [clock.evaluation_at(run).episodes for run in longer.values()] == [1] * 5 + [10]


def seeds(first: int, count: int) -> set:
    """The training seeds of `count` agents from `first`, and their evaluations' starts."""
    return {first + b + offset for b in range(count) for offset in (0, evaluation.EVALUATION_SEED)}


def test_the_rows_seeds_and_starts_are_clear_of_every_seed_any_tuning_used():
    """Rows train on 3000 up, evaluated from 13 000 up; no tuning ever used any of those."""
    tuned = set().union(*(seeds(first, count) for first, count in rule.TUNING_SEEDS.values()))
    most = max(rule.agents(task, row) for task in rule.TASKS for row in rule.rows(task))
    assert most == compute_plan.LIGHT_AGENTS
    assert not seeds(rule.SEED, most) & tuned
    # the search's own seeds, every rung's, are the ones the rule discloses
    search = set().union(*(seeds(rule.SEARCH_SEED, s) for _, s, _ in compute_plan.SEARCH_RUNGS))
    assert search <= seeds(*rule.TUNING_SEEDS["the third benchmark's search"])
    assert not search & seeds(rule.SEED, most)


def test_the_acrobots_greedy_episodes_start_from_states_that_differ_the_same_for_every_row():
    """Each greedy episode of the acrobot from its own state within 0.1 of the rest, drawn from
    the agent's seed alone: every row's agent b starts where every other row's does."""
    task = "acrobot.swingup"
    runs = [clock.evaluation_at(clock.trainings(rule.training(task, row, {}, rule.SEED, 2))[18])
            for row in rule.rows(task)[:2]]
    assert runs[0].task_options == runs[1].task_options
    definition = tasks.definition("acrobot", "swingup", **runs[0].task_options)
    starts = definition.initial_states(np.random.default_rng(runs[0].seed), 10)
    assert len({tuple(start) for start in starts}) == 10
    assert np.abs(starts).max() <= 0.1 and np.abs(starts).max() > 0.05
    assert not tasks.definition("acrobot", "swingup").initial_states(
        np.random.default_rng(0), 3).any()  # the task itself starts at rest


def fake_table(config, quality: float) -> pd.DataFrame:
    """A greedy evaluation table of `config`'s agents whose Mountain-Car steps fall with
    `quality` (the fake scorer)."""
    steps = 1000.0 - 900.0 * quality
    return pd.DataFrame({"seed": list(config.seeds), "steps": [steps] * config.agents})


def test_successive_halving_keeps_the_best_quarter_of_each_rung_and_chooses_by_the_final_score():
    """A fake scorer that ranks the configurations by how near their alpha is to 0.5 at the
    rungs, and makes the last rung's scores those of the configurations' positions: the
    rungs shrink 32, 8, 2 on 2, 4 and 10 seeds to 1/8, 1/2 and 1 of the budget, each keeps the
    best quarter of the one before, and the choice is the better final score."""
    row = rule.rows(TASK)[0]
    configurations = halving.configurations(TASK, row)
    distance = {i: abs(np.log(c.get("alpha", 1.0) / 0.5)) for i, c in enumerate(configurations)}
    seen = []

    def evaluate(trainings, what, how):
        seen.append({name: (run.agents, run.budget, run.seed) for name, run in trainings.items()})
        if how is clock.evaluation_at:  # the last rung: a later configuration scores better
            quality = 0.5 + 0.01 * len(seen)
            return {j: fake_table(run, quality) for j, run in trainings.items()}, None
        return {i: fake_table(run, 1 / (1 + distance[i])) for i, run in trainings.items()}, None

    reference = {"random": np.array([1000.0]), "classical": np.array([100.0])}
    rungs, chosen, _ = study.search_row(TASK, row, "analytic", reference, evaluate)
    budget = protocol.BUDGETS[TASK]
    assert [len(rung) for rung in rungs] == [32, 8, 2]
    assert {v[:2] for v in seen[0].values()} == {(2, budget // 8)}
    assert {v[:2] for v in seen[1].values()} == {(4, budget // 2)}
    assert all({v[0] for v in stage.values()} == {10} for stage in seen[2:])
    assert {v[2] for stage in seen for v in stage.values()} == {rule.SEARCH_SEED}
    assert sorted(rungs[1]) == sorted(sorted(range(32), key=lambda i: distance[i])[:8])
    assert sorted(rungs[2]) == sorted(sorted(rungs[1], key=lambda i: distance[i])[:2])
    assert chosen == max(rungs[2])  # the second finalist, evaluated later, scores better


def test_the_choice_takes_the_better_mean_ties_to_the_larger_area_and_a_diverged_agent_is_worst():
    """The rungs keep the best means (a NaN, a diverged agent, the worst; ties to the earlier);
    the last rung's choice goes by the mean final score, then by the area, then the earlier."""
    scores = {0: [0.5, 0.5], 1: [0.9, np.nan], 2: [0.6, 0.6], 3: [0.5, 0.5]}
    assert halving.best(scores, 2) == [0, 2]
    assert halving.choose({4: ([0.8, 0.8], 0.3), 7: ([0.8, 0.8], 0.5)}) == 7
    assert halving.choose({4: ([0.9, 0.8], 0.3), 7: ([0.8, 0.8], 0.5)}) == 4
    assert halving.choose({4: ([0.8, 0.8], 0.5), 7: ([0.8, 0.8], 0.5)}) == 4


def test_step_sizes_are_drawn_within_four_times_the_centre_and_normalisation_is_a_choice():
    """Within x1/4 to x4 of the row's centre, and below the bound of a step size the learner
    takes up to one only (the actor-critic's beta, whose centre is its defaults); every deep
    row's and new rival's observation normalisation is drawn both ways, and no task has a
    row whose normalisation is not searched."""
    for task in (TASK, "pendulum.swingup-continuous"):
        for row in rule.rows(task):
            configurations = halving.configurations(task, row)
            assert len(configurations) == 32 and configurations[0] == row.settings
            centre = halving.search.start(task, row)
            for name in halving.STEP_SIZES:
                drawn = np.asarray([c[name] for c in configurations[1:] if name in c])
                if len(drawn):
                    ratio = drawn / centre[name]
                    assert ratio.min() >= 0.25 and ratio.max() <= 4.0, (row.label, name)
                    assert drawn.max() <= halving.CAPS.get((row.learner, name), np.inf)
    critic = rule.rows("pendulum.swingup-continuous")[0]
    assert (halving.search.start("pendulum.swingup-continuous", critic)["beta"]
            == halving.search.learner_settings("actor_critic", None).beta != 0.5)
    ars = next(row for row in rule.rows(TASK) if row.learner == "ars")
    assert {c["variant"] for c in halving.configurations(TASK, ars)[1:]} == {"v1", "v2"}
    for task in (TASK, "pendulum.swingup-continuous"):
        for row in rule.rows(task):
            if not rule.linear(task, row) and row.learner not in ("ars", "ars_continuous"):
                drawn = {c["normalize_observations"] for c in halving.configurations(task, row)[1:]}
                assert drawn == {False, True}, row.label
    assert all(halving.unsearched(task) == [] for task in rule.TASKS)


def test_a_searchs_programs_are_its_configurations_apart_in_a_setting_that_shapes_one(monkeypatch):
    """A rival whose search draws its step size and one choice that shapes its program (ARS's
    variant, a streaming learner's observation normalisation) makes two programs of its 32
    configurations; DQN, which draws its network, minibatch and buffer too, makes many; and
    configurations apart in settings each agent may have of its own make one."""
    rows = {row.label: row for row in rule.rows(TASK)}
    for row in rows.values():
        count, largest = halving.programs(TASK, row)
        assert 1 <= count <= 32 and (count == 32) == (largest == 1), row.label
    assert [halving.programs(TASK, rows[label])[0] for label in ("ars", "stream_q")] == [2, 2]
    assert halving.programs(TASK, rows["dqn"])[0] > 16
    centre = rows["dqn"].settings
    monkeypatch.setattr(halving, "configurations", lambda task, row: [
        dict(centre, learning_rate=rate) for rate in np.geomspace(1e-4, 1e-2, 32)])
    assert halving.programs(TASK, rows["dqn"]) == (1, 32)


@pytest.fixture
def tiny(monkeypatch):
    """The paper's agent alone on Mountain-Car, a budget of 1 000 steps, 3 agents, a search
    of 4 configurations on 1, 2 and 3 seeds, evaluation episodes capped at 200 steps; the
    row taken as still rising at the budget."""
    shrink(monkeypatch)


def shrink(monkeypatch):
    """The `tiny` benchmark's settings, by `monkeypatch` (a `pytest.MonkeyPatch`)."""
    monkeypatch.setitem(protocol.BUDGETS, TASK, 1000)
    monkeypatch.setattr(protocol, "SHORTEST_EPISODE", 100)
    monkeypatch.setattr(compute_plan, "SEARCH_RUNGS", ((4, 1, 0.125), (2, 2, 0.5), (1, 3, 1.0)))
    monkeypatch.setattr(halving, "CONFIGURATIONS", 4)
    monkeypatch.setattr(compute_plan, "LIGHT_AGENTS", 3)
    monkeypatch.setattr(evaluation, "STEP_CAP", 200)
    every_row = rule.rows
    monkeypatch.setattr(rule, "rows", lambda task: every_row(task)[:1])
    monkeypatch.setattr(clock, "rising", lambda scores: True)  # continued to 4 times


def test_a_variant_is_its_task_in_the_variants_environment_in_training_and_evaluation():
    """The cart-pole with observation noise: every run of it, and its evaluations, read noisy
    observations; its search is its task's (the same configurations)."""
    task = "cartpole.balance+noise"
    row = rule.rows(task)[0]
    runs = clock.trainings(rule.training(task, row, {}, rule.SEED, 2))
    assert all(run.observation_noise for run in runs.values())
    assert clock.evaluation_at(runs[18]).observation_noise == runs[18].observation_noise
    assert halving.configurations(task, row) == halving.configurations("cartpole.balance", row)
    nominal = rule.training("cartpole.balance", row, {}, rule.SEED, 2)
    assert dataclasses.replace(runs[18], observation_noise={}) == nominal


def test_a_tiny_third_benchmark_resumes_computing_nothing_twice(tiny, tmp_path, capsys):
    """Run, run again (nothing computed: the same ledger and tables), then lose one
    evaluation: that one alone is computed; the status then says nothing is left."""
    from conftest import run_cli
    out = str(tmp_path / "b3")
    status, _, err = run_cli(["bench", "run", TASK, "--out", out, "--rule", "3",
                              "--workers", "1"], capsys)
    assert status == 0, err
    assert json.loads((tmp_path / "b3" / rule.EDITION_FILE).read_text()) == {"rule": rule.EDITION}
    ledger = (tmp_path / "b3" / "compute.jsonl").read_text().splitlines()
    tables = {path.name: path.read_bytes() for path in (tmp_path / "b3" / "runs").glob("*.csv.gz")}
    # 4 + 2 rung runs, 20 runs of the finalist and of the row on the clock, and 6 past the
    # budget, each evaluated
    assert len(tables) == 2 * (4 + 2 + 20 + 20 + 6)
    report = (tmp_path / "b3" / "README.md").read_text()
    assert "| paper | 3 |" in report
    assert "(carried)" not in report and "not run |" not in report
    # the run continued past the budget is the row's run until the budget cuts it: every
    # episode the same but the one the budget cut
    row = study.read_task(TASK, out).rows["paper"]
    runs = RunStore(out).read([row.trainings[18], clock.longer_trainings(row.trainings[18])[19]])
    one, longer = (part for _, part in runs.groupby("budget"))
    columns = ["seed", "episode", "steps", "return"]
    for (_, cut), (_, going_on) in zip(one.groupby("seed"), longer.groupby("seed")):
        assert cut[columns].iloc[:-1].reset_index(drop=True).equals(
            going_on[columns].iloc[:len(cut) - 1].reset_index(drop=True))
        assert cut.steps.iloc[-1] < going_on.steps.iloc[len(cut) - 1]
    # again, without --rule: the directory says which benchmark it is; nothing is computed
    status, _, err = run_cli(["bench", "run", TASK, "--out", out, "--workers", "1"], capsys)
    assert status == 0, err
    assert (tmp_path / "b3" / "compute.jsonl").read_text().splitlines() == ledger
    assert {p.name: p.read_bytes() for p in (tmp_path / "b3" / "runs").glob("*.csv.gz")} == tables
    # an evaluation lost: that evaluation alone is computed again, its training's agents kept
    runs = study.read_task(TASK, out).rows["paper"]
    lost = clock.evaluation_at(runs.trainings[5])
    (tmp_path / "b3" / "runs" / f"{lost.key}.csv.gz").unlink()
    with pytest.raises(study.Unfinished):
        study.read_task(TASK, out)
    partial = study.read_task(TASK, out, partial=True)
    assert not partial.rows
    assert "1 of 20 greedy evaluations not written" in partial.unfinished["paper"]
    status, _, err = run_cli(["bench", "run", TASK, "--out", out, "--workers", "1"], capsys)
    assert status == 0, err
    added = (tmp_path / "b3" / "compute.jsonl").read_text().splitlines()[len(ledger):]
    assert [json.loads(line)["runs"] for line in added] == [[lost.key]]
    status, text, err = run_cli(["bench", "status", TASK, "--out", out], capsys)
    assert status == 0, err
    assert "search rung 3, configuration" in text and "on the clock 20/20 evaluated" in text
    assert "continued to 4 times it 6/6 evaluated" in text
    assert "20/20 evaluated; configuration" in text and "left" not in text  # nothing left


@pytest.mark.parametrize("argv, words", [
    (["bench", "run", "nope.task", "--rule", "3"], "unknown task 'nope.task'"),
    (["bench", "run", TASK, "--rule", "3", "--plant", "mujoco"], "analytic plant"),
])
def test_bad_input_is_one_line_and_exit_status_2(argv, words, tmp_path, capsys):
    from conftest import run_cli
    status, _, err = run_cli([*argv, "--out", str(tmp_path / "b3")], capsys)
    assert status == 2 and len(err) == 1 and words in err[0], err


def test_a_directory_of_one_benchmark_is_refused_to_the_other(tmp_path, capsys):
    from conftest import run_cli
    second = tmp_path / "b2"
    (second / "runs").mkdir(parents=True)
    status, _, err = run_cli(["bench", "run", TASK, "--rule", "3", "--out", str(second)], capsys)
    assert status == 2 and len(err) == 1 and "second benchmark" in err[0], err
    third = tmp_path / "b3"
    third.mkdir()
    (third / rule.EDITION_FILE).write_text(json.dumps({"rule": rule.EDITION}))
    status, _, err = run_cli(["bench", "run", TASK, "--rule", "2", "--out", str(third)], capsys)
    assert status == 2 and len(err) == 1 and "--rule 2" in err[0], err
    (third / rule.EDITION_FILE).write_text(json.dumps({"rule": "benchmark3-0"}))
    status, _, err = run_cli(["bench", "run", TASK, "--out", str(third)], capsys)
    assert status == 2 and len(err) == 1 and "benchmark3-0" in err[0], err


def test_the_status_of_a_directory_not_begun_estimates_every_rows_trainings(tmp_path):
    """Nothing run: every row of a task waits for its search, a variant's for its task's,
    each with the agent-steps and, at the second benchmark's rates, the CPU they will take."""
    from lwrl.studies.paper.benchmark.third import progress
    lines = progress.lines([TASK, "acrobot.swingup+physics"], str(tmp_path))
    assert lines[0].endswith("reference rows not run yet")
    rows = [line for line in lines if line.startswith("  ") and "not run:" not in line
            and not line.startswith("  about")]
    assert len(rows) == len(rule.rows(TASK)) + len(rule.rows("acrobot.swingup+physics"))
    assert all("agent-steps" in line for line in rows)
    assert sum("wait for its task's search" in line for line in rows) == len(
        rule.rows("acrobot.swingup+physics"))
    assert "ledger (" in lines[-1]


def test_a_rows_cpu_left_is_at_the_rate_its_own_network_took():
    """The continuous pendulum's TD3 row, 256 x 256, after a search of mostly 64 x 64 runs: its
    estimate reads the records of the longest 256 x 256 run, whose CPU per agent-step is more
    than twice the mean the ledger gives over the search's runs."""
    from lwrl.runners import records
    from lwrl.studies.paper.benchmark import progress as ledger
    from lwrl.studies.paper.benchmark.third import progress
    task = "pendulum.swingup-continuous"
    out = str(pathlib.Path(__file__).resolve().parents[1] / "docs" / "benchmark3")
    row = next(row for row in rule.rows(task) if row.label == "td3")
    state = progress.row_progress(task, row, out, "analytic", None, None)
    wide = [run for run in state.known if progress.network(run) == "256,256"]
    state.pending, state.later = wide[:3], 0
    seconds, text = progress.left(state, out, {row.label: state}, None)
    table = records.read(out, [max(wide, key=lambda run: run.budget)])
    rate = table["cpu_s"].sum() / table["steps"].sum()
    assert seconds == pytest.approx(rate * progress.steps(state.pending))
    assert "longest recorded run" in text
    assert rate > 2 * np.mean(list(ledger.cpu_per_agent_step(out, state.known).values()))
