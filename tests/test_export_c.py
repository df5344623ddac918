"""The embedded controller (lwrl.export.c): the exported C picks the Python agent's
greedy action, compiles cleanly as C99, and bad inputs are refused in one line; for a
continuous actor-critic (CACLA) the C action is the Python agent's greedy action, within
the same error bound.

The C code runs in float (single precision, weights rounded to float32) by default; the
Python agent in float64. Where the Python agent's two best actions are within the float
error of each other, the C code may pick the other one. That error is bounded per state by

    bound(s) = REL * max_a sum_i |w_ia| phibar_i(s) + ABS

(REL: a few hundred float32 roundings, covering the weights, the state normalisation and the
exponentials; ABS: float underflow of features and weights below ~1e-38). The test checks
the C Q values are within that bound of Python's, calls a state a near tie where the top two
Python Q values differ by at most twice the bound, counts those (there are none or nearly
none with trained or random weights), and requires identical actions everywhere else.
"""

import dataclasses
import shutil
import subprocess

import numpy as np
import pytest
from conftest import one_line_error

from lwrl import tasks
from lwrl.agent import io as agent_io
from lwrl.agent.cmac import CMAC
from lwrl.agent.nrbf import NRBF
from lwrl.agent.sarsa import BatchedSarsa
from lwrl.runners.config import RunConfig
from lwrl.export.c import export_c, measure
from lwrl.runners.run import make_agents, run

COMPILER = next((shutil.which(c) for c in ("cc", "gcc", "clang") if shutil.which(c)), None)
needs_compiler = pytest.mark.skipif(COMPILER is None,
                                    reason="no C compiler (cc, gcc or clang) on the PATH")

TOLERANCE = {"float": (1e-5, 1e-30), "double": (1e-12, 1e-300)}
"""dtype: (REL, ABS) of the error bound in the module docstring."""

STRICT = ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Wconversion", "-Wdouble-promotion",
          "-Werror"]

DRIVER = r"""
#include <stdio.h>

#include "lwrl_policy.h"

/* Reads states (LWRL_STATE_DIM numbers each, hex floats are exact) from stdin; prints per
 * state the action of lwrl_act and the Q values of lwrl_q_values as hex floats, or for a
 * continuous controller the action and the actor's mean of lwrl_actor, both hex floats. */
int main(void)
{
#ifdef LWRL_NUM_ACTIONS
    lwrl_real state[LWRL_STATE_DIM], q[LWRL_NUM_ACTIONS];
    int a;
#else
    lwrl_real state[LWRL_STATE_DIM], mu;
#endif
    double value;
    int j;
    for (;;) {
        for (j = 0; j < LWRL_STATE_DIM; j++) {
            if (scanf("%lf", &value) != 1)
                return 0;
            state[j] = (lwrl_real)value;
        }
#ifdef LWRL_NUM_ACTIONS
        lwrl_q_values(state, q);
        printf("%d", lwrl_act(state));
        for (a = 0; a < LWRL_NUM_ACTIONS; a++)
            printf(" %a", (double)q[a]);
#else
        lwrl_actor(state, &mu);
        printf("%a %a", (double)lwrl_act(state), (double)mu);
#endif
        printf("\n");
    }
}
"""


def save(path, agent, config):
    agent_io.save(path, agent, {"config": dataclasses.asdict(config)})
    return path


