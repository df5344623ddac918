"""Today's light-weight rivals exported as C (`lwrl.agent.controller_forms`, template
`mlp_policy`): after a short training, ARS's linear policy (V1 and V2), Stream Q(lambda)'s
Q-network and Stream AC(lambda)'s actor, exported in float and in double, give the Python
agent's greedy decisions on states in and around the task's ranges.

The Python agents compute in float64 (ARS) or float32 with the statistics in float64 (the
streaming networks); the C code in `lwrl_real`. The outputs (scores, Q values, the
continuous action) must agree within

    bound(s) = REL * (1 + max_a |out(s, a)|)

(REL: float's rounding over the normalisation, the sums and the layer normalisation; in
double the Python network's own float32 rounding for the streaming learners, 1e-12 for
ARS, whose Python arithmetic is double too), and the actions must be equal wherever the
Python agent's two best outputs are more than twice the bound apart (near ties, counted,
must be rare).
"""

import dataclasses
import shutil

import numpy as np
import pytest
from test_export_c import COMPILER, compile_driver, run_driver

from lwrl.agent import io as agent_io
from lwrl.agent import jax_population
from lwrl.cli.main import main
from lwrl.export import device
from lwrl.export.c import export_c
from lwrl.runners.config import RunConfig
from lwrl.runners.run import run

pytestmark = [pytest.mark.slow,  # trains JAX populations (JIT compiling)
              pytest.mark.skipif(COMPILER is None, reason="no C compiler (cc, gcc or clang)"),
              pytest.mark.skipif(jax_population.missing_jax(),
                                 reason=f"the rivals are JAX populations: {jax_population.EXTRA}")]

AGENTS = {
    "ars_v2": dict(task="pendulum.swingup", learner="ars", budget=12000, timesteps=12000,
                   directions=2),
    "ars_v1": dict(task="pendulum.swingup", learner="ars", budget=12000, timesteps=12000,
                   variant="v1", directions=2),
    "stream_q": dict(task="cartpole.balance", learner="stream_q", budget=3000, timesteps=3000),
    "stream_ac_discrete": dict(task="cartpole.balance", learner="stream_ac_discrete",
                               budget=3000, timesteps=3000),
    "stream_ac": dict(task="pendulum.swingup", learner="stream_ac", actions="continuous",
                      budget=3000, timesteps=3000),
    "ars_continuous": dict(task="pendulum.swingup", learner="ars_continuous",
                           actions="continuous", budget=12000, timesteps=12000, directions=2),
}
"""Each case's run: short, enough for the policy to move from its start (ARS: two
iterations of two directions on the pendulum, whose returns differ where the cart-pole's
failures all score alike)."""
REL = {"float": 1e-4, "double": 1e-5}
"""REL of the module's bound, per C type (ARS in double: `ARS_DOUBLE`)."""
ARS_DOUBLE = 1e-12


@pytest.fixture(scope="module")
def agent_files(tmp_path_factory):
    """Each case's two agents, trained and saved with their run configuration."""
    directory = tmp_path_factory.mktemp("rivals")
    files = {}
    for name, options in AGENTS.items():
        config = RunConfig(plant="analytic", agents=2, seed=3, episodes=2000, **options)
        agents, _ = run(config)
        files[name] = directory / f"{name}.npz"
        agent_io.save(files[name], agents, {"config": dataclasses.asdict(config)})
    return files


def states_around(task, count: int, dtype) -> np.ndarray:
    """`count` states uniform in the task's ranges widened by a quarter on each side,
    rounded to `dtype` so that C and Python read the same numbers."""
    low, high = np.array(task.ranges.low), np.array(task.ranges.high)
    states = low + (high - low) * np.random.default_rng(1).uniform(-0.25, 1.25, (count, len(low)))
    return states.astype(dtype).astype(np.float64)


