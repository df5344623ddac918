"""The protocol's greedy evaluation of any library's policy (studies/paper/benchmark/
harness.py, `lwrl.bench`, `lwrl bench evaluate`): its episodes are the suite's own from the
protocol's starts, a policy of a batch, of one observation, with SB3's `predict` or in JAX
acts alike, saved agents act as the protocol evaluates them, and its results file is one
`lwrl bench score` takes."""

import numpy as np
import pytest
from conftest import one_line_error, run_cli

from lwrl import bench, tasks
from lwrl.agent import io as agent_io
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents
from lwrl.runners.stepped import run_batched
from lwrl.tasks.batched import flatten_observation
from lwrl.studies.paper.benchmark import evaluation, harness, outside, protocol

TASK = "mountain_car.cost_to_go"


def pump(observations):
    """Push along the velocity (Mountain-Car's actions: 0 left, 2 right), a batch."""
    return np.where(observations[:, 1] >= 0, 2, 0)


def pump_one(observation):
    return 2 if observation[1] >= 0 else 0


class Model:
    """Stable-Baselines3's face: `predict(observations, deterministic)` -> (actions, state)."""

    def predict(self, observations, deterministic=False):
        assert deterministic
        return pump(observations), None


def test_the_episodes_are_the_suites_own_from_the_protocols_starts():
    """Agent 3's episodes are those of one dm_env environment seeded 3 + 10 000, capped at
    the protocol's 1000 steps, stepped here by hand."""
    evaluated = harness.evaluate(pump, TASK, seed=3)
    env = tasks.load("mountain_car", "cost_to_go", seed=3 + evaluation.EVALUATION_SEED,
                     **evaluation.episode_options(TASK))
    steps = []
    for _ in range(evaluation.EPISODES):
        step, count = env.reset(), 0
        while not step.last():
            step, count = env.step(pump_one(flatten_observation(step.observation))), count + 1
        steps.append(count)
    assert evaluated.table["steps"].tolist() == steps
    assert evaluated.table["seed"].tolist() == [3] * evaluation.EPISODES


def test_a_policy_of_a_batch_of_one_observation_of_sb3_or_jax_acts_alike():
    every = harness.evaluate(pump, TASK, fraction=0.5)
    assert every.table["seed"].tolist() == np.repeat(range(protocol.AGENTS), evaluation.EPISODES).tolist()
    assert (every.table["fraction"] == 0.5).all()
    for policy in (pump_one, Model()):
        assert harness.evaluate(policy, TASK, fraction=0.5).table.equals(every.table)
    jnp = pytest.importorskip("jax.numpy")
    jax_policy = lambda o: jnp.where(o[:, 1] >= 0, 2, 0)  # noqa: E731
    assert harness.evaluate(jax_policy, TASK, fraction=0.5).table.equals(every.table)


def test_the_results_follow_the_protocol():
    evaluations = [bench.evaluate(pump, TASK, None, f) for f in bench.FRACTIONS]
    table = bench.results(evaluations, "pump")
    assert set(table["protocol"]) == {bench.VERSION}
    assert set(table["starts"]) == {evaluation.protocol_digest(TASK)}
    outside.check(table, "pump")
    one_line_error(lambda: bench.results(evaluations[1:], "pump"), "fraction must take each of")


def test_an_episode_that_does_not_reach_the_goal_counts_the_cap():
    idle = harness.evaluate(lambda o: np.ones(len(o), dtype=int), TASK, seed=0).table["steps"]
    assert idle.max() == bench.STEP_CAP and (idle <= bench.STEP_CAP).all()


def test_a_continuous_policy_acts_by_u_in_minus_one_to_one(monkeypatch):
    """On the pendulum with any torque, u = 1 and u = -1 are the two ends of the actuator's
    range, and beyond it the actuator saturates (one episode each: 3000 steps)."""
    monkeypatch.setattr(evaluation, "EPISODES", 1)
    task = "pendulum.swingup-continuous"
    ran = {u: harness.evaluate(lambda o, u=u: np.full(len(o), u), task, seed=0).table
           for u in (1.0, -1.0, 2.0)}
    assert ran[2.0].equals(ran[1.0])
    assert ran[-1.0]["uptime_s"].iloc[0] != ran[1.0]["uptime_s"].iloc[0]


@pytest.mark.parametrize("policy, fragment", [
    (lambda o: np.full(len(o), 3), "action"),
    (lambda o: np.zeros((len(o), 2), dtype=int), "one action per observation"),
    ("pump", "a policy is a function of observations"),
])
def test_a_policy_that_is_not_the_tasks_is_one_line(policy, fragment):
    one_line_error(lambda: harness.evaluate(policy, TASK, seed=0), fragment)


