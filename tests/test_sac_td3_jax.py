"""The JAX population learners of continuous actions (`sac_jax`, `td3_jax`): their first
gradient steps against the equations computed independently in NumPy, by hand (float64
forward passes, backpropagation written out, Adam, Polyak), from the same initial weights,
replay buffer and random draws; what a batch of them must share; and a short learning run.
The learner contract's tests (`tests/test_learners.py`) hold them to the rest."""

import dataclasses
import math

import numpy as np
import pytest

pytest.importorskip("jax", reason="the population learners need the jax extra: pip install 'lwrl[jax]'")

from lwrl import agent as learners  # noqa: E402
from lwrl.agent import sac, td3  # noqa: E402
from lwrl.runners.config import RunConfig, task_spec  # noqa: E402
from lwrl.runners.run import make_agents, run  # noqa: E402

TINY = dict(task="cartpole.balance", actions="continuous", plant="analytic", agents=2,
            episodes=3, seed=11, task_options={"time_limit": 0.4})
"""Two agents on the cart-pole, 20-step episodes: random actions tip the pole over before
the time limit in some episodes and not in others, so the buffer holds terminal states and
truncations."""
STEPS, GRADIENT_STEPS, BATCH = 24, 2, 20
"""Steps of learning: one training call of two gradient steps on minibatches of 20, after
the 24th and last step (`learning_starts` 23): the minibatches draw the end of an
episode on a terminal state and one at the time limit."""
COMMON = dict(timesteps=STEPS, learning_starts=STEPS - 1, gradient_steps=GRADIENT_STEPS,
              batch_size=BATCH, buffer_size=64, net_arch="8", gamma=0.9)


# --- NumPy, by hand ---------------------------------------------------------------------------

def numpy_layers(layers, index=None):
    """JAX layers `[(W (in, out), b (out,))]` as float64 NumPy, of critic `index` where the
    layers hold a leading axis of critics."""
    pick = (lambda x: np.asarray(x, np.float64)) if index is None else (
        lambda x: np.asarray(x[index], np.float64))
    return [(pick(w), pick(b)) for w, b in layers]


def forward(layers, x):
    """A ReLU MLP's output and its pre-activations (for `backward`)."""
    inputs = [x]
    for w, b in layers[:-1]:
        x = np.maximum(x @ w + b, 0.0)
        inputs.append(x)
    w, b = layers[-1]
    return x @ w + b, inputs


def backward(layers, inputs, dy):
    """`(gradients [(dW, db)], d input)` of a ReLU MLP given dLoss/dOutput `dy` (n, out)."""
    grads = []
    for index in range(len(layers) - 1, -1, -1):
        w, _ = layers[index]
        x = inputs[index]
        grads.append((x.T @ dy, dy.sum(axis=0)))
        dy = dy @ w.T
        if index > 0:
            dy = dy * (x > 0)
    return grads[::-1], dy


def adam(params, grads, state, rate, eps=1e-8):
    """Adam (Kingma and Ba 2015, Algorithm 1) with PyTorch's placement of eps."""
    m, v, t = state
    t += 1
    m = [0.9 * m_ + 0.1 * g for m_, g in zip(m, grads)]
    v = [0.999 * v_ + 0.001 * g * g for v_, g in zip(v, grads)]
    new = [p - rate / (1 - 0.9 ** t) * m_ / (np.sqrt(v_) / math.sqrt(1 - 0.999 ** t) + eps)
           for p, m_, v_ in zip(params, m, v)]
    return new, (m, v, t)


def flat_layers(layers):
    return [a for pair in layers for a in pair]


def pairs(arrays):
    return list(zip(arrays[::2], arrays[1::2]))


def adam_layers(layers, grads, state, rate):
    new, state = adam(flat_layers(layers), flat_layers(grads), state, rate)
    return pairs(new), state


def fresh_adam(layers):
    zeros = [np.zeros_like(a) for a in flat_layers(layers)]
    return zeros, zeros, 0


def polyak(layers, target, tau):
    return [(tau * w + (1 - tau) * wt, tau * b + (1 - tau) * bt)
            for (w, b), (wt, bt) in zip(layers, target)]


