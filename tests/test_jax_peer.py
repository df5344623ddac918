"""The JAX peer of the speed benchmark (`benchmarks/jax_peer.py`) computes lwrl's algorithm:
the same features and plant steps, and its agents learn as lwrl's do. It measures no speed
here. CI does not install JAX; these tests run where it is (the `jax` extra)."""

import numpy as np
import pytest

pytest.importorskip("jax", reason="the JAX peer needs JAX (the jax extra); CI does not "
                                  "install it")

import jax  # noqa: E402

from benchmarks import jax_peer  # noqa: E402
from lwrl.runners.config import RunConfig  # noqa: E402
from lwrl.tasks import cartpole, mountain_car  # noqa: E402


@pytest.mark.parametrize("task", list(jax_peer.TASKS))
def test_the_peer_computes_lwrls_features(task):
    """The peer's NRBF features equal `agent/nrbf.py`'s, far outside the ranges too (the
    underflow guard and the clamp)."""
    agent, _, _ = jax_peer.peer_agents(task, 1)
    config = RunConfig(task=task)
    features = config.agent.feature_map(config.task_info.low, config.task_info.high)
    rng = np.random.default_rng(0)
    low, high = np.array(features.low), np.array(features.high)
    states = low + (high - low) * rng.uniform(-0.5, 1.5, size=(200, len(low)))
    states[:5] *= [[1.0], [50.0], [-1e3], [1e20], [-1e200]]
    ours = np.asarray(jax.vmap(lambda s: jax_peer.features(agent, s))(states))
    np.testing.assert_allclose(ours, features.features(states), rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(ours.sum(axis=1), 1.0, rtol=1e-12)


def test_the_peer_steps_the_tasks_plants():
    """One step of the peer's plants equals the task modules' own `step` and `outcome`."""
    rng = np.random.default_rng(1)
    for state in rng.uniform((-1.2, -0.07), (0.5, 0.07), size=(100, 2)):
        for thrust in mountain_car.THRUSTS:
            expected = np.array(mountain_car.step(*state, thrust, np.asarray(mountain_car.NOMINAL)))
            ours = np.asarray(jax_peer.mountain_car_step(state, thrust))
            np.testing.assert_allclose(ours, expected, rtol=1e-14, atol=1e-17)
            reward, terminal = jax_peer.mountain_car_outcome(ours)
            assert (float(reward), bool(terminal)) == tuple(
                mountain_car.outcome(*expected, np.asarray(mountain_car.NOMINAL))[:2])
    for state in rng.uniform((-2.5, -2.0, -0.25, -3.0), (2.5, 2.0, 0.25, 3.0), size=(100, 4)):
        for force in cartpole.FORCES:
            expected = np.array(cartpole.step(*state, force, cartpole.TIMESTEP, True, False,
                                              np.asarray(cartpole.NOMINAL)))
            ours = np.asarray(jax_peer.cartpole_step(state, force))
            np.testing.assert_allclose(ours, expected, rtol=1e-13, atol=1e-15)
            reward, terminal = jax_peer.cartpole_outcome(ours)
            expected_outcome = cartpole.outcome(*expected, cartpole.TRACK_LIMIT,
                                                np.asarray(cartpole.NOMINAL))
            assert (float(reward), bool(terminal)) == (float(expected_outcome[0]),
                                                        bool(expected_outcome[1]))


def test_the_peer_learns_mountain_car_as_lwrl_does():
    """The paper's best Mountain-Car agent (replacing traces, alpha 3.9, lambda 0.9,
    epsilon 0, NRBF 8 x 8), 30 agents x 40 episodes, in the peer and in lwrl's compiled
    loop: both about 60 steps per episode over episodes 31 to 40 (the paper's Fig. 3), from
    hundreds in the first. Measured: the peer 62.7 ± 2.3, lwrl 60.8 ± 2.3 (means ± standard
    errors over agents); their random streams differ, so their numbers do too."""
    steps = jax_peer.learning_check(agents=30, episodes=40)
    peer, ours = np.mean(steps["JAX peer"][:, 30:40]), np.mean(steps["lwrl"][:, 30:40])
    assert peer < 90 and ours < 90
    assert abs(peer - ours) < 15  # about 4.5 standard errors of the difference
    assert np.mean(steps["JAX peer"][:, 0]) > 200  # it did have to learn
