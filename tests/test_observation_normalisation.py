"""Observation normalisation as a setting (`agent.observation_normalisation`: the deep
learners' JAX populations, SB3's `VecNormalize`; `agent.stream_agents`: the streaming
learners' own): what the networks read is the hand-computed normalisation, the default keeps
the run keys, a saved and loaded agent acts as it did, and a bad value is refused in one line."""

import dataclasses

import numpy as np
import pytest

pytest.importorskip("jax", reason="the population learners need the jax extra: pip install 'lwrl[jax]'")

from lwrl.agent import io  # noqa: E402
from lwrl.agent.controller_forms import controller  # noqa: E402
from lwrl.runners.config import RunConfig  # noqa: E402
from lwrl.runners.run import make_agents, run  # noqa: E402
from conftest import one_line_error  # noqa: E402

DQN = RunConfig(task="cartpole.balance", learner="dqn_jax", agents=2, episodes=2, seed=3,
                plant="analytic", task_options={"time_limit": 1.0}, timesteps=200,
                buffer_size=100, learning_starts=50, net_arch="8", normalize_observations=True)
"""A small dqn_jax run whose agents normalise their observations."""


@pytest.fixture(scope="module")
def trained():
    """`(config, agents, results)` of `DQN` run for three calls of the compiled program
    (`CHUNK` steps each, its episodes more than the budget lets run), computed once: trained
    normalising agents, and the run a stopped one must give again."""
    from lwrl.runners.population import CHUNK
    config = dataclasses.replace(DQN, episodes=2000, budget=3 * CHUNK, timesteps=3 * CHUNK)
    return config, *run(config)


def one_agent(tree, b=0):
    """Agent b's part of a batch's pytree."""
    import jax
    return jax.tree.map(lambda leaf: leaf[b], tree)