def q_value(critic, s, a):
    """Q(s, a) `(n,)` and what `backward` needs."""
    x = np.concatenate([s, a[:, None]], axis=1)
    q, inputs = forward(critic, x)
    return q[:, 0], inputs


def dq_da(critic, inputs):
    """dQ(s, a)/da `(n,)`: the critic's gradient with respect to its last input."""
    return backward(critic, inputs, np.ones((len(inputs[0]), 1)))[1][:, -1]


def critic_update(critics, adam_state, s, a, y, scale, rate):
    """The critics after one Adam step on `scale` sum_k mean((Q_k(s, a) - y)^2)."""
    grads = []
    for critic in critics:
        q, inputs = q_value(critic, s, a)
        grads.append(backward(critic, inputs, (scale * 2 * (q - y) / len(y))[:, None])[0])
    joined = [(np.stack([c[i][0] for c in critics]), np.stack([c[i][1] for c in critics]))
              for i in range(len(critics[0]))]
    joined_grads = [(np.stack([g[i][0] for g in grads]), np.stack([g[i][1] for g in grads]))
                    for i in range(len(grads[0]))]
    new, adam_state = adam_layers(joined, joined_grads, adam_state, rate)
    return [[(w[k], b[k]) for w, b in new] for k in range(len(critics))], adam_state


def squashed_sample(actor, s, eps):
    """SAC's a = tanh(mu + sigma eps) and log pi(a|s) = -eps^2 / 2 - log sigma - log
    sqrt(2 pi) - log(1 - a^2 + 1e-6) (Haarnoja et al. 2018, eq. 21), with what the actor's
    gradient needs."""
    out, inputs = forward(actor, s)
    mean, raw = out[:, 0], out[:, 1]
    log_std = np.clip(raw, -20.0, 2.0)
    std = np.exp(log_std)
    a = np.tanh(mean + std * eps)
    log_prob = (-eps ** 2 / 2 - log_std - math.log(math.sqrt(2 * math.pi))
                - np.log(1 - a ** 2 + 1e-6))
    return a, log_prob, (inputs, std, (raw >= -20.0) & (raw <= 2.0))


def sac_numpy(params, alpha_state, buffer, draws, h):
    """SB3's `SAC.train` of `len(draws)` gradient steps (Haarnoja et al. 2018, eqs. 5, 7, 18)."""
    actor, critics, targets = params
    log_alpha, alpha_adam = alpha_state
    actor_adam, critic_adam = fresh_adam(actor), fresh_adam(
        [(np.stack([w, w]), np.stack([b, b])) for w, b in critics[0]])
    for index, (rows, eps, next_eps) in enumerate(draws):
        s, a, r, s2, d = (buffer[name][rows] for name in
                          ("observations", "actions", "rewards", "next_observations", "terminals"))
        n = len(r)
        a_pi, log_prob, (actor_inputs, std, unclipped) = squashed_sample(actor, s, eps)
        alpha = math.exp(log_alpha) if h["auto"] else h["ent_coef"]
        if h["auto"]:  # eq. 18 on log alpha: d/d log alpha of -mean(log alpha (log pi + H))
            (log_alpha,), alpha_adam = adam([log_alpha], [-np.mean(log_prob - 1.0)], alpha_adam,
                                            h["rate"])
        a2, log_prob2, _ = squashed_sample(actor, s2, next_eps)
        next_q = np.minimum(*(q_value(t, s2, a2)[0] for t in targets))
        y = r + (1 - d) * h["gamma"] * (next_q - alpha * log_prob2)  # eq. 5
        critics, critic_adam = critic_update(critics, critic_adam, s, a, y, 0.5, h["rate"])
        # eq. 7: mean(alpha log pi(a~|s) - min_k Q_k(s, a~)), a~ = tanh(mu + sigma eps)
        values = [q_value(c, s, a_pi) for c in critics]
        low = np.where(values[0][0] <= values[1][0], 0, 1)
        slope = np.where(low == 0, dq_da(critics[0], values[0][1]), dq_da(critics[1], values[1][1]))
        squash = 2 * a_pi / (1 - a_pi ** 2 + 1e-6)  # -d log(1 - a^2 + 1e-6) / da
        da_du = 1 - a_pi ** 2
        d_mean = (alpha * squash * da_du - slope * da_du) / n
        d_log_std = (alpha * (-1 + squash * da_du * std * eps) - slope * da_du * std * eps) / n
        dy = np.stack([d_mean, d_log_std * unclipped], axis=1)
        actor, actor_adam = adam_layers(actor, backward(actor, actor_inputs, dy)[0], actor_adam,
                                        h["rate"])
        if index % h["interval"] == 0:
            targets = [polyak(c, t, h["tau"]) for c, t in zip(critics, targets)]
    return actor, critics, targets, log_alpha


