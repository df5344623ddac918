"""`lwrl bench` (studies/paper/bench*.py): its protocol builds a valid run for every learner
on every task, the light-weight claim's rule says what docs/FINDINGS.md says, callgrind
counts an exported controller's instructions, and bad input is one line."""

import dataclasses
import json
import os
import shutil

import numpy as np
import pytest

from lwrl.agent import jax_population, stable_baselines
from lwrl.export.c import export_c
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agent
from lwrl.studies.paper import bench_costs, bench_protocol, bench_report
from tests.conftest import one_line_error, run_cli

BASELINES = pytest.mark.skipif(bool(stable_baselines.missing_libraries()),
                               reason="the baselines extra is not installed (pip install 'lwrl[baselines]')")
JAX = pytest.mark.skipif(jax_population.missing_jax(),
                         reason=f"JAX is not installed ({jax_population.EXTRA})")


@BASELINES
@JAX
def test_every_cell_of_the_protocol_is_a_valid_run():
    tasks = list(bench_protocol.TASKS)
    labels = bench_protocol.check_learners(None, tasks)
    cells = bench_protocol.configs(tasks, labels, "analytic", 2)
    assert {label for _, label, _ in cells} == set(labels) and "paper" in labels
    for task in tasks:
        mine = [(label, config) for t, label, config in cells if t == task]
        assert mine[0][0] == "paper"
        episodes = {config.episodes for _, config in mine}
        options = {tuple(sorted(config.task_options.items())) for _, config in mine}
        assert len(episodes) == 1 and len(options) == 1  # one protocol for every learner
        assert len({config.seeds[0] for _, config in mine}) == 1
    for label in ("dqn", "dqn_jax"):
        dqn = [config for task, l, config in cells if l == label and task == "mountain_car.cost_to_go"][0]
        assert dqn.agent.net_arch == "256,256" and dqn.agent.timesteps == 120_000  # the zoo's set


def test_the_rule_is_findings():
    assert bench_report.verdict({"dqn": (True, True), "ppo": (True, True)}) == "yes"
    assert bench_report.verdict({"dqn": (True, False), "ppo": (True, True)}) == "partly"
    assert bench_report.verdict({"dqn": (True, True), "ppo": (False, True)}) == "partly"
    assert bench_report.verdict({"dqn": (False, True), "ppo": (False, True)}) == "no"
    assert bench_report.verdict({"dqn": (True, True)}) == "partly"  # one baseline is not both


@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not installed")
def test_callgrind_counts_the_same_instructions_every_time(tmp_path):
    config = RunConfig(task="pendulum.swingup", plant="analytic", agents=1, episodes=1)
    agent = make_agent(config)
    agent.weights[:] = np.random.default_rng(0).normal(size=agent.weights.shape)
    from lwrl.agent import io as agent_io
    agent_io.save(tmp_path / "agent.npz", agent, {"config": {"task": config.task}})
    export_c(tmp_path / "agent.npz", tmp_path / "c")
    first = bench_costs.callgrind_instructions(tmp_path / "c", count=50)
    assert first > 100  # a decision of a 10 x 10 NRBF evaluates 20 exponentials
    assert bench_costs.callgrind_instructions(tmp_path / "c", count=50) == first


@pytest.mark.parametrize("argv, fragment", [
    (["bench", "nowhere.nothing"], "unknown bench task 'nowhere.nothing'"),
    (["bench", "all", "--learners", "paper,nobody"], "unknown bench learner 'nobody'"),
    (["bench", "all", "--agents-per-cell", "1"], "at least 2"),
])
def test_bad_input_is_one_line(argv, fragment, capsys, tmp_path):
    status, _, err = run_cli(argv + ["--out", str(tmp_path / "out")], capsys)
    assert status == 2 and len(err) >= 1 and fragment in err[-1]


