"""Gradient-descent Sarsa(lambda) (eq. 1) with NRBF features, for a batch of agents."""

import numpy as np
import pytest

from lwrl.agent.nrbf import NRBF
from lwrl.agent.sarsa import BatchedSarsa

LINE = NRBF(low=(0.0,), high=(1.0,), n=2)
"""Two neurons on [0, 1], centroids 0.25 and 0.75: at s = 0.5 both features are 0.5."""


def make(trace="replacing", alpha=0.5, lam=0.5, epsilon=0.0, seeds=(0,), features=LINE, actions=2):
    return BatchedSarsa(features, actions, alpha=alpha, lam=lam, epsilon=epsilon, trace=trace,
                        seeds=list(seeds))


def feed(agent, first, reward, discount, observation):
    return int(agent.step([first], [reward], [discount], [[observation]])[0])


@pytest.mark.parametrize("trace", ["replacing", "accumulating"])
def test_two_updates_by_hand(trace):
    """Two neurons, two actions, alpha = 0.5, gamma = 1, lambda = 0.5, always at s = 0.5
    where phibar = (0.5, 0.5).

    Step 1: r = -1 into a non-terminal state; all Q are 0, so delta = -1 + 0 - 0 = -1 and
    e[a0] = (0.5, 0.5) for either trace; w[a0] = 0.5 * -1 * (0.5, 0.5) = (-0.25, -0.25).
    Now Q(s, a0) = -0.25 and the other action's Q is 0.
    Step 2: r = -1 into a terminal state: delta = -1 - Q(s, a1), where a1 was drawn at step 1
    from two tied actions (all Q were 0 then).
    - a1 = a0: delta = -1 + 0.25 = -0.75; e[a0] = 0.5 * 0.5 + 0.5 = 0.75 (accumulating) or
      max(0.25, 0.5) = 0.5 (replacing); w[a0] = -0.25 - 0.75 * 0.5 * e[a0].
    - a1 != a0: delta = -1; e[a0] = 0.25 (decayed), e[a1] = 0.5; w[a0] = -0.25 - 0.5 * 0.25
      = -0.375 and w[a1] = -0.5 * 0.5 = -0.25.
    """
    agent = make(trace)
    a0 = feed(agent, True, 0.0, 1.0, 0.5)
    a1 = feed(agent, False, -1.0, 1.0, 0.5)
    np.testing.assert_allclose(agent.weights[0, :, a0], [-0.25, -0.25], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(agent.weights[0, :, 1 - a0], [0.0, 0.0])
    assert feed(agent, False, -1.0, 0.0, 0.5) == 0  # terminal: no action is drawn
    w = agent.weights[0]
    if a1 == a0:
        e = 0.75 if trace == "accumulating" else 0.5
        np.testing.assert_allclose(w[:, a0], -0.25 - 0.75 * 0.5 * e, rtol=0, atol=1e-15)
        np.testing.assert_array_equal(w[:, 1 - a0], [0.0, 0.0])
    else:
        np.testing.assert_allclose(w[:, a0], -0.375, rtol=0, atol=1e-15)
        np.testing.assert_allclose(w[:, a1], -0.25, rtol=0, atol=1e-15)


def reference_weights(features, steps, actions, alpha, lam, trace, gamma=1.0, num_actions=3):
    """Eq. 1, 2 and 6 written out with whole arrays, replaying the agent's actions."""
    w = np.zeros((features.num_features, num_actions))
    e = np.zeros_like(w)
    history = []
    phi_prev = a_prev = None
    for (first, reward, discount, observation), action in zip(steps, actions):
        phi = features.features(np.array(observation))
        if first:
            e[:] = 0.0
        else:
            grad = np.zeros_like(w)
            grad[:, a_prev] = phi_prev
            target = reward + (gamma * discount * (phi @ w)[action] if discount > 0 else 0.0)
            delta = target - phi_prev @ w[:, a_prev]
            e = gamma * lam * e + grad if trace == "accumulating" else np.maximum(gamma * lam * e, grad)
            w = w + alpha * delta * e
        phi_prev, a_prev = phi, action
        history.append(w.copy())
    return history


@pytest.mark.parametrize("trace", ["replacing", "accumulating"])
@pytest.mark.parametrize("lam", [0.0, 0.9])
def test_matches_the_equations_written_out(trace, lam):
    """Over 300 random transitions (episode starts, terminal and non-terminal steps) on a
    3 x 3 NRBF with three actions and epsilon = 0.3, the weights follow eq. 1 with eq. 2 or 6
    as written with whole arrays, to 1e-12 at every step."""
    features = NRBF(low=(-1.0, -2.0), high=(1.0, 2.0), n=3)
    agent = make(trace, alpha=0.7, lam=lam, epsilon=0.3, features=features, actions=3)
    rng = np.random.default_rng(5)
    steps, actions, weights = [], [], []
    first = True
    for _ in range(300):
        discount = 0.0 if rng.random() < 0.1 else 1.0
        step = (first, rng.normal(), discount, rng.uniform(-1.5, 1.5, size=2))
        action = int(agent.step([step[0]], [step[1]], [step[2]], [step[3]])[0])
        steps.append(step)
        actions.append(action)
        weights.append(agent.weights[0].copy())
        first = discount == 0.0
    for expected, actual in zip(reference_weights(features, steps, actions, 0.7, lam, trace), weights):
        np.testing.assert_allclose(actual, expected, rtol=0, atol=1e-12)


def test_lambda_zero_is_one_step_sarsa():
    """With lambda = 0 an update changes only Q(s, a)'s column: by alpha delta phibar(s)."""
    features = NRBF(low=(0.0, 0.0), high=(1.0, 1.0), n=4)
    agent = make("accumulating", alpha=0.3, lam=0.0, epsilon=0.5, features=features, actions=3)
    rng = np.random.default_rng(1)
    action = int(agent.step([True], [0.0], [1.0], [[0.2, 0.3]])[0])
    observation = [0.2, 0.3]
    for _ in range(50):
        before = agent.weights[0].copy()
        phi = features.features(np.array(observation))
        q_before = phi @ before[:, action]
        next_observation = rng.uniform(0, 1, size=2)
        next_action = int(agent.step([False], [-1.0], [1.0], [next_observation])[0])
        delta = -1.0 + features.features(next_observation) @ before[:, next_action] - q_before
        expected = before.copy()
        expected[:, action] += 0.3 * delta * phi
        np.testing.assert_allclose(agent.weights[0], expected, rtol=0, atol=1e-13)
        observation, action = next_observation, next_action


def test_q_values_read_the_weights():
    features = NRBF(low=(0.0, 0.0), high=(1.0, 1.0), n=3)
    agent = make(features=features, seeds=(0, 1))
    agent.arrays.weights[:] = np.random.default_rng(0).normal(size=agent.arrays.weights.shape)
    states = np.random.default_rng(1).uniform(size=(5, 2))
    q = agent.action_values(states)
    assert q.shape == (2, 5, 2)
    np.testing.assert_allclose(q[1], features.features(states) @ agent.weights[1], rtol=1e-12)


@pytest.mark.parametrize("kwargs, message", [
    (dict(alpha=0.0), r"alpha must be in \(0.0, inf\]; got 0.0"),
    (dict(alpha=[0.5, -1.0]), r"alpha must be in \(0.0, inf\]; got -1.0"),
    (dict(lam=1.5), r"lambda must be in \[0.0, 1.0\]; got 1.5"),
    (dict(epsilon=-0.1), r"epsilon must be in \[0.0, 1.0\]; got -0.1"),
    (dict(trace="dutch"), "unknown trace 'dutch'; allowed: replacing, accumulating, replacing_reset"),
    (dict(seeds=(-1, 2)), "seeds must be a 1-D sequence of non-negative integers"),
])
def test_bad_hyper_parameters(kwargs, message):
    base = dict(alpha=0.5, lam=0.5, epsilon=0.0, trace="replacing", seeds=(0, 1))
    with pytest.raises(ValueError, match=message):
        BatchedSarsa(LINE, 2, **{**base, **kwargs})


def test_grid_below_two_is_refused():
    with pytest.raises(ValueError, match=r"n \(centroids per dimension\) must be an integer >= 2"):
        NRBF(low=(0.0,), high=(1.0,), n=1)


def test_bad_observation_shape():
    with pytest.raises(ValueError, match=r"observation must have shape \(1, 1\)"):
        make().step([True], [0.0], [1.0], [[0.1, 0.2]])
