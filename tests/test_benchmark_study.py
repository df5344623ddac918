"""The second benchmark's runs (studies/paper/benchmark/study.py) at a tiny scale, on
Mountain-Car with the paper's agent and its other trace (the other rows, deep ones among
them, take the same path through the sweep): every row searched and chosen, every fraction
of the budget trained and evaluated, the reference rows written once; a second call
computes nothing and gives the same scores, and neither does a third once the kept agents
are gone (a fresh clone has the committed tables only)."""

import dataclasses
import time

import numpy as np
import pytest

from lwrl.agent import jax_population
from lwrl.studies.paper.benchmark import evaluation, progress, protocol, report, search, study

TASK = "mountain_car.cost_to_go"


def shrink(monkeypatch, episodes: int) -> None:
    """2 agents a row, 2 configurations of 2 agents in the search, `episodes` greedy episodes
    an evaluation."""
    monkeypatch.setattr(protocol, "AGENTS", 2)
    monkeypatch.setattr(protocol, "SHORTEST_EPISODE", 100)
    monkeypatch.setattr(search, "CONFIGURATIONS", 2)
    monkeypatch.setattr(search, "SEEDS", (1000, 1001))
    monkeypatch.setattr(search, "AGENTS", 2)
    monkeypatch.setattr(evaluation, "EPISODES", episodes)


@pytest.fixture
def tiny(monkeypatch):
    monkeypatch.setitem(protocol.BUDGETS, TASK, 400)
    monkeypatch.setattr(protocol, "DEEP", {})
    every_row = protocol.rows
    monkeypatch.setattr(protocol, "rows", lambda task: every_row(task)[:2])  # paper's two traces
    shrink(monkeypatch, 2)
    monkeypatch.setattr(evaluation, "STEP_CAP", 200)


def test_a_tiny_benchmark_runs_resumes_and_needs_no_kept_agents_once_evaluated(tiny, tmp_path,
                                                                               capsys):
    """`lwrl bench run` writes the report with its command; the study then resumes."""
    from conftest import run_cli
    status, _, err = run_cli(["bench", "run", TASK, "--out", str(tmp_path), "--workers", "1"],
                             capsys)
    assert status == 0, err
    text = (tmp_path / "README.md").read_text()
    assert f"`lwrl bench run {TASK} --out {tmp_path} --workers 1`" in text
    assert (tmp_path / "figures" / f"{TASK}-curves.png").exists()
    assert (tmp_path / "costs.json").exists()
    runs = len(list((tmp_path / "runs").glob("*.csv.gz")))
    assert f"{runs} of the report's {runs} runs in `runs/`" in text  # the ledger counts each
    assert "Every run is on the analytic plant." in text
    first = study.study_task(TASK, str(tmp_path), sweep={"workers": 1})
    labels = [row.label for row in protocol.rows(TASK)]
    assert set(first.chosen) == set(labels) and len(first.search_scores) == 2 * len(labels)
    assert set(first.scores) == {(label, f) for label in labels for f in protocol.FRACTIONS}
    assert all(len(values) == 2 for values in first.scores.values())
    assert all(np.isfinite(values).all() for values in first.references.values())
    training = first.tables[first.tables["run"] == first.trainings["paper", 1.0].key]
    assert training.groupby("seed")["steps"].sum().tolist() == [400, 400]
    written = sorted(path.name for path in (tmp_path / "runs").iterdir())
    again = study.study_task(TASK, str(tmp_path), sweep={"workers": 1})
    assert sorted(path.name for path in (tmp_path / "runs").iterdir()) == written
    for name, values in first.scores.items():
        np.testing.assert_array_equal(again.scores[name], values)
    for path in (tmp_path / "runs").glob("*.agents.npz"):
        path.unlink()
    third = study.study_task(TASK, str(tmp_path), sweep={"workers": 1})
    assert not list((tmp_path / "runs").glob("*.agents.npz"))
    assert third.chosen == first.chosen
    judged = report.judge([first], {(TASK, "paper"): 1e-6})
    assert judged[0].verdict == "not judged"  # no rival row ran
    text = report.document(judged, "lwrl bench ...", time.perf_counter(), str(tmp_path / "figures"),
                           str(tmp_path))
    assert "| mountain_car.cost_to_go | **not judged** |" in text
    assert all(f"\n| {label} | " in text for label in labels)
    assert text.count("| **yes** |") == len(labels)  # one chosen configuration per row
    assert "](figures/mountain_car.cost_to_go-curves.png)" in text
    status = progress.task_lines(TASK, str(tmp_path))
    assert status[0].endswith("reference rows written") and len(status) == 1 + len(labels)
    for label, line in zip(labels, status[1:]):
        score = np.mean(third.search_scores[label, third.chosen[label]])
        assert (f"search 2/2 trained, 2/2 evaluated; configuration {third.chosen[label]} chosen, "
                f"search score {score:.2f}; rows (2 agents at 4 fractions) 4/4 trained, "
                "4/4 evaluated") in line
    late = evaluation.evaluation(search.runs(TASK)[labels[1], 1])
    (tmp_path / "runs" / f"{late.key}.csv.gz").unlink()  # one row's search not evaluated whole
    whole, unfinished = progress.task_lines(TASK, str(tmp_path))[1:]
    assert f"configuration {third.chosen[labels[0]]} chosen" in whole  # chosen before the other
    assert "search 2/2 trained, 1/2 evaluated; its rows wait for every row's search" in unfinished
    assert (tmp_path / "figures" / "mountain_car.cost_to_go-curves.png").exists()


