"""The learner in C (lwrl.export.learner, the form of agent/sarsa_c.py) learns as lwrl's
Python learner does.

The C learner is compiled as a shared library and driven through ctypes beside lwrl's
`BatchedSarsa` (made from the same run configuration), on the same episodes of the analytic
plant (`tasks.batched.BatchedEnv`):

- in double, it takes the Python learner's action at every step and ends every episode with
  the Python learner's weights, bit for bit: both call the same libm `exp` in this process
  (numba's `np.exp` is the C library's), and the C code adds and multiplies in agent/'s
  order. Mountain-Car's paper agent over its 40 episodes, accumulating traces with epsilon
  draws, the pendulum, and the cart-pole's four-variable grid;
- in float, its learning curves (10 Mountain-Car agents, 6 pendulum agents) lie within the 95 % intervals of the Python
  learner's over the same seeds;
- a saved agent resumed in C goes on as the Python agent goes on;
- the RAM it declares is the RAM its object file takes, and a grid that does not fit a
  stated RAM is refused in one line, as are the learners, features and traces with no C form.
"""

import ctypes
import shutil
import subprocess

import numpy as np
import pytest
from conftest import one_line_error, run_cli
from scipy import stats

from lwrl.agent import io as agent_io
from lwrl.agent.jax_population import EXTRA, missing_jax
from lwrl.agent.sarsa import BatchedSarsa
from lwrl.export import device, learner
from lwrl.export.c import section_sizes
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents
from lwrl.tasks.batched import BatchedEnv

COMPILER = next((shutil.which(c) for c in ("cc", "gcc", "clang") if shutil.which(c)), None)
needs_compiler = pytest.mark.skipif(COMPILER is None,
                                    reason="no C compiler (cc, gcc or clang) on the PATH")
STRICT = ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Wconversion", "-Wdouble-promotion",
          "-Werror", "-ffp-contract=off"]
needs_emulated_m4 = pytest.mark.skipif(
    bool(device.missing_tools()), reason="needs the Cortex-M4 cross compiler and QEMU "
    "(gcc-arm-none-eabi, libnewlib-arm-none-eabi, qemu-system-arm)")


def learns_on_the_emulated_m4(capsys, task: str, learner_name: str, episodes: int) -> str:
    """`lwrl device run TASK --learner L --episodes K` (a new agent of the learner learning
    on the emulated Cortex-M4 and in the host build) succeeds, every episode's steps equal
    on both; its output."""
    status, out, _ = run_cli(["device", "run", task, "--learner", learner_name, "--episodes",
                              str(episodes)], capsys)
    assert status == 0 and "steps per episode equal on both" in out, out
    return out


class CLearner:
    """One C learner: `write_learner`'s files for `source` compiled as a shared library in
    `directory` (each directory its own library, so its own static state)."""

    def __init__(self, source, dtype, directory):
        written = learner.write_learner(source, directory, dtype)
        library = directory / "liblearner.so"
        result = subprocess.run([COMPILER, *STRICT, "-O2", "-shared", "-fPIC", written["source"],
                                 "-o", str(library), "-lm"], capture_output=True, text=True)
        assert result.returncode == 0, result.stderr
        self.lib = ctypes.CDLL(str(library))
        self.real = ctypes.c_double if dtype == "double" else ctypes.c_float
        self.lib.lwrl_reset.argtypes = [ctypes.c_uint64]
        self.lib.lwrl_begin.argtypes = [ctypes.POINTER(self.real)]
        self.lib.lwrl_learn.argtypes = [ctypes.POINTER(self.real), self.real, ctypes.c_int]
        self.lib.lwrl_greedy.argtypes = [ctypes.POINTER(self.real)]
        self.lib.lwrl_weights.restype = ctypes.POINTER(self.real)
        self.shape = source.agents.arrays.weights.shape[1:]
        assert written["weights"] == np.prod(self.shape)
        self.observation = (self.real * source.agents.dim)()
        self._observation = np.ctypeslib.as_array(self.observation)
        self.seed = written["seed"]
        self.lib.lwrl_reset(self.seed)

    def step(self, first, reward, discount, observation) -> int:
        """The C learner's call for one dm_env-style time step: its next action."""
        self._observation[:] = observation
        if first:
            return self.lib.lwrl_begin(self.observation)
        return self.lib.lwrl_learn(self.observation, float(reward), int(discount == 0.0))

    def greedy(self, observation) -> int:
        self._observation[:] = observation
        return self.lib.lwrl_greedy(self.observation)

    @property
    def weights(self) -> np.ndarray:
        """The weights `(A, N)`, action-major as `BatchedSarsa` stores them (a copy)."""
        return np.ctypeslib.as_array(self.lib.lwrl_weights(), shape=self.shape).astype(np.float64)

    @property
    def diverged(self) -> bool:
        return bool(self.lib.lwrl_diverged())