def td3_numpy(params, buffer, draws, h):
    """SB3's `TD3.train` of `len(draws)` gradient steps (Fujimoto et al. 2018, eqs. 10, 14,
    section 5.2), from its first."""
    actor, critics, targets, actor_target = params
    actor_adam, critic_adam = fresh_adam(actor), fresh_adam(
        [(np.stack([w, w]), np.stack([b, b])) for w, b in critics[0]])
    for updates, (rows, noise) in enumerate(draws, start=1):
        s, a, r, s2, d = (buffer[name][rows] for name in
                          ("observations", "actions", "rewards", "next_observations", "terminals"))
        smoothing = np.clip(h["target_policy_noise"] * noise, -h["clip"], h["clip"])  # eq. 14
        a2 = np.clip(np.tanh(forward(actor_target, s2)[0][:, 0]) + smoothing, -1, 1)
        y = r + (1 - d) * h["gamma"] * np.minimum(*(q_value(t, s2, a2)[0] for t in targets))  # eq. 10
        critics, critic_adam = critic_update(critics, critic_adam, s, a, y, 1.0, h["rate"])
        if updates % h["delay"] == 0:  # section 5.2
            out, inputs = forward(actor, s)
            mu = np.tanh(out[:, 0])
            slope = dq_da(critics[0], q_value(critics[0], s, mu)[1])
            dy = (-slope * (1 - mu ** 2) / len(r))[:, None]
            actor, actor_adam = adam_layers(actor, backward(actor, inputs, dy)[0], actor_adam,
                                            h["rate"])
            targets = [polyak(c, t, h["tau"]) for c, t in zip(critics, targets)]
            actor_target = polyak(actor, actor_target, h["tau"])
    return actor, critics, targets, actor_target


# --- The learners' runs -----------------------------------------------------------------------

def tiny_run(name, per_agent):
    """`(fresh agents, trained agents, results)` of `TINY` with `COMMON` and each agent's
    own settings `per_agent[b]`, joined into one batch as a sweep joins runs."""
    configs = [RunConfig(**{**TINY, "agents": 1, "seed": TINY["seed"] + b}, learner=name,
                         **COMMON, **settings) for b, settings in enumerate(per_agent)]
    seeds = [config.seed for config in configs]
    fresh = make_agents(*configs)
    trained, results = run(configs[0], agents=make_agents(*configs), seeds=seeds, batch=configs)
    return fresh, trained, results


def agent_state(agents, b):
    import jax
    return jax.tree.map(lambda x: np.asarray(x[b]), agents.state)


def buffer_of(state):
    return {name: np.asarray(values, np.float64) for name, values in state["buffer"].items()
            if name != "count"}


def draws(key, sac_draws: bool):
    """Each gradient step's minibatch rows and Gaussian draws, from the agent's key as its
    update splits it (`replay_update`, `ActorCriticAgents.program`, the learner's
    `gradient_step`)."""
    import jax
    import jax.numpy as jnp
    _, steps_key = jax.random.split(key)
    found = []
    for step_key in jax.random.split(steps_key, GRADIENT_STEPS):
        sample_key, own = jax.random.split(step_key)
        rows = np.asarray(jax.random.randint(sample_key, (BATCH,), 0, STEPS))
        keys = jax.random.split(own) if sac_draws else [own]
        found.append((rows, *(np.asarray(jax.random.normal(k, (BATCH,), jnp.float32), np.float64)
                              for k in keys)))
    return found