@BASELINES
def test_the_search_tries_the_zoos_set_first_and_keeps_the_best_on_seeds_of_its_own():
    """Each baseline's candidates are the zoo's set, its learning rate times each factor and
    its horizon (DQN: and warm-up) shorter, on seeds none of the rows take; the best mean is chosen (fewer steps on Mountain-Car, more
    up-time on the pendulum), the zoo's on a tie; the row with the zoo's set chosen keeps its
    run key, so its kept run is not recomputed."""
    import pandas as pd

    from lwrl.studies.paper import bench_search

    tasks = ["mountain_car.cost_to_go", "pendulum.swingup"]
    cells = bench_protocol.configs(tasks, ["paper", *bench_protocol.DEEP], "analytic", 5)
    found = bench_search.candidates(cells)
    assert set(found) == {(task, label) for task in tasks for label in bench_protocol.DEEP}
    for (task, label), configs in found.items():
        row = next(config for t, l, config in cells if (t, l) == (task, label))
        rates = [config.agent.learning_rate / row.agent.learning_rate for config in configs]
        np.testing.assert_allclose(rates, (1.0, *bench_search.FACTORS, 1.0))
        shorter = configs[-1].agent
        assert shorter.timesteps == row.agent.timesteps // bench_search.SHORTER
        if label.startswith("dqn"):
            assert shorter.learning_starts == row.agent.learning_starts // bench_search.SHORTER
        assert all(min(config.seeds) >= row.agents for config in configs)
        assert dataclasses.replace(configs[0], agents=row.agents, seed=row.seed).key == row.key

    def results(scores):
        return pd.DataFrame([{"run": config.key, "seed": seed, "steps": value, "uptime_s": value}
                             for configs in found.values()
                             for config, value in zip(configs, scores) for seed in config.seeds])
    chosen = bench_search.choose(found, results([50.0, 20.0, 80.0, 50.0]))
    assert chosen["mountain_car.cost_to_go", "dqn_jax"] is found["mountain_car.cost_to_go", "dqn_jax"][1]
    assert chosen["mountain_car.cost_to_go", "dqn"] is found["mountain_car.cost_to_go", "dqn"][1]
    assert chosen["pendulum.swingup", "ppo"] is found["pendulum.swingup", "ppo"][2]
    tie = bench_search.choose(found, results([30.0, 30.0, 30.0, 30.0]))
    assert all(tie[cell] is configs[0] for cell, configs in found.items())


def test_lwrl_bench_writes_its_report_and_resumes(tmp_path, capsys):
    """`--quick` with the paper's agent alone (no baseline, so no search): the report names
    the command and has the row; a second call computes nothing."""
    out = tmp_path / "bench"
    argv = ["bench", "mountain_car.cost_to_go", "--learners", "paper", "--quick",
            "--agents-per-cell", "2", "--out", str(out)]
    status, _, _ = run_cli(argv, capsys)
    report = (out / "README.md").read_text()
    assert status == 0 and "lwrl bench mountain_car.cost_to_go --learners paper --quick" in report
    assert "computed 1 of the 1 runs" in report and "\n| paper | " in report
    assert run_cli(argv, capsys)[0] == 0
    assert "computed 0 of the 1 runs" in (out / "README.md").read_text()


@JAX
def test_population_agents_act_greedily_step_by_step_and_learn_only_as_a_program():
    """`Agents.step` of a population learner (what the costs time): each agent's greedy
    action is the argmax of its own action values; learning step by step is one line."""
    config = RunConfig(task="mountain_car.cost_to_go", learner="dqn_jax", agents=3, seed=0,
                       timesteps=400, buffer_size=1000)
    agent = make_agent(config)
    states = np.array([[-0.5, 0.0], [0.3, 0.01], [-1.0, -0.02]])
    actions = agent.step(np.ones(3, bool), np.zeros(3), np.ones(3), states, learn=False,
                         greedy=True)
    values = agent.action_values(states)  # (agent, state, action)
    np.testing.assert_array_equal(actions, values[np.arange(3), np.arange(3)].argmax(axis=-1))
    assert len(set(map(tuple, values[:, 0].round(6)))) == 3  # three agents, three networks
    one_line_error(lambda: agent.step(np.ones(3, bool), np.zeros(3), np.ones(3), states),
                   "only acts greedily")


@JAX
def test_a_row_whose_agents_have_no_c_controller_is_costed_without_one(tmp_path):
    """The second benchmark's DQN row runs on `dqn_jax`, whose agents have no C controller:
    its costs are measured, and `c_controller` says why there are no C sizes."""
    config = RunConfig(task="mountain_car.cost_to_go", learner="dqn_jax", net_arch="8",
                       timesteps=200, learning_starts=10, batch_size=4, buffer_size=64,
                       task_options={"time_limit": 2.0})
    costs = bench_costs.measure_cell(config, "dqn", str(tmp_path / "c"), quick=True)
    assert costs["cpu_s_per_learning_step"] > 0 and "c_code_bytes" not in costs
    assert costs["c_controller"].startswith("none: ") and "no C controller" in costs["c_controller"]


def die(*cell):
    """A cost measurement whose process dies (as one killed or crashed would)."""
    os._exit(9)


def test_a_measurement_whose_process_dies_stops_with_what_was_measured_kept(tmp_path, monkeypatch):
    """A cell measured before is kept; the next one's process dies: one error naming it, not
    a wait for a result that will never come, and `costs.json` as it was."""
    kept, lost = (RunConfig(task="mountain_car.cost_to_go", alpha=alpha) for alpha in (1.0, 2.0))
    measured = {kept.key: {"task": "mountain_car.cost_to_go", "label": "kept", "cpu": 1.0}}
    (tmp_path / "costs.json").write_text(json.dumps(measured))
    monkeypatch.setattr(bench_costs, "measure_cell", die)
    cells = [("mountain_car.cost_to_go", "kept", kept), ("mountain_car.cost_to_go", "lost", lost)]
    with pytest.raises(RuntimeError, match="measuring the costs of lost on mountain_car"):
        bench_costs.measure_all(cells, str(tmp_path))
    assert json.loads((tmp_path / "costs.json").read_text()) == measured
