"""`lwrl bench` (studies/paper/bench*.py): its protocol builds a valid run for every learner
on every task, the light-weight claim's rule says what docs/FINDINGS.md says, callgrind
counts an exported controller's instructions, and bad input is one line."""

import shutil

import numpy as np
import pytest

from lwrl.agent import stable_baselines
from lwrl.export.c import export_c
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agent
from lwrl.studies.paper import bench_costs, bench_protocol, bench_report
from tests.conftest import run_cli

BASELINES = pytest.mark.skipif(bool(stable_baselines.missing_libraries()),
                               reason="the baselines extra is not installed (pip install 'lwrl[baselines]')")


@BASELINES
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
    dqn = [config for task, label, config in cells if label == "dqn" and task == "mountain_car.cost_to_go"][0]
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