def check_buffer(state, results, b):
    """`(buffer, rows that end a truncated episode)`: the replay buffer holds the agent's 24
    steps of learning, their rewards, actions in [-1, 1] and terminal states where an
    episode ended on one, not at a time limit (SB3's `handle_timeout_termination`)."""
    buffer = buffer_of(state)
    assert int(state["buffer"]["count"]) == STEPS
    steps = results.steps[b].astype(int)
    ends = np.cumsum(steps) - 1
    kept = ends < STEPS
    truncated = results.truncated[b]
    np.testing.assert_array_equal(np.flatnonzero(buffer["terminals"][:STEPS]),
                                  ends[kept & ~truncated])
    assert np.all(np.abs(buffer["actions"][:STEPS]) <= 1.0)
    np.testing.assert_allclose(buffer["rewards"][:steps[0]].sum(), results.returns[b, 0], atol=1e-5)
    return buffer, ends[kept & truncated]


def sampled_ends(buffer, cut, found) -> set:
    """Which ends of episodes the minibatches of `found` drew: `terminal`, `truncated`."""
    rows = np.concatenate([rows for rows, *_ in found])
    return ({"terminal"} if buffer["terminals"][rows].any() else set()) | (
        {"truncated"} if np.isin(rows, cut).any() else set())


def assert_layers(jax_layers, numpy_layers_, index=None):
    for (w, b), (w_, b_) in zip(numpy_layers(jax_layers, index), numpy_layers_):
        np.testing.assert_allclose(w, w_, rtol=1e-4, atol=2e-6)
        np.testing.assert_allclose(b, b_, rtol=1e-4, atol=2e-6)


@pytest.mark.slow
def test_sacs_first_gradient_steps_are_the_equations():
    """Two agents in one batch, the temperature learned by one (from 0.5) and fixed for the
    other (0.2), other learning rates and tau: each agent's one training call of two
    gradient steps moves log alpha, the critics (toward the min of the two target critics
    less alpha log pi at s'), the actor and, at the call's first step only
    (`target_update_interval` 2), the target critics as the NumPy equations do."""
    per_agent = [dict(ent_coef=0.5, ent_coef_mode="auto", learning_rate=0.01, tau=0.1,
                      target_update_interval=2),
                 dict(ent_coef=0.2, ent_coef_mode="fixed", learning_rate=0.003, tau=0.3,
                      target_update_interval=2)]
    fresh, trained, results = tiny_run("sac_jax", per_agent)
    ends = set()
    for b, settings in enumerate(per_agent):
        start, end = agent_state(fresh, b), agent_state(trained, b)
        buffer, cut = check_buffer(end, results, b)
        found = draws(start["key"], True)
        ends |= sampled_ends(buffer, cut, found)
        critics = [numpy_layers(start["params"]["critics"], k) for k in range(2)]
        params = (numpy_layers(start["params"]["actor"]), critics, critics)
        alpha = (float(start["log_alpha"]), ([0.0], [0.0], 0))
        assert math.isclose(math.exp(alpha[0]), settings["ent_coef"] if b == 0 else 1.0, rel_tol=1e-6)
        h = dict(auto=settings["ent_coef_mode"] == "auto", ent_coef=settings["ent_coef"],
                 rate=settings["learning_rate"], tau=settings["tau"], gamma=COMMON["gamma"],
                 interval=settings["target_update_interval"])
        actor, critics, targets, log_alpha = sac_numpy(params, alpha, buffer, found, h)
        assert_layers(end["params"]["actor"], actor)
        for k in range(2):
            assert_layers(end["params"]["critics"], critics[k], k)
            assert_layers(end["critic_target"], targets[k], k)
        assert math.isclose(float(end["log_alpha"]), log_alpha, rel_tol=1e-5, abs_tol=1e-7)
        if not h["auto"]:
            assert float(end["log_alpha"]) == float(start["log_alpha"])
    assert ends == {"terminal", "truncated"}  # the targets checked: (1 - terminal) and not