@pytest.mark.parametrize("dtype", ["float", "double"])
@pytest.mark.parametrize("name", list(AGENTS))
def test_the_c_policy_takes_the_python_agents_greedy_decisions(agent_files, tmp_path, name, dtype):
    b = 1
    written = export_c(agent_files[name], tmp_path / "out", agent_index=b, dtype=dtype)
    executable = compile_driver(tmp_path / "out", tmp_path)
    agents, _ = agent_io.load(agent_files[name])
    continuous = agents.continuous
    states = states_around(agents.task, 3000, np.float32 if dtype == "float" else np.float64)
    c_actions, c_outputs = run_driver(executable, states, continuous=continuous)
    # scores, Q(s, .), the actor's preferences, or the clipped action (M, 1)
    python = (agents.greedy_actions(states)[b][:, None] if continuous
              else getattr(agents, "preferences", agents.action_values)(states)[b])
    rel = ARS_DOUBLE if dtype == "double" and "ars" in name else REL[dtype]
    bound = rel * (1.0 + np.abs(python).max(axis=1))
    if continuous:
        error = np.abs(c_actions - python[:, 0])
        assert np.all(error <= bound), f"C actions off by up to {error.max():.3g}"
        assert python[:, 0].std() > 0.01, "the test needs actions that differ"
        assert np.all(np.abs(c_actions) <= 1.0)
    else:
        error = np.abs(c_outputs - python).max(axis=1)
        assert np.all(error <= bound), f"C outputs off by up to {(error / bound).max():.3g} bounds"
        ordered = np.sort(python, axis=1)
        near_tie = ordered[:, -1] - ordered[:, -2] <= 2 * bound
        assert near_tie.mean() < 0.01, f"{near_tie.sum()} near ties"
        np.testing.assert_array_equal(c_actions[~near_tie], python.argmax(axis=1)[~near_tie])
        assert len(set(python.argmax(axis=1))) > 1, "the test needs states whose actions differ"
    assert written["weight_bytes"] == written["flash_bytes"] - written["constant_bytes"]


def test_the_statistics_are_the_controllers_constants(agent_files, tmp_path):
    """V2 and the streaming learners store the normalisation's mean and scale (2 d values
    beside the weights); V1 stores none; the streaming networks' layers are normalised."""
    sizes = {}
    for name in ("ars_v1", "ars_v2", "stream_q"):
        written = export_c(agent_files[name], tmp_path / name, agent_index=0)
        sizes[name] = written["constant_bytes"]
        source = (tmp_path / name / "lwrl_policy.c").read_text()
        assert ("#define LWRL_LAYER_NORM 1" in source) == (name == "stream_q")
        assert ("#define LWRL_NORMALISE 1" in source) == (name != "ars_v1")
    assert sizes == {"ars_v1": 0, "ars_v2": 2 * 2 * 4, "stream_q": 2 * 4 * 4}  # d = 2, 4


@pytest.mark.skipif(bool(device.missing_tools()), reason="missing the cross tools or QEMU")
@pytest.mark.skipif(shutil.which("valgrind") is None, reason="missing valgrind")
def test_the_controllers_are_measured_on_the_emulated_m4(agent_files):
    """`policy_costs`: a frozen controller keeps everything in flash (no static RAM), its
    object holds at least its weights, and a decision of Stream Q's network (two hidden
    layers of 32, layer-normalised) costs far more instructions than ARS's linear scores,
    on both machines, as their counted multiply-adds say."""
    ars, stream_q = (device.policy_costs(agent_files[name]) for name in ("ars_v2", "stream_q"))
    for result in (ars, stream_q):
        assert result["object"]["data"] + result["object"]["bss"] == 0
        assert result["object"]["text"] >= result["written"]["flash_bytes"]
        assert 0 < result["stack"] < 1024
        assert result["m4_decide"] > 0 and result["host_decide"] > 0
    for machine in ("host_decide", "m4_decide"):
        assert stream_q[machine] > 20 * ars[machine]


def test_device_costs_measures_a_c_learners_controller_where_asked(monkeypatch, capsys):
    """`--controller`: a learner with a C learner (Stream Q(lambda)) measured as its greedy
    controller, as a learner without one is; without it, as its C learner."""
    from lwrl.cli import device as device_command
    for table in ("learning_costs", "controller_costs"):
        monkeypatch.setattr(device_command, table,
                            lambda names, args, settings, table=table: print(table, names))
    for flags, table in (([], "learning_costs"), (["--controller"], "controller_costs")):
        assert main(["device", "costs", "cartpole.balance", "--learner", "stream_q", *flags]) == 0
        assert f"{table} ['cartpole.balance']" in capsys.readouterr().out, flags


@pytest.mark.skipif(bool(device.missing_tools()), reason="missing the cross tools or QEMU")
@pytest.mark.skipif(shutil.which("valgrind") is None, reason="missing valgrind")
def test_device_costs_measures_a_learner_without_a_c_learner(capsys):
    """`lwrl device costs TASK --learner stream_ac_discrete`: Stream AC(lambda) has no
    learner in C, so its row is its greedy controller's, after `--train` steps, with its
    counted arithmetic and memory against the board's RAM."""
    assert main(["device", "costs", "pendulum.swingup", "--learner", "stream_ac_discrete",
                 "--train", "3000"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "after 3000 steps of learning" in lines[0]
    row = next(line for line in lines if line.startswith("pendulum.swingup"))
    assert "(fits)" in row and "stream_ac_discrete: actor 2-32-32-2, critic 2-32-32-1" in row