@pytest.mark.parametrize("arguments, fragment", [
    ({"seed": 20}, "seed must be an integer 0 to 19"),
    ({"fraction": 0.3}, "fraction must be one of 0.1, 0.25, 0.5, 1.0"),
    ({"task": "mountain_car.cost_to_go", "plant": "mujoco"}, "unknown benchmark task"),
])
def test_what_the_protocol_does_not_have_is_one_line(arguments, fragment):
    arguments = {"task": TASK, **arguments}
    one_line_error(lambda: harness.evaluate(pump, **arguments), fragment)


def test_lwrl_bench_evaluate_writes_a_file_that_scores(tmp_path, monkeypatch, capsys):
    """`--policy MODULE:NAME` and `--agents MODULE:NAME` (from the current directory), with
    fewer agents so that it runs in seconds."""
    monkeypatch.setattr(protocol, "AGENTS", 2)
    (tmp_path / "mine.py").write_text(
        "import numpy as np\n"
        "def act(o):\n    return np.where(o[:, 1] >= 0, 2, 0)\n"
        "def agents(seed, fraction):\n    return act\n")
    monkeypatch.chdir(tmp_path)
    status, _, err = run_cli(["bench", "evaluate", TASK, "--policy", "mine:act", "--learner",
                              "pump"], capsys)
    assert status == 0, err
    written = tmp_path / f"pump-{TASK}.csv.gz"
    first = outside.read(str(written))
    status, _, err = run_cli(["bench", "evaluate", TASK, "--agents", "mine:agents", "--learner",
                              "pump", "--out", str(written)], capsys)
    assert status == 2 and "exists; use --force" in err[0]
    status, _, err = run_cli(["bench", "evaluate", TASK, "--agents", "mine:agents", "--learner",
                              "pump", "--out", str(written), "--force"], capsys)
    assert status == 0, err
    assert outside.read(str(written)).equals(first)
    for argv, fragment in [(["--policy", "mine:missing"], "mine has no missing"),
                           (["--policy", "absent:act"], "cannot import absent"),
                           (["--policy", "mine"], "--policy must be MODULE:NAME"),
                           (["--policy", "mine:act", "--learner", "paper"], "the name of a row")]:
        status, _, err = run_cli(["bench", "evaluate", TASK, "--learner", "x", *argv], capsys)
        assert status == 2 and len(err) == 1 and fragment in err[0], err


@pytest.fixture
def saved(tmp_path, monkeypatch):
    """Two Mountain-Car agents of the paper's learner with weights of their own, the second
    diverged in training, saved (`lwrl train --save`'s file); the protocol's agents two and
    its cap 100 steps, so that it runs in seconds."""
    monkeypatch.setattr(protocol, "AGENTS", 2)
    monkeypatch.setattr(evaluation, "STEP_CAP", 100)
    config = RunConfig(task=TASK, plant="analytic", agents=2, episodes=1)
    agent = make_agents(config)
    agent.weights[:] = np.random.default_rng(0).normal(size=agent.weights.shape)
    agent.arrays.diverged[1] = True
    path = tmp_path / "agents.npz"
    agent_io.save(path, agent, {"config": {"task": TASK}})
    return path


def test_saved_agents_act_as_the_protocol_evaluates_them_a_diverged_one_at_the_worst(saved):
    evaluated = harness.evaluate(agent_io.load(saved)[0], TASK)
    env = evaluation.evaluation_env(TASK, 2, "analytic")
    direct = run_batched(env, agent_io.load(saved)[0], evaluation.EPISODES, learn=False,
                         greedy=True)
    table = evaluated.table
    assert table[table["seed"] == 0]["steps"].tolist() == direct.steps[0].tolist()
    assert (table[table["seed"] == 1]["steps"] == 100).all()  # diverged: the worst, the cap
    table = bench.results([harness.evaluate(agent_io.load(saved)[0], TASK, None, f)
                           for f in protocol.FRACTIONS], "saved")
    outside.check(table, "saved")  # the diverged agent's starts are the protocol's too
    one_line_error(lambda: harness.evaluate(agent_io.load(saved)[0], TASK, seed=0),
                   "saved agents are evaluated together")


def test_lwrl_bench_evaluate_takes_saved_agents_for_each_fraction(saved, tmp_path, capsys):
    given = [arg for f in protocol.FRACTIONS for arg in ("--saved", f"{f:g}={saved}")]
    out = tmp_path / "saved.csv.gz"
    status, _, err = run_cli(["bench", "evaluate", TASK, *given, "--learner", "saved", "--out",
                              str(out)], capsys)
    assert status == 0, err
    assert len(outside.read(str(out))) == len(protocol.FRACTIONS) * 2 * evaluation.EPISODES
    status, _, err = run_cli(["bench", "evaluate", TASK, *given[:-2], "--learner", "saved",
                              "--out", str(tmp_path / "other.csv")], capsys)
    assert status == 2 and "--saved must give one file for each fraction 0.1, 0.25, 0.5, 1" in err[0]