@pytest.mark.slow
def test_td3s_first_gradient_steps_are_the_equations():
    """Two agents in one batch with their own smoothing noise, clip, learning rate and tau:
    the first gradient step moves the critics only (toward the min of the two target
    critics at the smoothed target action), the second (`policy_delay` 2) the critics, then
    the actor along Q_1 and both targets by Polyak, as the NumPy equations do."""
    per_agent = [dict(target_policy_noise=0.2, target_noise_clip=0.3, learning_rate=0.01,
                      tau=0.1, policy_delay=2, noise_std=0.1),
                 dict(target_policy_noise=0.5, target_noise_clip=0.4, learning_rate=0.003,
                      tau=0.3, policy_delay=2, noise_std=0.3)]
    fresh, trained, results = tiny_run("td3_jax", per_agent)
    ends = set()
    for b, settings in enumerate(per_agent):
        start, end = agent_state(fresh, b), agent_state(trained, b)
        buffer, cut = check_buffer(end, results, b)
        found = draws(start["key"], False)
        ends |= sampled_ends(buffer, cut, found)
        assert any(np.abs(settings["target_policy_noise"] * noise).max() > settings["target_noise_clip"]
                   for _, noise in found)  # the clip acts
        critics = [numpy_layers(start["params"]["critics"], k) for k in range(2)]
        actor = numpy_layers(start["params"]["actor"])
        h = dict(target_policy_noise=settings["target_policy_noise"],
                 clip=settings["target_noise_clip"], rate=settings["learning_rate"],
                 tau=settings["tau"], gamma=COMMON["gamma"], delay=settings["policy_delay"])
        actor, critics, targets, actor_target = td3_numpy((actor, critics, critics, actor),
                                                          buffer, found, h)
        assert int(end["updates"]) == GRADIENT_STEPS
        assert_layers(end["params"]["actor"], actor)
        assert_layers(end["actor_target"], actor_target)
        for k in range(2):
            assert_layers(end["params"]["critics"], critics[k], k)
            assert_layers(end["critic_target"], targets[k], k)
    assert ends == {"terminal", "truncated"}


@pytest.mark.parametrize("name", ["sac_jax", "td3_jax"])
def test_a_batch_shares_what_shapes_its_program(name):
    """SB3's `batch_size` and gradient steps are settings per agent, but one compiled program
    has one minibatch shape and one count of gradient steps: a batch that mixes them is
    refused in one line as the batch is made, as the settings that shape it are."""
    learner = learners.learner(name)
    task = task_spec("pendulum.swingup", actions="continuous")
    first = learner.settings(net_arch="8", buffer_size=16)
    for change, message in ((dict(batch_size=32), "must share batch_size"),
                            (dict(gradient_steps=2), "as many gradient steps"),
                            (dict(buffer_size=32), "must share buffer_size")):
        with pytest.raises(ValueError) as error:
            learner.make([first, dataclasses.replace(first, **change)], task, [0, 1])
        assert message in str(error.value) and "\n" not in str(error.value)


def test_they_take_sac_and_td3s_settings_and_counts():
    """`sac`'s and `td3`'s settings (their flags, defaults and checks) and the observation
    normalisation alone beside them; their counted arithmetic where it is off; continuous
    actions, the population path."""
    task = task_spec("pendulum.swingup", actions="continuous")
    for name, twin in (("sac_jax", sac), ("td3_jax", td3)):
        learner = learners.learner(name)
        own = {field.name for field in dataclasses.fields(learner.settings)}
        assert issubclass(learner.settings, twin.LEARNER.settings)
        assert own - {field.name for field in dataclasses.fields(twin.LEARNER.settings)} == {
            "normalize_observations"}
        assert learner.arithmetic(learner.settings(), task) == twin.arithmetic(
            twin.LEARNER.settings(), task)
        assert learner.actions == "continuous" and learner.population


@pytest.mark.slow
def test_sac_jax_learns_to_balance_the_cart_pole():
    """Two agents (seeds 0 and 1), 3000 steps of learning with small networks (64 x 64,
    minibatches of 64 from step 200), then greedy, on the cart-pole pushed with a continuous
    force (10-s episodes): its first ten episodes (the uniform warm-up, then an untrained
    policy) last 26 steps on average, its last ten (greedy) 200 (bounds with a margin of
    two and more)."""
    config = RunConfig(task="cartpole.balance", learner="sac_jax", agents=2, episodes=60, seed=0,
                       plant="analytic", actions="continuous", task_options={"time_limit": 10.0},
                       net_arch="64,64", batch_size=64, learning_starts=200, buffer_size=10_000,
                       timesteps=3000, gamma=0.98)
    _, results = run(config)
    first, last = results.steps[:, :10].mean(), results.steps[:, -10:].mean()
    assert np.isfinite(results.steps).all() and not results.diverged_episode.max() >= 0
    assert first < 50 and last > 100 and last > 4 * first, (first, last)
