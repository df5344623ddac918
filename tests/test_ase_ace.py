"""ASE/ACE (Barto, Sutton and Anderson 1983): its constants, its boxes against `pole.c`'s
`get_box`, one step by hand, the tasks it fits, and learning the cart-pole."""

import dataclasses
import math

import numpy as np
import pytest

from lwrl.agent.ase_ace import BOXES, AseAceAgents, AseAceSettings, box_of
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents, run


def test_the_constants_are_the_papers():
    """Barto et al. (1983), section V, and `pole.c`: alpha 1000, beta 0.5, delta 0.9 (the
    ASE's trace), gamma 0.95, lambda 0.8 (the ACE's trace), sigma 0.01, 162 boxes."""
    settings = AseAceSettings()
    assert dataclasses.astuple(settings)[:6] == (1000.0, 0.5, 0.9, 0.95, 0.8, 0.01)
    assert settings.policy == "gaussian" and BOXES == 162


def get_box(x, x_dot, theta, theta_dot):
    """`pole.c`'s `get_box`, written out (with exact degrees)."""
    one, six, fifty = math.radians(1), math.radians(6), math.radians(50)
    box = 0 if x < -0.8 else 1 if x < 0.8 else 2
    box += 0 if x_dot < -0.5 else 3 if x_dot < 0.5 else 6
    box += (0 if theta < -six else 9 if theta < -one else 18 if theta < 0 else
            27 if theta < one else 36 if theta < six else 45)
    box += 0 if theta_dot < -fifty else 54 if theta_dot < fifty else 108
    return box


def test_boxes_are_pole_cs():
    """Every box is reached, each numbered as `get_box` numbers it, edges included."""
    rng = np.random.default_rng(0)
    agent = AseAceAgents(seeds=[0])
    edges = [-0.8, 0.8, -0.5, 0.5, *map(math.radians, (-6, -1, 0, 1, 6, -50, 50))]
    states = rng.uniform(-1, 1, size=(20000, 4)) * [2.4, 1.5, math.radians(12), 2.0]
    states[:40] = rng.choice(edges, size=(40, 4))
    boxes = [box_of(state, agent.arrays.edges) for state in states]
    assert boxes == [get_box(*state) for state in states]
    assert set(boxes) == set(range(BOXES))


def test_one_step_by_hand():
    """First step in box k (zero weights): the action y = +-1, e[k] = (1 - delta) y = 0.1 y,
    x_bar[k] = 1 - lambda = 0.2, p(t - 1) = 0. Then a failure (r = -1, p = 0): r_hat = -1,
    w[k] = 1000 * -1 * 0.1 y = -100 y, v[k] = 0.5 * -1 * 0.2 = -0.1, and the traces decay to
    0.09 y and 0.16."""
    agent = AseAceAgents(seeds=[3])
    state = np.array([[0.1, -0.2, 0.05, 0.3]])
    k = box_of(state[0], agent.arrays.edges)
    action = agent.step([True], [0.0], [1.0], state)[0]
    y = 1.0 if action == 1 else -1.0
    assert agent.arrays.e[0, k] == pytest.approx(0.1 * y) and agent.arrays.xbar[0, k] == pytest.approx(0.2)
    assert agent.step([False], [-1.0], [0.0], [[0.1, -0.2, 0.3, 0.3]])[0] == 0
    assert agent.arrays.delta[0] == -1.0
    assert agent.arrays.weights[0, 0, k] == pytest.approx(-100 * y)
    assert agent.arrays.weights[0, 1, k] == pytest.approx(-0.1)
    assert agent.arrays.e[0, k] == pytest.approx(0.09 * y) and agent.arrays.xbar[0, k] == pytest.approx(0.16)
    assert np.count_nonzero(agent.arrays.weights) == 2
    # Greedy, it pushes the way its weight says, without a draw from its stream.
    streams = agent.arrays.streams.copy()
    greedy = agent.step([True], [0.0], [1.0], state, learn=False, greedy=True)[0]
    assert greedy == (1 if -100 * y >= 0 else 0)
    np.testing.assert_array_equal(agent.arrays.streams, streams)


def test_it_fits_the_cartpole_only():
    for task in ("mountain_car.cost_to_go", "pendulum.swingup", "acrobot.swingup"):
        with pytest.raises(ValueError, match=f"^ase_ace fits the cart-pole .*; {task} has"):
            RunConfig(task=task, learner="ase_ace")
    assert make_agents(RunConfig(task="cartpole.balance", learner="ase_ace")).batch_size == 10


def test_it_learns_to_balance():
    """Four agents, 80 trials on the analytic plant: the first ten fail within seconds; by
    the last ten the agents' mean up-time is several times longer."""
    config = RunConfig(task="cartpole.balance", plant="analytic", learner="ase_ace", agents=4,
                       episodes=80)
    _, results = run(config)
    first, last = np.nanmean(results.uptime[:, :10]), np.nanmean(results.uptime[:, -10:])
    assert first < 10 and last > 5 * first


def test_values_are_the_actors_preferences_and_the_critics_prediction():
    agent = make_agents(RunConfig(task="cartpole.balance", learner="ase_ace", agents=2))
    rng = np.random.default_rng(1)
    agent.arrays.weights[:] = rng.normal(size=agent.arrays.weights.shape)
    states = rng.uniform(-1, 1, size=(5, 4)) * [2.4, 1.5, 0.2, 2.0]
    boxes = [box_of(state, agent.arrays.edges) for state in states]
    preferences = agent.action_values(states)
    np.testing.assert_array_equal(preferences[1, :, 1], agent.arrays.weights[1, 0, boxes])
    np.testing.assert_array_equal(preferences[..., 0], -preferences[..., 1])
    np.testing.assert_array_equal(agent.state_values(states, agent.arrays.weights[0]),
                                  agent.arrays.weights[0, 1, boxes])


def test_its_settings_are_its_own():
    """Settings of other learners are refused in one line, and its own reach it."""
    with pytest.raises(ValueError, match="^n is not a setting of ase_ace; its settings: alpha, "
                                         "beta, delta, gamma, lam, policy, sigma$"):
        RunConfig(task="cartpole.balance", learner="ase_ace", n=6)
    with pytest.raises(ValueError, match="^beta is not a setting of sarsa"):
        RunConfig(task="cartpole.balance", beta=0.5)
    assert RunConfig(task="cartpole.balance", learner="ase_ace", beta=0.25).settings.beta == 0.25
