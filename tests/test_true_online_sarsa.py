"""True online Sarsa(lambda) (van Seijen et al. 2016): a transition by hand, one-step Sarsa at
lambda = 0, and the online lambda-return forward view it is equivalent to."""

import numpy as np
import pytest

from lwrl.agent.nrbf import NRBF
from lwrl.agent.true_online_sarsa import TrueOnlineAgents
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents, run, run_compiled

LINE = NRBF(low=(0.0,), high=(1.0,), n=2)
"""Two neurons on [0, 1], centroids 0.25 and 0.75: at s = 0.5 both features are 0.5."""


def feed(agent, first, reward, discount, observation):
    return int(agent.step([first], [reward], [discount], [[observation]])[0])


def test_two_updates_by_hand():
    """alpha = 0.5, gamma = 1, lambda = 0.5, always at s = 0.5 where x = (0.5, 0.5) in the
    taken action's row.

    Step 1 (r = -1, not terminal): Q = 0, Q' = 0, delta = -1, z^T x = 0, so z[a0] = x and
    w[a0] = 0.5 (-1 + 0 - 0) x = (-0.25, -0.25); Q_old = Q' = 0.
    Step 2 (r = -1, terminal, Q' = 0), with a1 the action drawn at step 1 from a tie:
    - a1 = a0: Q = -0.25, delta = -0.75, z^T x = 0.5, z[a0] = 0.5 z + (1 - 0.5 * 0.5 * 0.5) x
      = 0.6875 each; w[a0] = -0.25 + 0.5 (-0.75 - 0.25) 0.6875 - 0.5 (-0.25) 0.5 = -0.53125.
    - a1 != a0: Q = 0, delta = -1, z[a0] = 0.25, z[a1] = x = 0.5; w[a0] = -0.25 - 0.5 * 0.25
      = -0.375, w[a1] = -0.5 * 0.5 = -0.25.
    """
    agent = TrueOnlineAgents(LINE, 2, alpha=0.5, lam=0.5, epsilon=0.0, seeds=[0])
    a0 = feed(agent, True, 0.0, 1.0, 0.5)
    a1 = feed(agent, False, -1.0, 1.0, 0.5)
    np.testing.assert_allclose(agent.weights[0, :, a0], [-0.25, -0.25], rtol=0, atol=1e-15)
    assert feed(agent, False, -1.0, 0.0, 0.5) == 0
    w = agent.weights[0]
    if a1 == a0:
        np.testing.assert_allclose(w[:, a0], -0.53125, rtol=0, atol=1e-15)
        np.testing.assert_array_equal(w[:, 1 - a0], [0.0, 0.0])
    else:
        np.testing.assert_allclose(w[:, a0], -0.375, rtol=0, atol=1e-15)
        np.testing.assert_allclose(w[:, a1], -0.25, rtol=0, atol=1e-15)


@pytest.mark.parametrize("trace", ["replacing", "accumulating"])
def test_at_lambda_zero_it_is_one_step_sarsa(trace):
    """With lambda = 0 the dutch trace is x itself and the update alpha delta x: one-step
    Sarsa, which either trace of `agent.sarsa` is at lambda = 0. Five Mountain-Car episodes:
    the same steps, and the weights equal to round-off."""
    config = RunConfig(task="mountain_car.cost_to_go", agents=3, episodes=5, lam=0.0, alpha=2.0)
    sarsa = make_agents(RunConfig(task="mountain_car.cost_to_go", agents=3, episodes=5, lam=0.0,
                                 alpha=2.0, trace=trace))
    dutch = make_agents(RunConfig(task="mountain_car.cost_to_go", agents=3, episodes=5,
                                 lam=0.0, alpha=2.0, learner="true_online_sarsa"))
    one = run_compiled("mountain_car", "cost_to_go", sarsa, 5, config.seeds)
    other = run_compiled("mountain_car", "cost_to_go", dutch, 5, config.seeds)
    np.testing.assert_array_equal(one.steps, other.steps)
    np.testing.assert_allclose(dutch.weights, sarsa.weights, rtol=1e-9, atol=1e-12)
    assert np.abs(sarsa.weights).max() > 1.0