@pytest.mark.skipif(jax_population.missing_jax(),
                    reason="the deep rows' settings are the JAX populations': pip install 'lwrl[jax]'")
def test_the_status_of_an_empty_directory_is_that_nothing_ran(tmp_path, capsys):
    """`lwrl bench status` reads the directory only: nothing run, nothing written; a task
    that is not the benchmark's is one line and status 2."""
    from conftest import run_cli
    status, printed, _ = run_cli(["bench", "status", TASK, "--out", str(tmp_path)], capsys)
    assert status == 0 and not list(tmp_path.iterdir())
    lines = printed.splitlines()
    assert lines[0] == f"{TASK} (analytic plant): reference rows not run yet"
    assert all("search 0/16 trained, 0/16 evaluated; its rows wait" in line for line in lines[1:-1])
    assert lines[-1].endswith("0 runs, 0.00 h of wall time, 0.00 h of CPU")
    status, _, err = run_cli(["bench", "status", "cartpole.swingup", "--out", str(tmp_path)], capsys)
    assert status == 2 and len(err) == 1 and "unknown benchmark task" in err[0]


@pytest.mark.skipif(jax_population.missing_jax(),
                    reason="the deep rows' settings are the JAX populations': pip install 'lwrl[jax]'")
def test_the_status_says_what_the_trainings_left_will_cost_from_the_ledger(tmp_path):
    """Mountain-Car's DQN: two search runs in the ledger, at 1 and 3 ms of CPU per agent-step
    (3 agents x 100 000 steps: 300 s and 900 s); their tables not being here, the 16 runs are
    left, at their mean, 2 ms (16 x 600 s = 2.7 h); the rows, one run of 20 agents' budget at
    the first's rate or the second's (2 000 s = 33 min, or 1.7 h). A line joining a family
    counts its longest run."""
    import json

    from lwrl.runners.store import RunStore
    budget = protocol.BUDGETS[TASK]
    runs = search.runs(TASK)
    first, second = runs["dqn", 0], runs["dqn", 1]
    ledger = [{"runs": [first.key], "cpu_s": 1e-3 * 3 * budget},
              {"runs": [second.key], "cpu_s": 3e-3 * 3 * budget}]
    (tmp_path / "compute.jsonl").write_text("".join(json.dumps(line) + "\n" for line in ledger))
    line, = (line for line in progress.task_lines(TASK, str(tmp_path)) if "  dqn " in line)
    assert line.endswith("its rows wait for every row's search (they will take 33 min to 1.7 h "
                         "of CPU, by the configuration chosen); about 2.7 h of CPU of trainings "
                         "left (its search's)")
    assert progress.cpu_per_agent_step(str(tmp_path), [first, second]) == {
        first.key: pytest.approx(1e-3), second.key: pytest.approx(3e-3)}
    row = next(row for row in protocol.rows(TASK) if row.label == "dqn")
    fractions = list(study.row_trainings(TASK, row, 0).values())
    assert progress.cpu_left(fractions, 1e-3) == pytest.approx(1e-3 * 20 * budget)
    kept = RunStore.resume_file(tmp_path, fractions[-1].key)  # the family's run, under way
    kept.parent.mkdir()
    np.savez(kept, document=np.array(json.dumps({"steps": 30_000, "cpu_s": 1200.0})))
    assert progress.under_way(str(tmp_path), fractions) == (
        f" (its run under way kept at 30,000 of {budget:,} steps)")
    assert progress.cpu_left(fractions, 1e-3, str(tmp_path)) == pytest.approx(  # its own 2 ms
        1200.0 / 30_000 * (budget - 30_000))
    (tmp_path / "compute.jsonl").write_text(json.dumps({"runs": [c.key for c in fractions],
                                                        "cpu_s": 7.0}) + "\n")
    assert progress.cpu_per_agent_step(str(tmp_path), fractions) == {
        fractions[-1].key: pytest.approx(7.0 / (20 * budget))}
    (tmp_path / "compute.jsonl").write_text(json.dumps({"runs": [first.key, second.key],
                                                        "cpu_s": 12.0}) + "\n")
    assert progress.cpu_per_agent_step(str(tmp_path), [first, second]) == {  # one population
        key: pytest.approx(12.0 / (6 * budget)) for key in (first.key, second.key)}