def test_the_first_observations_are_read_normalised_as_computed_by_hand():
    """The replay buffer holds what the network reads: the first observation normalised by
    itself alone (variance 1 before two samples: 0), the second and its next observation by
    the mean and sample variance of the two, clipped to +-10 (`VecNormalize`'s `clip_obs`)."""
    import jax.numpy as jnp
    agents = make_agents(DQN)
    program = agents.trained_program()
    state = one_agent(agents.state)
    hyper = one_agent(program.hyper)
    key = jnp.zeros(2, jnp.uint32)
    first, second, after = (np.array([0.1, -0.2, 0.3, 0.0]), np.array([0.5, 0.2, -0.1, 4.0]),
                            np.array([0.4, 0.3, 0.1, 1e6]))
    for clock, (observation, final) in enumerate([(first, second), (second, after)]):
        action, extras = program.act(state, jnp.asarray(observation), key, hyper, False, clock)
        state = program.record(state, extras, jnp.asarray(observation), action, jnp.asarray(1.0),
                               jnp.asarray(False), jnp.asarray(False), jnp.asarray(final), hyper,
                               clock, jnp.asarray(True))
    both = np.stack([first, second])
    mean, variance = both.mean(axis=0), both.var(axis=0, ddof=1)
    expected = np.clip((np.stack([second, after]) - mean) / np.sqrt(variance + 1e-8), -10, 10)
    buffer = state["buffer"]
    np.testing.assert_array_equal(np.asarray(buffer["observations"][0]), np.zeros(4, np.float32))
    np.testing.assert_allclose(np.asarray(buffer["observations"][1]), expected[0].astype(np.float32),
                               rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(np.asarray(buffer["next_observations"][1]),
                               expected[1].astype(np.float32), rtol=1e-6, atol=1e-12)
    assert np.asarray(buffer["next_observations"][1])[3] == 10.0  # clipped
    np.testing.assert_allclose(np.asarray(state["observation_stats"]["mean"]), mean, rtol=1e-12)
    assert float(state["observation_stats"]["count"]) == 2.0


def test_a_greedy_act_leaves_the_statistics_as_learning_left_them():
    import jax.numpy as jnp
    agents = make_agents(DQN)
    program = agents.trained_program()
    state, hyper = one_agent(agents.state), one_agent(program.hyper)
    _, extras = program.act(state, jnp.ones(4), jnp.zeros(2, jnp.uint32), hyper, True, 0)
    assert float(extras["observation_stats"]["count"]) == 0.0


@pytest.mark.parametrize("learner, default", [("dqn_jax", False), ("ppo_jax", False),
                                              ("sac_jax", False), ("td3_jax", False),
                                              ("stream_q", True), ("stream_ac", True)])
def test_the_default_keeps_the_run_key_and_the_other_value_changes_it(learner, default):
    options = {"actions": "continuous"} if learner in ("sac_jax", "td3_jax", "stream_ac") else {}
    plain = RunConfig(task="pendulum.swingup", learner=learner, task_options=options)
    assert dataclasses.replace(plain, normalize_observations=default).key == plain.key
    assert dataclasses.replace(plain, normalize_observations=not default).key != plain.key
    assert f'"normalize_observations": {str(default).lower()}' not in plain.key_json()


def test_a_saved_and_loaded_normalising_agent_acts_as_it_did(tmp_path, trained):
    _, agents, _ = trained
    assert float(agents.state["observation_stats"]["count"][0]) > 0
    path = tmp_path / "agents.npz"
    io.save(path, agents)
    loaded, _ = io.load(path)
    np.testing.assert_array_equal(loaded.arrays.weights, agents.arrays.weights)
    states = np.random.default_rng(0).normal(size=(5, 4))
    np.testing.assert_array_equal(loaded.action_values(states), agents.action_values(states))
    zeros = np.zeros(2)
    for observation in states:
        batch = np.stack([observation, observation])
        np.testing.assert_array_equal(
            loaded.step(np.ones(2, bool), zeros, zeros, batch, learn=False, greedy=True),
            agents.step(np.ones(2, bool), zeros, zeros, batch, learn=False, greedy=True))


def test_the_action_values_read_the_states_normalised(trained):
    """A normalising agent's values at task-unit states are its network's at the states
    normalised by its statistics."""
    from lwrl.agent import observation_normalisation
    _, agents, _ = trained
    states = np.random.default_rng(1).normal(size=(3, 4))
    tree = agents.unflatten(agents.arrays.weights[1])
    inputs = observation_normalisation.normalised(states, tree["observations"])
    np.testing.assert_allclose(agents.action_values(states)[1],
                               np.asarray(agents.q_values(tree["weights"], inputs)), rtol=1e-12)


def test_a_streaming_learner_without_normalisation_reads_task_units_and_exports_so():
    from lwrl.agent import streaming
    config = RunConfig(task="cartpole.balance", learner="stream_q", agents=1, episodes=2, seed=2,
                       plant="analytic", task_options={"time_limit": 1.0}, timesteps=100,
                       net_arch="8", normalize_observations=False)
    agents, _ = run(config)
    states = np.random.default_rng(2).normal(size=(3, 4))
    tree = agents.unflatten(agents.arrays.weights[0])
    np.testing.assert_array_equal(agents.action_values(states)[0], np.asarray(
        streaming.forward(tree["params"], np.asarray(states, np.float32)), np.float64))
    form = controller(agents, 0)
    assert form.values["normalise"] == "0" and "input_mean" not in form.values
    assert controller(make_agents(dataclasses.replace(config, normalize_observations=True)),
                      0).values["normalise"] == "1"


@pytest.mark.parametrize("learner", ["dqn_jax", "stream_q"])
def test_a_bad_value_is_refused_in_one_line(learner):
    one_line_error(lambda: RunConfig(task="cartpole.balance", learner=learner,
                                     normalize_observations="yes"),
                   "normalize_observations must be true or false", "'yes'")


def test_a_stopped_normalising_run_goes_on_from_its_kept_statistics(trained):
    """The statistics are a part of the state a stopped run keeps (`runners.resume`): going on
    gives the numbers, the weights and the statistics of the run computed in one go
    (`trained`)."""
    import tempfile
    from pathlib import Path
    from lwrl.runners.population import CHUNK
    config, whole_agents, whole = trained
    calls = []

    def stop_at_second(_):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "run.resume.npz"
        _, stopped = run(config, resume=path, progress=stop_at_second)
        assert stopped.interrupted
        agents, resumed = run(config, resume=path)
    assert not resumed.interrupted and resumed.earlier_compute[0] > 0
    for field in ("steps", "returns", "truncated", "diverged_episode"):
        np.testing.assert_array_equal(getattr(resumed, field), getattr(whole, field))
    np.testing.assert_array_equal(agents.arrays.weights, whole_agents.arrays.weights)
    assert float(agents.state["observation_stats"]["count"][0]) > CHUNK