def episode_lengths(learners, task: str, seeds, episodes: int, time_limit: float) -> np.ndarray:
    """`(agents, episodes)` the steps of each of `learners`' (`CLearner`s) first `episodes`
    episodes, each on its own analytic plant of `task` (the seeds' `BatchedEnv`) cut at
    `time_limit` seconds."""
    env = BatchedEnv(*task.split("."), "analytic", seeds=seeds, time_limit=time_limit)
    lengths = [[] for _ in seeds]
    ts = env.reset()
    while min(len(episode) for episode in lengths) < episodes:
        actions = np.array([c.step(ts.first()[b], ts.reward[b], ts.discount[b], ts.observation[b])
                            for b, c in enumerate(learners)])
        for b in np.flatnonzero(ts.last()):
            lengths[b].append(env.steps[b])
        ts = env.step(actions)
    return np.array([episode[:episodes] for episode in lengths], dtype=float)


def python_agents(task, seeds, **settings):
    """lwrl's learner for `task` with `settings`, one agent per seed (consecutive), as
    `from_task` makes the C learner's."""
    agents = make_agents(RunConfig(task=task, agents=len(seeds), seed=seeds[0], **settings))
    assert isinstance(agents, BatchedSarsa)
    return agents


def lockstep(c_learner, agent, env, episodes):
    """Both learners on one environment (`BatchedEnv` of one), the Python learner's actions
    driving it; every step the C learner's action must be the same, and at every episode's
    end its weights. Returns the steps run."""
    ts = env.reset()
    done, steps = 0, 0
    while done < episodes:
        actions = agent.step(ts.first(), ts.reward, ts.discount, ts.observation)
        c_action = c_learner.step(ts.first()[0], ts.reward[0], ts.discount[0], ts.observation[0])
        steps += 1
        if ts.last()[0]:
            done += 1
            np.testing.assert_array_equal(c_learner.weights, agent.arrays.weights[0],
                                          err_msg=f"weights part after episode {done}")
        else:
            assert c_action == actions[0], (f"actions part at step {steps} (episode {done + 1}): "
                                            f"C {c_action}, Python {actions[0]}")
        ts = env.step(actions)
    assert c_learner.diverged == bool(agent.diverged[0])
    return steps


@needs_compiler
@pytest.mark.parametrize("task, episodes, overrides", [
    ("mountain_car.cost_to_go", 40, {}),  # the paper's best agent, Fig. 3
    ("mountain_car.cost_to_go", 12, {"trace": "accumulating", "alpha": 0.5, "epsilon": 0.1, "seed": 7}),
    ("pendulum.swingup", 3, {"seed": 3}),
    ("cartpole.balance", 25, {"epsilon": 0.05, "seed": 2}),
], ids=["mountain_car", "mountain_car_accumulating_epsilon", "pendulum", "cartpole"])
def test_double_learner_is_the_python_learner_bit_for_bit(tmp_path, task, episodes, overrides):
    overrides = dict(overrides)
    seed = overrides.pop("seed", 0)
    domain, name = task.split(".")
    env = BatchedEnv(domain, name, "analytic", seeds=[seed])
    steps = lockstep(CLearner(learner.from_task(task, seed=seed, **overrides), "double", tmp_path),
                     python_agents(task, [seed], **overrides), env, episodes)
    print(f"\n{task} {overrides}, seed {seed}: {episodes} episodes, {steps} steps, the same actions and weights")