def test_the_best_mean_is_chosen_a_diverged_agent_the_worst_and_the_first_on_a_tie():
    scores = {("a", 0): np.array([0.5, 0.5]), ("a", 1): np.array([0.9, 0.2]),
              ("b", 0): np.array([0.1, 0.1]), ("b", 1): np.array([2.0, np.nan]),
              ("c", 0): np.array([0.3]), ("c", 1): np.array([0.3])}
    assert study.choose(scores) == {"a": 1, "b": 0, "c": 0}



CONTINUOUS = "pendulum.swingup-continuous"


@pytest.fixture
def tiny_continuous(monkeypatch):
    """The continuous pendulum at a tiny scale: the actor-critic and SAC (the light-weight row
    and a deep one), 300 steps of budget."""
    monkeypatch.setitem(protocol.BUDGETS, CONTINUOUS, 300)
    monkeypatch.setattr(protocol, "CONTINUOUS_DEEP", {"sac": "sac_jax"})
    one_small_deep_row(monkeypatch, "sac", "sac_jax", ("actor_critic", "sac"))


def one_small_deep_row(monkeypatch, label: str, learner: str, labels) -> None:
    """The rows `labels` only, the deep one `label` (`learner`) with a 16 x 16 network and
    minibatches of 32 learning from step 100, its search drawing the learning rate alone;
    then `shrink`'s sizes, but one agent a search configuration and one episode a training
    (the fixtures' 300 steps of budget end it within its first either way): the search's
    trainings (2 configurations of one agent), the rows' and the rows' evaluations are then
    one compiled program of the deep row (2 agents, one episode), its search's evaluations
    another."""
    every_row = protocol.rows

    def rows(task):
        return [dataclasses.replace(row, settings={**row.settings, "net_arch": "16,16",
                                                    "batch_size": 32, "learning_starts": 100})
                if row.label == label else row for row in every_row(task)
                if row.label in labels]
    monkeypatch.setattr(protocol, "rows", rows)
    monkeypatch.setattr(search, "RANGES", {**search.RANGES, learner: (
        search.LogUniform("learning_rate", 1e-4, 3e-3),)})
    shrink(monkeypatch, 1)
    monkeypatch.setattr(search, "AGENTS", 1)
    monkeypatch.setattr(search, "SEEDS", (1000,))
    monkeypatch.setattr(protocol, "SHORTEST_EPISODE", 300)


@pytest.mark.skipif(jax_population.missing_jax(),
                    reason="SAC's row runs on a JAX population: pip install 'lwrl[jax]'")
def test_a_tiny_continuous_benchmark_runs_its_own_rows_and_references(tiny_continuous, tmp_path):
    """`pendulum.swingup-continuous`: every run made with continuous actions, the actor-critic
    in the paper's agent's place against SAC (on its JAX population), the reference rows
    acting by a number in [-1, 1]; the report judges the actor-critic against SAC."""
    from lwrl.studies.paper.benchmark import benchmark
    path = benchmark.benchmark([CONTINUOUS], str(tmp_path), "lwrl bench run " + CONTINUOUS,
                               sweep={"workers": 1})
    runs = study.study_task(CONTINUOUS, str(tmp_path), sweep={"workers": 1})
    assert [row.label for row in protocol.rows(CONTINUOUS)] == ["actor_critic", "sac"]
    assert {config.actions for config in runs.trainings.values()} == {"continuous"}
    assert {config.task for config in runs.trainings.values()} == {"pendulum.swingup"}
    assert runs.trainings["sac", 1.0].learner == "sac_jax"
    assert set(runs.tables["actions"]) == {"continuous"}
    assert all(np.isfinite(values).all() for values in runs.references.values())
    assert np.mean(runs.references["classical"]) > 50.0 > np.mean(runs.references["random"])
    text = open(path).read()
    assert "| task | verdict | against sac |" in text and f"| {CONTINUOUS} | **" in text
    assert "P(actor_critic better)" in text and "one task only" in text