@pytest.fixture(scope="module")
def agent_files(tmp_path_factory):
    """Saved agents: one Mountain-Car agent trained for 20 episodes; cart-pole (1296 x 2) and
    pendulum agents with random weights (non-trivial everywhere; no training needed); and a
    one-variable agent saved without a run configuration."""
    directory = tmp_path_factory.mktemp("agents")
    config = RunConfig(task="mountain_car.cost_to_go", plant="analytic", agents=1, episodes=20)
    agent, _ = run(config)
    files = {"mountain_car": save(directory / "mountain_car.npz", agent, config)}
    rng = np.random.default_rng(5)
    for task, scale in (("cartpole.balance", 1.0), ("pendulum.swingup", 30.0)):
        config = RunConfig(task=task, plant="analytic", agents=2, episodes=3)
        agent = make_agents(config)
        agent.weights[:] = scale * rng.normal(size=agent.weights.shape)
        files[task.split(".")[0]] = save(directory / f"{task}.npz", agent, config)
    one_dimensional = BatchedSarsa(NRBF((-3.0,), (2.0,), 7), 3, alpha=0.1, lam=0.0, epsilon=0.0,
                                   trace="replacing", seeds=[0])
    one_dimensional.weights[:] = rng.normal(size=one_dimensional.weights.shape)
    agent_io.save(directory / "one_dimensional.npz", one_dimensional)  # no run configuration
    files["one_dimensional"] = directory / "one_dimensional.npz"
    for task, scale in (("pendulum.swingup", 1.0), ("cartpole.balance", 1.0)):
        config = RunConfig(task=task, learner="actor_critic", actions="continuous",
                           plant="analytic", agents=2, episodes=3)
        agent = make_agents(config)
        agent.arrays.weights[:] = scale * rng.normal(size=agent.arrays.weights.shape)
        files[f"{task.split('.')[0]}_actor"] = save(directory / f"{task}-actor.npz", agent, config)
    return files


