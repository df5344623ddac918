"""The streaming learners (`stream_q`, `stream_ac`, `stream_ac_discrete`): their equations
(`agent.streaming`) held to hand-computed cases, their first updates to the authors' step
restated in PyTorch on the same inputs, and learning on the cart-pole."""

import math

import numpy as np
import pytest

pytest.importorskip("jax", reason="the streaming learners need the jax extra: pip install 'lwrl[jax]'")

from lwrl import agent as learners  # noqa: E402
from lwrl.agent import running_stats, streaming  # noqa: E402
from lwrl.agent.stable_baselines import missing_libraries  # noqa: E402
from lwrl.runners.config import RunConfig, task_spec  # noqa: E402
from lwrl.runners.run import make_agents, run  # noqa: E402
from lwrl.agent.jax_population import jax_modules  # noqa: E402
from conftest import one_line_error  # noqa: E402

jax, jnp = jax_modules()  # in 64 bits, as the learners run

needs_torch = pytest.mark.skipif("torch" in missing_libraries(), reason="needs the baselines "
                                 "extra (PyTorch): pip install 'lwrl[baselines]'")


def test_obgd_bounds_the_step_by_hand():
    """z = gamma lambda z + g = 0.25 [0.5, 0] + [1, -1] = [1.125, -1], ||z||_1 = 2.125;
    delta 2, alpha 1, kappa 2: M = 1 * 2 * 2 * 2.125 = 8.5 > 1, step 1 / 8.5."""
    params, trace = {"w": jnp.array([1.0, 2.0], jnp.float32)}, {"w": jnp.array([0.5, 0.0], jnp.float32)}
    grad = {"w": jnp.array([1.0, -1.0], jnp.float32)}
    new, z = streaming.obgd(params, trace, grad, jnp.float64(2.0), 1.0, jnp.float64(0.5),
                            jnp.float64(0.5), 2.0)
    np.testing.assert_allclose(z["w"], [1.125, -1.0])
    np.testing.assert_allclose(new["w"], [1.0 + 2.0 / 8.5 * 1.125, 2.0 - 2.0 / 8.5], rtol=1e-6)


def test_obgd_takes_the_full_step_below_its_bound():
    """alpha 0.1, kappa 2, |delta| 0.5 < 1 (delta_bar 1), ||z||_1 2.125: M = 0.425 < 1, so
    the step is alpha."""
    assert float(streaming.obgd_step_size({"w": jnp.array([1.125, -1.0])}, -0.5, 0.1, 2.0)) \
        == pytest.approx(0.1)
    assert float(streaming.obgd_step_size({"w": jnp.array([1.125, -1.0])}, -3.0, 1.0, 2.0)) \
        == pytest.approx(1.0 / (2.0 * 3.0 * 2.125))