@needs_compiler
def test_resumed_learner_goes_on_as_the_saved_agent_would(tmp_path):
    """A saved Mountain-Car agent after 5 episodes, resumed in C and in Python from the file:
    the same actions and weights over 5 more (its random stream goes on too: epsilon 0.2)."""
    task = "mountain_car.cost_to_go"
    agent = python_agents(task, [4], epsilon=0.2)
    env = BatchedEnv("mountain_car", "cost_to_go", "analytic", seeds=[4])
    lockstep(CLearner(learner.from_task(task, seed=4, epsilon=0.2), "double", tmp_path / "first"),
             agent, env, 5)
    agent_io.save(tmp_path / "agent.npz", agent, {"config": {"task": task}})
    resumed, _ = agent_io.load(tmp_path / "agent.npz")
    c_learner = CLearner(learner.from_file(tmp_path / "agent.npz"), "double", tmp_path / "resumed")
    assert c_learner.seed == int(agent.arrays.streams[0]) != 4
    np.testing.assert_array_equal(c_learner.weights, resumed.arrays.weights[0])
    lockstep(c_learner, resumed, BatchedEnv("mountain_car", "cost_to_go", "analytic", seeds=[11]), 5)
    header = (tmp_path / "resumed" / "lwrl_learner.h").read_text()
    assert "resumed from agent 0 of" in header and "Task: mountain_car.cost_to_go" in header


def learning_curves(task, seeds, episodes, tmp_path, measure):
    """Per seed and episode, `measure(env, b)` at each episode's end for the C float learner
    and for the Python learner, each on its own `BatchedEnv` of those seeds; for each, the
    values `(seeds, episodes)` and the final weights `(seeds, A, N)`."""
    domain, name = task.split(".")
    curves = {}
    c_learners = [CLearner(learner.from_task(task, seed=seed), "float", tmp_path / f"c{seed}")
                  for seed in seeds]
    for kind in ("c", "python"):
        env = BatchedEnv(domain, name, "analytic", seeds=seeds)
        agent = python_agents(task, seeds)
        values = np.full((len(seeds), episodes), np.nan)
        done = np.zeros(len(seeds), dtype=int)
        ts = env.reset()
        while (done < episodes).any():
            if kind == "python":
                actions = agent.step(ts.first(), ts.reward, ts.discount, ts.observation)
            else:
                actions = np.array([c.step(ts.first()[b], ts.reward[b], ts.discount[b], ts.observation[b])
                                    for b, c in enumerate(c_learners)])
            for b in np.flatnonzero(ts.last()):
                if done[b] < episodes:
                    values[b, done[b]] = measure(env, b)
                done[b] += 1
            ts = env.step(actions)
        weights = (np.array([c.weights for c in c_learners]) if kind == "c"
                   else np.array(agent.arrays.weights))
        curves[kind] = values, weights
    return curves["c"], curves["python"]


def t_interval(values):
    """The 95 % t interval of the mean of `values` over the first axis."""
    mean = values.mean(axis=0)
    half = stats.t.ppf(0.975, len(values) - 1) * values.std(axis=0, ddof=1) / np.sqrt(len(values))
    return mean - half, mean + half