def test_the_pendulum_with_three_torques_and_with_any_torque_side_by_side(monkeypatch, tmp_path):
    """Both pendulum tasks, the light-weight row of each alone: the report sets the paper's
    agent (three torques) beside the actor-critic (any torque) on the seconds up, the steps
    and the trials to the level, with the direct comparison and its figure."""
    from lwrl.studies.paper.benchmark import benchmark, torques
    tasks = ["pendulum.swingup", CONTINUOUS]
    for task in tasks:
        monkeypatch.setitem(protocol.BUDGETS, task, 400)
    monkeypatch.setattr(protocol, "DEEP", {})
    monkeypatch.setattr(protocol, "CONTINUOUS_DEEP", {})
    every_row = protocol.rows
    monkeypatch.setattr(protocol, "rows", lambda task: [
        row for row in every_row(task) if row.label in ("paper", "actor_critic")])
    shrink(monkeypatch, 1)
    monkeypatch.setattr(evaluation, "STEP_CAP", 200)
    path = benchmark.benchmark(tasks, str(tmp_path), "lwrl bench run ...", sweep={"workers": 1})
    runs = [study.study_task(task, str(tmp_path), sweep={"workers": 1}) for task in tasks]
    trials, reached = torques.trials_to_level(runs[1], "actor_critic")
    measures = torques.training_measures(runs[1], "actor_critic")
    assert measures.shape == (protocol.AGENTS, 1)  # 400 steps: part of one 3000-step episode
    assert trials.shape == reached.shape == (protocol.AGENTS,)
    assert np.all(np.where(reached, trials == 1, trials == 2))
    text = open(path).read()
    assert "## pendulum.swingup: three torques or any torque" in text
    assert "| paper | discrete |" in text and "| actor_critic | continuous |" in text
    assert "P(actor_critic better)" in text and "outside the verdicts' Holm family" in text
    assert (tmp_path / "figures" / "pendulum.swingup-torques.png").exists()


@pytest.fixture
def tiny_mujoco(monkeypatch):
    """The pendulum on MuJoCo's model at a tiny scale: the paper's agent and DQN (a linear
    row and a deep one), 300 steps of budget."""
    monkeypatch.setitem(protocol.BUDGETS, "pendulum.swingup", 300)
    monkeypatch.setattr(protocol, "DEEP", {"dqn": "dqn_jax"})
    one_small_deep_row(monkeypatch, "dqn", "dqn_jax", ("paper", "dqn"))


@pytest.mark.skipif(jax_population.missing_jax(),
                    reason="DQN's row runs on a JAX population: pip install 'lwrl[jax,mjx]'")
def test_a_tiny_benchmark_on_mujocos_model_trains_the_deep_rows_on_mjx(tiny_mujoco, tmp_path):
    """On the mujoco plant the linear row and the references run on the C engine, the deep
    row on MJX (`protocol.row_plant`); the report judges the paper's agent against DQN."""
    pytest.importorskip("mujoco.mjx", reason="the deep rows on MuJoCo's model: pip install 'lwrl[mjx]'")
    from lwrl.studies.paper.benchmark import benchmark
    path = benchmark.benchmark(["pendulum.swingup"], str(tmp_path), "lwrl bench run ...",
                               plant="mujoco", sweep={"workers": 1})
    runs = study.study_task("pendulum.swingup", str(tmp_path), plant="mujoco", sweep={"workers": 1})
    assert runs.trainings["paper", 1.0].plant == "mujoco"
    assert runs.trainings["dqn", 1.0].plant == "mjx"
    assert set(runs.tables["plant"]) == {"mujoco", "mjx"}
    assert (tmp_path / "references" / "pendulum.swingup-mujoco.csv.gz").exists()
    text = open(path).read()
    assert "| pendulum.swingup | **" in text
    assert "The runs are on the mujoco plant (paper); the mjx plant (dqn)." in text