def test_running_statistics_are_the_sample_mean_and_variance():
    samples = np.random.default_rng(1).normal(3.0, 2.0, size=(50, 3))
    stats = running_stats.stats_start(3)
    stats = running_stats.stats_add(stats, samples[0])
    assert np.all(np.asarray(running_stats.stats_variance(stats)) == 1.0)  # one sample: 1
    np.testing.assert_array_equal(running_stats.normalised(samples[0], stats), 0.0)
    for sample in samples[1:]:
        stats = running_stats.stats_add(stats, sample)
    np.testing.assert_allclose(stats["mean"], samples.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(running_stats.stats_variance(stats), samples.var(axis=0, ddof=1),
                               rtol=1e-12)


def test_rewards_are_scaled_by_the_discounted_return_s_spread():
    """u = 0.5 (1 - ended) u + r over rewards 1, 2 (ending an episode), 4: u = 1, 2, 5 (the
    end of the transition itself clears what came before, as the authors' `ScaleReward`
    computes it); var(1, 2) = 0.5, var(1, 2, 5) = 13/3."""
    stats, u = running_stats.stats_start(), jnp.zeros(())
    first, u, stats = streaming.scaled_reward(1.0, u, stats, 0.5, 0.0)
    assert float(first) == pytest.approx(1.0 / math.sqrt(1.0 + 1e-8))
    second, u, stats = streaming.scaled_reward(2.0, u, stats, 0.5, 1.0)
    assert float(u) == 2.0 and float(second) == pytest.approx(2.0 / math.sqrt(0.5 + 1e-8))
    third, u, stats = streaming.scaled_reward(4.0, u, stats, 0.5, 0.0)
    assert float(u) == 5.0 and float(third) == pytest.approx(4.0 / math.sqrt(13 / 3 + 1e-8))


def test_sparse_initialisation_zeros_each_unit_s_share_of_inputs():
    w, b = streaming.sparse_layer(jax.random.PRNGKey(0), 40, 7, 0.9)
    assert w.shape == (40, 7) and not np.any(np.asarray(b))
    np.testing.assert_array_equal((np.asarray(w) == 0).sum(axis=0), math.ceil(0.9 * 40))
    assert np.abs(np.asarray(w)).max() <= 1 / math.sqrt(40)


def test_the_exploration_rate_falls_linearly_then_stays():
    assert float(streaming.epsilon(0, 1.0, 0.01, 100)) == 1.0
    assert float(streaming.epsilon(50, 1.0, 0.01, 100)) == pytest.approx(0.505)
    assert float(streaming.epsilon(500, 1.0, 0.01, 100)) == pytest.approx(0.01)


def test_layer_norm_is_torch_s_without_parameters():
    x = jnp.array([[1.0, 2.0, 4.0], [0.0, -1.0, 3.0]], jnp.float32)
    expected = (np.asarray(x) - np.asarray(x).mean(1, keepdims=True)) / np.sqrt(
        np.asarray(x).var(1, keepdims=True) + 1e-5)
    np.testing.assert_allclose(streaming.layer_norm(x), expected, rtol=1e-6)


def transition(agents, x, action, reward, next_x, terminated=False, ended=False, fresh=False):
    extras = {**agents.blank_extras(), "action": jnp.asarray(action, agents.blank_extras()["action"].dtype)}
    return {"x": jnp.asarray(x, jnp.float32), "next_x": jnp.asarray(next_x, jnp.float32),
            "reward": jnp.float64(reward), "terminated": jnp.asarray(terminated),
            "ended": jnp.asarray(ended), "fresh": jnp.asarray(fresh), "extras": extras}


def hyper_of(agents):
    return {name: jnp.asarray(values[0]) for name, values in agents.program().hyper.items()}


def torch_network(torch, layers):
    """The authors' network (`StreamQ.q`, `Actor`, `Critic`) of `nn.Linear` layers holding
    the JAX `layers`' weights."""
    linears = []
    for w, b in layers:
        linear = torch.nn.Linear(w.shape[0], w.shape[1])
        with torch.no_grad():
            linear.weight.copy_(torch.from_numpy(np.asarray(w).T.copy()))
            linear.bias.copy_(torch.from_numpy(np.asarray(b).copy()))
        linears.append(linear)

    def forward(x):
        for linear in linears[:-1]:
            x = linear(x)
            x = torch.nn.functional.leaky_relu(torch.nn.functional.layer_norm(x, x.size()))
        return linears[-1](x)
    return linears, forward


def torch_obgd(torch, linears, traces, delta, lr, gamma, lam, kappa):
    """The authors' `ObGD.step` (optim.py) restated: e = gamma lambda e + grad (of the
    negated objective), the bounded step, p -= step delta e."""
    params = [p for linear in linears for p in (linear.weight, linear.bias)]
    z_sum = 0.0
    for index, p in enumerate(params):
        traces[index] = traces[index] * (gamma * lam) + p.grad
        z_sum += traces[index].abs().sum().item()
    dot = max(abs(delta), 1.0) * z_sum * lr * kappa
    step = lr / dot if dot > 1 else lr
    with torch.no_grad():
        for p, e in zip(params, traces):
            p.add_(delta * e, alpha=-step)


def assert_layers_match(layers, linears):
    for (w, b), linear in zip(layers, linears):
        np.testing.assert_allclose(np.asarray(w).T, linear.weight.detach().numpy(), rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(np.asarray(b), linear.bias.detach().numpy(), rtol=1e-5, atol=1e-6)


@needs_torch
def test_stream_q_s_first_updates_are_the_authors():
    """Two updates of stream_q (the second with the first's trace) against the authors'
    `StreamQ.update_params` restated in PyTorch on the same weights and inputs."""
    import torch
    config = RunConfig(task="cartpole.balance", learner="stream_q", agents=1, seed=3)
    agents = make_agents(config)
    hyper, params = hyper_of(agents), agents.state["params"]
    params = [(w[0], b[0]) for w, b in params]
    traces = [(jnp.zeros_like(w), jnp.zeros_like(b)) for w, b in params]
    rng = np.random.default_rng(0)
    steps = [(rng.normal(size=4), 1, -0.7, rng.normal(size=4)),
             (rng.normal(size=4), 0, 2.5, rng.normal(size=4))]
    linears, forward = torch_network(torch, params)
    torch_traces = [torch.zeros_like(p) for linear in linears for p in (linear.weight, linear.bias)]
    learn = jax.jit(agents.learn)  # as the run's program calls it: one compilation
    for x, action, reward, next_x in steps:
        params, traces = learn(params, traces, transition(agents, x, action, reward, next_x), hyper)
        s, s_next = torch.tensor(x, dtype=torch.float), torch.tensor(next_x, dtype=torch.float)
        q_sa = forward(s)[action]
        target = torch.tensor(reward) + 0.99 * torch.max(forward(s_next), dim=-1).values
        for linear in linears:
            linear.zero_grad()
        (-q_sa).backward()
        torch_obgd(torch, linears, torch_traces, (target - q_sa).item(), 1.0, 0.99, 0.8, 2.0)
        assert_layers_match(params, linears)


def gaussian(torch, out, action):
    """The authors' continuous policy at the actor's outputs `out` (`stream_ac_continuous.py`),
    and `action` (a number) as it takes it."""
    policy = torch.distributions.Normal(out[0], torch.nn.functional.softplus(out[1]))
    return policy, torch.tensor(action, dtype=torch.float)


def softmax(torch, out, action):
    """The authors' discrete policy (`stream_ac_discrete.py`, `Categorical(probs)`), and
    `action` (an index) as it takes it."""
    return torch.distributions.Categorical(torch.softmax(out, dim=-1)), torch.tensor(action)


@needs_torch
@pytest.mark.parametrize("learner, actions, policy, draw", [
    ("stream_ac", "continuous", gaussian, lambda rng, task: rng.normal()),
    ("stream_ac_discrete", "discrete", softmax,
     lambda rng, task: int(rng.integers(task.action.n)))])
def test_stream_ac_s_first_updates_are_the_authors(learner, actions, policy, draw):
    """Two updates of stream-AC(lambda) against the authors' `StreamAC.update_params`
    restated in PyTorch, with their Gaussian or softmax policy: the critic's and the
    actor's ObGD (kappa 2 and 3), the entropy term."""
    import torch
    config = RunConfig(task="pendulum.swingup", learner=learner, agents=1, seed=3,
                       actions=actions, net_arch="16,16")
    agents = make_agents(config)
    hyper = hyper_of(agents)
    unbatched = {name: [(w[0], b[0]) for w, b in network]
                 for name, network in agents.state["params"].items()}
    params, traces = unbatched, {name: [(jnp.zeros_like(w), jnp.zeros_like(b)) for w, b in network]
                                 for name, network in unbatched.items()}
    actor_linears, actor = torch_network(torch, unbatched["actor"])
    critic_linears, critic = torch_network(torch, unbatched["critic"])
    actor_traces = [torch.zeros_like(p) for linear in actor_linears for p in (linear.weight, linear.bias)]
    critic_traces = [torch.zeros_like(p) for linear in critic_linears for p in (linear.weight, linear.bias)]
    rng, learn = np.random.default_rng(2), jax.jit(agents.learn)
    for _ in range(2):
        x, u, reward, next_x = rng.normal(size=2), draw(rng, agents.task), rng.normal(), rng.normal(size=2)
        params, traces = learn(params, traces, transition(agents, x, u, reward, next_x), hyper)
        s, s_next = torch.tensor(x, dtype=torch.float), torch.tensor(next_x, dtype=torch.float)
        v_s = critic(s)
        delta = (torch.tensor(reward) + 0.99 * critic(s_next) - v_s).item()
        dist, action = policy(torch, actor(s), u)
        objective = -dist.log_prob(action).sum() - 0.01 * dist.entropy().sum() * np.sign(delta)
        for linear in actor_linears + critic_linears:
            linear.zero_grad()
        (-v_s).sum().backward()
        objective.backward()
        torch_obgd(torch, actor_linears, actor_traces, delta, 1.0, 0.99, 0.8, 3.0)
        torch_obgd(torch, critic_linears, critic_traces, delta, 1.0, 0.99, 0.8, 2.0)
        assert_layers_match(params["actor"], actor_linears)
        assert_layers_match(params["critic"], critic_linears)


@pytest.fixture(scope="module")
def balancing():
    """`(agents, results)` of four stream_q agents on the cart-pole, 90 episodes of at most
    1000 steps, the exploration over 2000 steps, learning at every step (100 000 steps of
    learning: more than 90 episodes can take); run once for the module."""
    return run(RunConfig(task="cartpole.balance", learner="stream_q", agents=4, episodes=90,
                         seed=0, task_options={"time_limit": 20.0}, timesteps=100_000,
                         exploration_fraction=0.02))


def test_stream_q_learns_to_balance_the_cart_pole(balancing):
    """`balancing`: the last ten episodes last at least three times as long as the first ten
    (about 20 steps)."""
    _, results = balancing
    first, last = results.steps[:, :10].mean(), results.steps[:, -10:].mean()
    assert first < 40 and last > 3 * first, (first, last)


def test_every_observation_enters_the_statistics_once(balancing):
    """Over `balancing` (its episodes ended by falls and by the time limit), the observation
    statistics take each episode's start and each step's next observation once (an
    observation that continues an episode is not taken again when the learner acts on it),
    and the reward statistics each step's discounted return."""
    agents, results = balancing
    assert results.truncated.any() and not results.truncated.all()
    steps = results.steps.sum(axis=1)
    np.testing.assert_array_equal(agents.state["observations"]["count"], steps + 90)
    np.testing.assert_array_equal(agents.state["rewards"]["count"], steps)


@pytest.mark.parametrize("setting, value, message", [
    ("learning_rate", -1.0, "learning_rate must be a finite number > 0"),
    ("sparsity", 1.0, "sparsity must be a number in [0, 1)"),
    ("lam", 1.5, "lam must be a number in [0, 1]"),
    ("kappa", 0.0, "kappa must be a finite number > 0"),
])
def test_bad_settings_are_refused_in_one_line(setting, value, message):
    one_line_error(lambda: RunConfig(task="cartpole.balance", learner="stream_q", **{setting: value}),
                   message)


def test_the_continuous_learner_refuses_a_discrete_task_in_one_line():
    assert "--action-kind continuous" in learners.learner("stream_ac").fits(task_spec("pendulum.swingup"))