@needs_compiler
@pytest.mark.parametrize("task, agents, episodes, block, measure", [
    ("mountain_car.cost_to_go", 10, 30, 10, lambda env, b: env.steps[b]),
    ("pendulum.swingup", 6, 4, 2, lambda env, b: env.uptime[b]),
], ids=["mountain_car_steps", "pendulum_uptime"])
def test_float_learner_learns_within_the_python_learners_intervals(tmp_path, task, agents, episodes,
                                                                   block, measure):
    """Agents of seeds 0, 1, ..., per block of episodes: the C float learner's mean lies in
    the 95 % t interval of the Python learner's mean over the same seeds."""
    seeds = list(range(agents))
    (c_values, c_weights), (python_values, python_weights) = learning_curves(
        task, seeds, episodes, tmp_path, measure)
    c_blocks = c_values.reshape(len(seeds), -1, block).mean(axis=2)
    python_blocks = python_values.reshape(len(seeds), -1, block).mean(axis=2)
    low, high = t_interval(python_blocks)
    c_mean = c_blocks.mean(axis=0)
    scale = np.abs(python_weights).max()
    print(f"\n{task} float C learner, block means {np.round(c_mean, 2)}; Python's 95 % "
          f"intervals {np.round(low, 2)} .. {np.round(high, 2)}; {np.sum(c_values == python_values)} "
          f"of {c_values.size} episodes measure the same; final weights differ by up to "
          f"{np.abs(c_weights - python_weights).max() / scale:.2g} of the largest")
    assert np.all((low <= c_mean) & (c_mean <= high)), (c_mean, low, high)
    # The C learner ran in float: its weights are not the double learner's.
    assert 0 < np.abs(c_weights - python_weights).max()


@needs_compiler
def test_greedy_is_the_argmax_of_the_learned_weights(tmp_path):
    agent = python_agents("mountain_car.cost_to_go", [1])
    c_learner = CLearner(learner.from_task("mountain_car.cost_to_go", seed=1), "double", tmp_path)
    lockstep(c_learner, agent, BatchedEnv("mountain_car", "cost_to_go", "analytic", seeds=[1]), 3)
    states = np.random.default_rng(0).uniform((-1.2, -0.07), (0.5, 0.07), size=(300, 2))
    q = agent.action_values(states)[0]
    greedy = np.array([c_learner.greedy(state) for state in states])
    np.testing.assert_array_equal(greedy, q.argmax(axis=1))


@needs_compiler
def test_declared_ram_is_the_objects_static_data(tmp_path):
    """`ram_bytes` against the object file's .bss and .data (`size -A`): equal up to the
    compiler's alignment padding."""
    for task in ("mountain_car.cost_to_go", "cartpole.balance"):
        for dtype in ("float", "double"):
            written = learner.write_learner(learner.from_task(task), tmp_path / task / dtype, dtype)
            assert written["ram"]["total"] == sum(v for k, v in written["ram"].items() if k != "total")
            obj = tmp_path / task / dtype / "learner.o"
            subprocess.run([COMPILER, *STRICT, "-O2", "-c", written["source"], "-o", str(obj)], check=True)
            sections = section_sizes(obj)
            static = sum(v for k, v in sections.items() if k.startswith((".bss", ".data")))
            assert written["ram"]["total"] <= static <= written["ram"]["total"] + 64, (task, dtype, static)


def test_bad_inputs_are_refused_in_one_line(tmp_path):
    source = learner.from_task("cartpole.balance")
    one_line_error(lambda: learner.write_learner(source, tmp_path, "float", ram=16384),
                   "6 x 6 x 6 x 6 grid's learner needs 31228 bytes", "more than the 16384 allowed")
    learner.write_learner(source, tmp_path / "fits", "float", ram=31228)
    one_line_error(lambda: learner.write_learner(source, tmp_path, "half"), "dtype must be one of")
    one_line_error(lambda: learner.from_task("nowhere.task"), "unknown task")
    for settings, fragments in (
            ({"trace": "replacing_reset"}, ("replacing and accumulating traces", "replacing_reset")),
            ({"features": "cmac"}, ("only NRBF agents can learn in C", "CMAC")),
            ({"learner": "true_online_sarsa"}, ("true_online_sarsa agents cannot learn in C",))):
        refused = learner.from_task("mountain_car.cost_to_go", **settings)
        one_line_error(lambda: learner.write_learner(refused, tmp_path / "refused"), *fragments)
    assert not (tmp_path / "refused").exists()
    one_line_error(lambda: learner.from_task("mountain_car.cost_to_go", alpha=0.0), "alpha")
    one_line_error(lambda: learner.from_task("mountain_car.cost_to_go", lam=1.5), "lambda")
    one_line_error(lambda: learner.from_task("mountain_car.cost_to_go", seed=-1), "seed")
    one_line_error(lambda: learner.write_learner(learner.from_task("mountain_car.cost_to_go", alpha=1e39),
                                                 tmp_path / "big"), "alpha = 1e+39 do not fit float32")
    one_line_error(lambda: learner.from_file(tmp_path / "missing.npz"), "no such agent file")
    (tmp_path / "file").write_text("")
    one_line_error(lambda: learner.write_learner(source, tmp_path / "file", "float"), "cannot write")