def compile_driver(out_dir, build_dir):
    """The exported files and DRIVER built with the strict warnings; the executable's path."""
    (build_dir / "driver.c").write_text(DRIVER)
    executable = build_dir / "driver"
    result = subprocess.run([COMPILER, *STRICT, "-O2", "-I", str(out_dir), "driver.c",
                             str(out_dir / "lwrl_policy.c"), "-o", str(executable), "-lm"],
                            cwd=build_dir, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return executable


def run_driver(executable, states, continuous=False):
    """C actions `(M,)` and Q values `(M, A)` at `states` `(M, d)` (exact: hex floats), or
    for a `continuous` controller its actions and the actor's means `(M, 1)`."""
    text = "\n".join(" ".join(float(v).hex() for v in row) for row in states) + "\n"
    output = subprocess.run([str(executable)], input=text, capture_output=True, text=True,
                            check=True).stdout.split("\n")
    rows = [line.split() for line in output if line]
    assert len(rows) == len(states)
    return (np.array([float.fromhex(row[0]) if continuous else int(row[0]) for row in rows]),
            np.array([[float.fromhex(v) for v in row[1:]] for row in rows]))


def sample_states(features, count, rng, dtype):
    """`count` random states in the ranges widened by half their width on each side, then
    the box's corners, a state on the first centroid and far corners (normalised values
    -1e6 and 1 + 1e6), rounded to `dtype` so the C code and Python see the same numbers."""
    low, high = np.array(features.low), np.array(features.high)
    width = high - low
    random = low + width * rng.uniform(-0.5, 1.5, size=(count, features.dim))
    special = np.concatenate([low + width * corners(features.dim),
                              (low + width * 0.5 / features.n)[None],
                              low + width * np.where(corners(features.dim) > 0, 1 + 1e6, -1e6)])
    return np.concatenate([random, special]).astype(dtype).astype(np.float64)


def corners(dim):
    """The 2^d corners of the unit box `(2^d, d)`, in C order."""
    return np.array(np.meshgrid(*[[0.0, 1.0]] * dim, indexing="ij")).reshape(dim, -1).T


def check_against_python(path, out_dir, build_dir, agent_index, dtype, count=2000):
    """Export, compile, run; compare with the Python agent. Returns (states, near ties)."""
    result = export_c(path, out_dir, agent_index=agent_index, dtype=dtype)
    executable = compile_driver(out_dir, build_dir)
    agent, _ = agent_io.load(path)
    states = sample_states(agent.features, count, np.random.default_rng(agent_index + 11),
                         np.float32 if dtype == "float" else np.float64)
    c_actions, c_q = run_driver(executable, states)
    q = agent.action_values(states)[agent_index]  # float64, (M, A)
    phi = agent.features.features(states)
    scale = (phi @ np.abs(agent.weights[agent_index])).max(axis=1)
    rel, absolute = TOLERANCE[dtype]
    bound = rel * scale + absolute
    error = np.abs(c_q - q).max(axis=1)
    assert np.all(error <= bound), f"C Q values off by up to {(error / scale).max():.3g} x scale"
    np.testing.assert_array_equal(c_actions, c_q.argmax(axis=1))  # lowest index on ties
    top_two = np.sort(q, axis=1)[:, -2:]
    near_tie = top_two[:, 1] - top_two[:, 0] <= 2 * bound
    np.testing.assert_array_equal(c_actions[~near_tie], q.argmax(axis=1)[~near_tie])
    assert near_tie.sum() <= len(states) // 100, f"{near_tie.sum()} near ties: the test says little"
    # Beyond the far corners (huge, infinite) the C features are those at the far corners
    # (agent/nrbf.py gives every centroid the same weight when the normalised value is
    # beyond ~1e15, where float64 cannot tell the centroids apart, so no Python reference).
    # A NaN state gives action 0.
    far = np.sign(corners(agent.features.dim) - 0.5)
    huge_actions, huge_q = run_driver(executable, np.concatenate([far * 1e30, far * 3e38,
                                                                  far * np.inf]))
    far_actions, far_q = c_actions[-len(far):], c_q[-len(far):]
    np.testing.assert_array_equal(huge_actions, np.tile(far_actions, 3))
    np.testing.assert_array_equal(huge_q, np.tile(far_q, (3, 1)))
    nan_action, _ = run_driver(executable, np.full((1, agent.features.dim), np.nan))
    assert nan_action[0] == 0
    print(f"\n{result['task']} ({dtype}): {len(states)} states, {near_tie.sum()} near ties, "
          f"C Q error <= {(error / scale).max():.2g} x scale")
    return len(states), int(near_tie.sum())


@needs_compiler
@pytest.mark.parametrize("name, agent_index", [("mountain_car", 0), ("cartpole", 1),
                                               ("pendulum", 0), ("one_dimensional", 0)])
def test_c_controller_picks_the_python_agents_greedy_action(agent_files, tmp_path, name, agent_index):
    check_against_python(agent_files[name], tmp_path / "out", tmp_path, agent_index, "float")


@needs_compiler
@pytest.mark.parametrize("name", ["mountain_car", "cartpole"])
def test_double_precision_controller_agrees_too(agent_files, tmp_path, name):
    check_against_python(agent_files[name], tmp_path / "out", tmp_path, 0, "double", count=500)


def greedy_actions(agent, b, states):
    """Agent b's greedy actions at `states` `(M, d)`, each the step of an episode's first
    observation (`Agents.step`, `greedy=True`, no learning), as the run loops take them."""
    batch = agent.batch_size
    return np.array([agent.step([True] * batch, [0.0] * batch, [1.0] * batch,
                                np.tile(state, (batch, 1)), learn=False, greedy=True)[b]
                     for state in states])


@needs_compiler
@pytest.mark.parametrize("name, dtype", [("pendulum_actor", "float"), ("pendulum_actor", "double"),
                                         ("cartpole_actor", "float"), ("cartpole_actor", "double")])
def test_c_actor_gives_the_python_agents_greedy_action(agent_files, tmp_path, name, dtype):
    """A continuous actor-critic (CACLA) exported: `lwrl_act` returns a real, the Python
    agent's greedy action clip(mu(s), -1, 1), within the bound of the module's docstring over
    the actor's weights (float), within 1e-12 of it (double); `lwrl_actor` its mean mu(s).
    Random weights put mu beyond [-1, 1] at some states, so the clip is tested too. The
    header gives the actuator's range and the mapping, and the file holds the actor's
    weights only."""
    path, b = agent_files[name], 1
    result = export_c(path, tmp_path / "out", agent_index=b, dtype=dtype)
    executable = compile_driver(tmp_path / "out", tmp_path)
    agent, _ = agent_io.load(path)
    states = sample_states(agent.features, 2000, np.random.default_rng(7),
                           np.float32 if dtype == "float" else np.float64)
    c_actions, c_means = run_driver(executable, states, continuous=True)
    python = greedy_actions(agent, b, states)
    mu = agent.policy_means(states)[b]
    rel, absolute = TOLERANCE[dtype]
    bound = rel * agent.features.features(states) @ np.abs(agent.arrays.weights[b, 0]) + absolute
    assert np.all(np.abs(c_means[:, 0] - mu) <= bound)
    assert np.all(np.abs(c_actions - python) <= (bound if dtype == "float" else 1e-12))
    np.testing.assert_array_equal(python, np.clip(python, -1.0, 1.0))
    assert (np.abs(mu) > 1.0).mean() > 0.05 and (np.abs(mu) < 1.0).mean() > 0.05
    assert np.all(np.abs(c_actions) <= 1.0)
    nan_action, _ = run_driver(executable, np.full((1, agent.dim), np.nan), continuous=True)
    assert nan_action[0] == 0.0  # the middle of the actuator's range
    header = (tmp_path / "out" / "lwrl_policy.h").read_text()
    real = "f" if dtype == "float" else ""
    low, high = tasks.definition(*result["task"].split("."), actions="continuous").control_range
    assert f"#define LWRL_ACTION_LOW ({low!r}{real})" in header
    assert f"#define LWRL_ACTION_HIGH ({high!r}{real})" in header
    assert "lwrl_real lwrl_act(const lwrl_real *state);" in header
    assert "LWRL_NUM_ACTIONS" not in header and "(lwrl.tasks.commands)" in header
    assert result["weight_bytes"] == agent.features.num_features * (4 if dtype == "float" else 8)
    print(f"\n{name} ({dtype}): {len(states)} states, C action error <= "
          f"{np.abs(c_actions - python).max():.2g}, "
          f"{(np.abs(mu) > 1.0).mean():.0%} of the means clipped")


def test_exported_files_describe_the_controller(agent_files, tmp_path):
    result = export_c(agent_files["cartpole"], tmp_path, agent_index=1)
    assert result["source"] == str(tmp_path / "lwrl_policy.c")
    assert result["header"] == str(tmp_path / "lwrl_policy.h")
    assert (result["neurons"], result["actions"], result["n"]) == (1296, 2, 6)
    assert result["weight_bytes"] == 1296 * 2 * 4
    assert result["flash_bytes"] == result["weight_bytes"] + (2 * 4 + 1) * 4
    source = (tmp_path / "lwrl_policy.c").read_text()
    header = (tmp_path / "lwrl_policy.h").read_text()
    assert "Task: cartpole.balance" in source and "grid 6 x 6 x 6 x 6" in source
    assert str(agent_files["cartpole"]) in source and "agent 1 of 2" in source
    assert "state[2] pole_angle" in source and "[-2.4, 2.4]" in source
    assert source.count("#include") == 2 and "#include <math.h>" in source
    assert "static const float WEIGHTS[LWRL_NUM_ACTIONS][LWRL_NUM_NEURONS]" in source.replace(
        "lwrl_real", "float")
    assert "int lwrl_act(const lwrl_real *state);" in header
    assert "typedef float lwrl_real;" in header and "#define LWRL_NUM_NEURONS 1296" in header
    # The weights in the file are the agent's, action-major, rounded to float.
    agent, _ = agent_io.load(agent_files["cartpole"])
    body = source.split("LWRL_NUM_NEURONS] = {")[1].split("};")[0]
    values = [float(v.rstrip("f")) for line in body.splitlines() if "*/" in line and "action" not in line
              for v in line.split("*/")[1].split(",") if v.strip()]
    np.testing.assert_array_equal(np.array(values, dtype=np.float32),
                                  agent.arrays.weights[1].astype(np.float32).ravel())
    # The same file gives the same code (no time stamps).
    export_c(agent_files["cartpole"], tmp_path / "again", agent_index=1)
    assert (tmp_path / "again" / "lwrl_policy.c").read_text() == source


@needs_compiler
def test_measure_reports_flash_and_time_per_decision(agent_files, tmp_path):
    """Sizes on this host's compiler; the time is printed, never asserted."""
    for name in ("mountain_car", "cartpole"):
        exported = export_c(agent_files[name], tmp_path / name)
        sizes = measure(tmp_path / name, seconds=0.05)
        assert sizes["code_bytes"] > 0
        assert sizes["rodata_bytes"] >= exported["weight_bytes"]
        assert sizes["ns_per_decision"] > 0
        print(f"\n{exported['task']} {exported['neurons']} x {exported['actions']}: weights "
              f"{exported['weight_bytes']} B (+{exported['constant_bytes']} B constants), "
              f"code {sizes['code_bytes']} B .text at -Os, read-only data "
              f"{sizes['rodata_bytes']} B, {sizes['ns_per_decision']:.0f} ns per decision "
              f"({sizes['compiler']})")


def test_bad_inputs_are_refused_in_one_line(agent_files, tmp_path):
    one_line_error(lambda: export_c(tmp_path / "missing.npz", tmp_path), "no such agent file")
    (tmp_path / "text.npz").write_text("not an agent")
    one_line_error(lambda: export_c(tmp_path / "text.npz", tmp_path), "not an lwrl agent file")
    cmac = BatchedSarsa(CMAC(*tasks.definition("mountain_car", "cost_to_go").ranges), 3,
                        alpha=0.5, lam=0.9, epsilon=0.0, trace="replacing", seeds=[0])
    agent_io.save(tmp_path / "cmac.npz", cmac)
    one_line_error(lambda: export_c(tmp_path / "cmac.npz", tmp_path / "out"), "only NRBF", "CMAC")
    for bad_index in (2, -1, True, 1.0, "0"):
        one_line_error(lambda: export_c(agent_files["cartpole"], tmp_path / "out", bad_index),
                       "agent_index must be an integer in 0..1", repr(bad_index))
    one_line_error(lambda: export_c(agent_files["cartpole"], tmp_path / "out", dtype="half"),
                   "dtype must be one of float, double")
    # A diverged agent: non-finite weights, or only the flag (its weights frozen, finite).
    agent, metadata = agent_io.load(agent_files["pendulum"])
    agent.weights[1, 7, 0] = np.nan
    agent_io.save(tmp_path / "nan.npz", agent, metadata)
    export_c(tmp_path / "nan.npz", tmp_path / "ok", agent_index=0)  # agent 0 is fine
    one_line_error(lambda: export_c(tmp_path / "nan.npz", tmp_path / "out", 1), "agent 1 diverged")
    agent, metadata = agent_io.load(agent_files["pendulum"])
    agent.arrays.diverged[0] = True
    agent_io.save(tmp_path / "flagged.npz", agent, metadata)
    one_line_error(lambda: export_c(tmp_path / "flagged.npz", tmp_path / "out"), "agent 0 diverged")
    # Weights beyond float's range: refused for float, fine for double.
    agent, metadata = agent_io.load(agent_files["pendulum"])
    agent.weights[0, 3, 1] = 1e300
    agent_io.save(tmp_path / "huge.npz", agent, metadata)
    one_line_error(lambda: export_c(tmp_path / "huge.npz", tmp_path / "out"), "beyond the range of float")
    export_c(tmp_path / "huge.npz", tmp_path / "huge", dtype="double")
    # A continuous actor-critic: with CMAC features, or saved without its task (the
    # header's actuator range), refused; its diverged agent too.
    config = RunConfig(task="pendulum.swingup", learner="actor_critic", actions="continuous",
                       features="cmac", agents=1)
    agent_io.save(tmp_path / "actor_cmac.npz", make_agents(config),
                  {"config": dataclasses.asdict(config)})
    one_line_error(lambda: export_c(tmp_path / "actor_cmac.npz", tmp_path / "out"), "only NRBF")
    agent, metadata = agent_io.load(agent_files["pendulum_actor"])
    agent_io.save(tmp_path / "actor_alone.npz", agent)
    one_line_error(lambda: export_c(tmp_path / "actor_alone.npz", tmp_path / "out"),
                   "names no task", "actuator's range")
    agent.arrays.weights[1, 0, 5] = np.inf
    agent_io.save(tmp_path / "actor_inf.npz", agent, metadata)
    one_line_error(lambda: export_c(tmp_path / "actor_inf.npz", tmp_path / "out", 1),
                   "agent 1 diverged")
    # An output directory that is a file.
    (tmp_path / "file").write_text("")
    one_line_error(lambda: export_c(agent_files["pendulum"], tmp_path / "file"), "cannot write")
