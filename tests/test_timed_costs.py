"""The second benchmark's costs timed apart from its runs (studies/paper/benchmark/
timed_costs.py): callgrind counts an exported controller's instructions, a population row
is timed and costed without a C controller, and a measurement whose process dies stops with
what was measured kept."""

import json
import os
import shutil

import numpy as np
import pytest

from lwrl.agent import jax_population
from lwrl.export.c import export_c
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents
from lwrl.studies.paper.benchmark import timed_costs
from tests.conftest import one_line_error

JAX = pytest.mark.skipif(jax_population.missing_jax(),
                         reason=f"JAX is not installed ({jax_population.EXTRA})")


@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not installed")
def test_callgrind_counts_the_same_instructions_every_time(tmp_path):
    config = RunConfig(task="pendulum.swingup", plant="analytic", agents=1, episodes=1)
    agent = make_agents(config)
    agent.weights[:] = np.random.default_rng(0).normal(size=agent.weights.shape)
    from lwrl.agent import io as agent_io
    agent_io.save(tmp_path / "agent.npz", agent, {"config": {"task": config.task}})
    export_c(tmp_path / "agent.npz", tmp_path / "c")
    first = timed_costs.callgrind_instructions(tmp_path / "c", count=50)
    assert first > 100  # a decision of a 10 x 10 NRBF evaluates 20 exponentials
    assert timed_costs.callgrind_instructions(tmp_path / "c", count=50) == first


@JAX
def test_population_agents_act_greedily_step_by_step_and_learn_only_as_a_program():
    """`Agents.step` of a population learner (what the costs time): each agent's greedy
    action is the argmax of its own action values; learning step by step is one line."""
    config = RunConfig(task="mountain_car.cost_to_go", learner="dqn_jax", agents=3, seed=0,
                       timesteps=400, buffer_size=1000)
    agent = make_agents(config)
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
    costs = timed_costs.measure_cell(config, "dqn", str(tmp_path / "c"))
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
    monkeypatch.setattr(timed_costs, "measure_cell", die)
    cells = [("mountain_car.cost_to_go", "kept", kept), ("mountain_car.cost_to_go", "lost", lost)]
    with pytest.raises(RuntimeError, match="measuring the costs of lost on mountain_car"):
        timed_costs.measure_all(cells, str(tmp_path))
    assert json.loads((tmp_path / "costs.json").read_text()) == measured