def test_the_cli_takes_lwrl_trains_flags_for_a_task_and_none_for_a_saved_agent(tmp_path, capsys):
    status, out, _ = run_cli(["learner", "mountain_car.cost_to_go", "--c", str(tmp_path / "new"),
                              "--trace", "accumulating", "--lambda", "0.5", "--seed", "3"], capsys)
    assert status == 0 and "accumulating traces, alpha 3.9, lambda 0.5" in out
    assert "#define LWRL_SEED UINT64_C(3)" in (tmp_path / "new" / "lwrl_learner.h").read_text()
    agent_io.save(tmp_path / "agents.npz", python_agents("mountain_car.cost_to_go", [0, 1]))
    status, _, err = run_cli(["learner", str(tmp_path / "agents.npz"), "--c", str(tmp_path / "saved"),
                              "--lambda", "0.5", "--seed", "1"], capsys)
    assert status == 2 and err == ["lwrl learner: error: --lambda, --seed: a resumed agent keeps its "
                                   "own learner, settings and stream; these apply to a task"]
    status, out, _ = run_cli(["learner", str(tmp_path / "agents.npz"), "--agent", "1", "--c",
                              str(tmp_path / "saved")], capsys)
    assert status == 0 and "resumed from agent 1 of" in out
    status, _, err = run_cli(["learner", "cartpole.balance", "--learner", "ase_ace", "--c",
                              str(tmp_path / "other")], capsys)
    assert status == 2 and err == ["lwrl learner: error: ase_ace agents cannot learn in C"]


@needs_compiler
@pytest.mark.skipif(missing_jax(), reason=f"ARS and stream-Q are JAX populations: {EXTRA}")
@pytest.mark.parametrize("name, rtol", [("ars", 0.0), ("stream_q", 1e-6)])
def test_a_learner_learns_over_the_device_link_as_it_learns_alone(tmp_path, capsys, name, rtol):
    """`lwrl device hil TASK --learner L` for the learners whose C learner draws its own
    numbers (not the JAX agent's): the device program (built for this machine, in double)
    over the link takes the steps the same C learner takes driven directly on the same
    episodes, and its weights, fetched by frames and saved, are that learner's (to the bit,
    or within float32's rounding where the agent keeps float32 networks) and load as an
    agent that `lwrl eval` runs."""
    import csv

    episodes, out, saved = 20, tmp_path / "run", tmp_path / "agent.npz"
    assert run_cli(["device", "hil", "mountain_car.cost_to_go", "--learner", name, "--episodes",
                    str(episodes), "--seed", "3", "--env-seed", "11", "--time-limit", "50",
                    "--out", str(out), "--save", str(saved)], capsys)[0] == 0
    with open(out / "episodes.csv") as file:
        steps = [int(row["steps"]) for row in csv.DictReader(file)]
    alone = CLearner(learner.from_task("mountain_car.cost_to_go", seed=3, learner=name),
                     "double", tmp_path)
    own = episode_lengths([alone], "mountain_car.cost_to_go", [11], episodes, 50.0)[0]
    assert steps == own.tolist() and len(set(steps)) > 1
    loaded, metadata = agent_io.load(saved)
    assert metadata["config"]["learner"] == name
    np.testing.assert_allclose(loaded.arrays.weights[0], alone.weights.ravel(), rtol=rtol, atol=0)
    assert run_cli(["eval", str(saved), "--episodes", "1"], capsys)[0] == 0