def online_lambda_return(features, rewards, alpha, gamma, lam):
    """The weights `w_h^h`, h = 0..T, of the online lambda-return algorithm (van Seijen et
    al. 2016, section 3; Sutton and Barto 2018, eq. 12.9 and 12.10) over one episode of
    state-action feature vectors `features[t]` (t = 0..T-1, the terminal one 0) and
    `rewards[t]` = R_{t+1}, from zero weights, recomputed from the start at each horizon."""
    steps = len(rewards)
    x = list(features) + [np.zeros_like(features[0])]
    final = [np.zeros_like(features[0])]

    def n_step(t, n):  # G_{t:t+n}, bootstrapping with the weights of horizon t + n - 1
        g = sum(gamma ** (i - 1) * rewards[t + i - 1] for i in range(1, n + 1))
        return g + gamma ** n * final[t + n - 1] @ x[t + n]

    for h in range(1, steps + 1):
        w = np.zeros_like(features[0])
        for t in range(h):
            target = (1 - lam) * sum(lam ** (n - 1) * n_step(t, n) for n in range(1, h - t)) \
                + lam ** (h - t - 1) * n_step(t, h - t)
            w = w + alpha * (target - w @ x[t]) * x[t]
        final.append(w)
    return final


def test_its_weights_are_the_online_lambda_return_forward_view():
    """The equivalence that defines it (van Seijen et al. 2016, Theorem 1): on an episode of
    8 steps through random states of a 3 x 3 NRBF with 3 actions (epsilon 0.5, so the actions
    vary), the weights after every step equal the forward view's at that horizon, to
    round-off."""
    rng = np.random.default_rng(4)
    features = NRBF(low=(0.0, 0.0), high=(1.0, 1.0), n=3)
    states = rng.uniform(size=(9, 2))
    rewards = rng.normal(size=8)
    alpha, gamma, lam = 0.4, 0.9, 0.8
    agent = TrueOnlineAgents(features, 3, alpha=alpha, lam=lam, epsilon=0.5, gamma=gamma,
                             seeds=[2])
    actions, weights = [agent.step([True], [0.0], [1.0], states[:1])[0]], []
    for t in range(1, 9):
        terminal = t == 8
        actions.append(agent.step([False], [rewards[t - 1]], [0.0 if terminal else 1.0],
                                  states[t:t + 1])[0])
        weights.append(agent.arrays.weights[0].ravel().copy())
    phi = features.features(states[:8])
    x = [np.kron(np.eye(3)[a], phi[t]) for t, a in enumerate(actions[:8])]  # action-major
    forward = online_lambda_return(x, rewards, alpha, gamma, lam)
    assert len(set(actions[:8])) > 1
    for h in range(1, 9):
        np.testing.assert_allclose(weights[h - 1], forward[h], rtol=1e-12, atol=1e-12)
    assert np.abs(forward[8]).max() > 0.1


def test_it_learns_mountain_car():
    """The paper's Mountain-Car protocol (30 agents, 40 episodes) with the learner's default
    alpha: from several hundred steps in the first episodes to below 100 by the last ten."""
    _, results = run(RunConfig(task="mountain_car.cost_to_go", learner="true_online_sarsa"))
    assert np.nanmean(results.steps[:, :4]) > 250
    assert np.nanmean(results.steps[:, -10:]) < 100


def test_its_trace_is_dutch_and_sarsa_has_none_such():
    """`--trace` takes every learner's traces; a learner refuses another's in one line."""
    with pytest.raises(ValueError, match="^unknown trace 'dutch'; allowed: replacing, "
                                         "accumulating, replacing_reset$"):
        RunConfig(task="cartpole.balance", trace="dutch")
    with pytest.raises(ValueError, match="^unknown trace 'replacing'; allowed: dutch$"):
        RunConfig(task="cartpole.balance", learner="true_online_sarsa", trace="replacing")
