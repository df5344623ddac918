"""The equations of streaming deep reinforcement learning (Elsayed, Vasan & Mahmood 2024,
"Streaming deep reinforcement learning finally works", arXiv:2410.14606), as small pure JAX
functions, one equation each, apart from any learner's plumbing (`agent.stream_agents`):
what `agent.stream_q`, `agent.stream_ac` and `agent.stream_ac_discrete` compute per
transition.

Each follows the paper and the authors' PyTorch code, `mohmdelsayed/streaming-drl` at commit
407dca7 (`optim.py`, `sparse_init.py`, `normalization_wrappers.py`, `stream_q.py`,
`stream_ac_continuous.py`, `stream_ac_discrete.py`), whose file is named at each function.
Time-indexed names as in rlax: `z_tm1` the trace before the step, `z_t` after it.

The networks are float32 (the authors' `torch.float`); the running statistics, the TD error
and the step size float64 (their NumPy statistics and Python floats). What meets the
parameters is rounded to their own type, so that float64 parameters are computed in float64
throughout (the C learner's double build against these equations, `tests/test_stream_q_c.py`).
This module imports JAX:
only the learners' agents import it, once JAX is there (`agent.jax_population.jax_modules`).
"""

import math

import jax
import jax.numpy as jnp

from lwrl.agent.running_stats import STATS_EPS, stats_add, stats_variance

LAYER_NORM_EPS = 1e-5
"""`torch.nn.functional.layer_norm`'s epsilon."""
LEAKY_SLOPE = 0.01
"""`torch.nn.functional.leaky_relu`'s negative slope."""


def sparse_layer(key, fan_in: int, fan_out: int, sparsity: float):
    """`(W (fan_in, fan_out), b (fan_out,))` float32: the paper's sparse initialisation
    (its `SparseInit`; `sparse_init.py`): W uniform in
    [-1/sqrt(fan_in), 1/sqrt(fan_in)] (LeCun's scale as the authors' code draws it), then for
    each output unit ceil(sparsity fan_in) of its inputs, drawn without replacement, set to 0;
    b = 0 (the authors' `initialize_weights`)."""
    uniform_key, order_key = jax.random.split(key)
    bound = math.sqrt(1.0 / fan_in)
    w = jax.random.uniform(uniform_key, (fan_in, fan_out), jnp.float32, -bound, bound)
    zeros = math.ceil(sparsity * fan_in)
    rank = jnp.argsort(jnp.argsort(jax.random.uniform(order_key, (fan_in, fan_out)), axis=0), axis=0)
    return jnp.where(rank < zeros, 0.0, w).astype(jnp.float32), jnp.zeros(fan_out, jnp.float32)


def sparse_network(key, sizes, sparsity: float) -> list:
    """`[(W, b), ...]` of layer widths `sizes`, each layer `sparse_layer`."""
    keys = jax.random.split(key, len(sizes) - 1)
    return [sparse_layer(k, fan_in, fan_out, sparsity)
            for k, fan_in, fan_out in zip(keys, sizes[:-1], sizes[1:])]


def layer_norm(x):
    """Layer normalisation without learned parameters (Ba et al. 2016;
    `F.layer_norm(x, x.size())`): (x - mean) / sqrt(var + 1e-5) over the last axis, var
    biased."""
    mean = x.mean(axis=-1, keepdims=True)
    var = ((x - mean) ** 2).mean(axis=-1, keepdims=True)
    return (x - mean) / jnp.sqrt(var + LAYER_NORM_EPS)


def leaky_relu(x):
    """x where x > 0, else 0.01 x (`F.leaky_relu`), with torch's derivative at 0, the slope
    (JAX's `jax.nn.leaky_relu` takes 1 there): the sparse initialisation zeroes every input
    weight of a first layer of few inputs (ceil(0.9 d) = d for d <= 9), so its units start
    at exactly 0 and the derivative there is what the first updates follow."""
    return jnp.where(x > 0, x, LEAKY_SLOPE * x)


def forward(layers, x):
    """The authors' networks (`StreamQ.q`, `Actor.forward`, `Critic.forward`): each hidden
    layer linear, layer-normalised, then leaky ReLU; the last layer linear. `x` float32
    `(..., d)`."""
    for w, b in layers[:-1]:
        x = leaky_relu(layer_norm(x @ w + b))
    w, b = layers[-1]
    return x @ w + b


def accumulate_trace(z_tm1, grad, gamma, lam):
    """The eligibility trace over the parameters, z_t = gamma lambda z_tm1 + grad (the
    paper's ObGD, `ObGD.step`), gamma lambda rounded to the parameters' type (float32)."""
    decay = gamma * lam
    return jax.tree.map(lambda z, g: decay.astype(z.dtype) * z + g, z_tm1, grad)


def obgd_step_size(z_t, delta_t, learning_rate, kappa):
    """ObGD's bounded step size (the paper's ObGD, `ObGD.step`): with
    delta_bar = max(|delta|, 1) and M = alpha kappa delta_bar ||z||_1, the step is
    alpha / max(M, 1), so that the update never overshoots the TD target by the bound."""
    norm = sum(jnp.sum(jnp.abs(z)).astype(jnp.float64) for z in jax.tree.leaves(z_t))
    bound = learning_rate * kappa * jnp.maximum(jnp.abs(delta_t), 1.0) * norm
    return learning_rate / jnp.maximum(bound, 1.0)


def obgd_apply(params, z_t, delta_t, step_size):
    """The parameters moved along the trace, w_t = w_tm1 + step delta z_t (ObGD; the
    authors' `p -= step delta e` of the trace of the negated gradient), step delta rounded
    to the parameters' type (float32)."""
    scale = step_size * delta_t
    return jax.tree.map(lambda w, z: w + scale.astype(w.dtype) * z, params, z_t)


def obgd(params, z_tm1, grad, delta_t, learning_rate, gamma, lam, kappa):
    """One ObGD step: `(params_t, z_t)`."""
    z_t = accumulate_trace(z_tm1, grad, gamma, lam)
    step = obgd_step_size(z_t, delta_t, learning_rate, kappa)
    return obgd_apply(params, z_t, delta_t, step), z_t


def cleared(z, reset):
    """The trace zeroed where `reset` (an episode's end; stream-Q's exploratory action,
    Watkins' Q(lambda))."""
    return jax.tree.map(lambda leaf: jnp.where(reset, jnp.zeros_like(leaf), leaf), z)


def scaled_reward(reward, u_tm1, stats, gamma, ended):
    """A reward scaled by the running standard deviation of the discounted return
    (`ScaleReward`): u_t = gamma (1 - ended) u_tm1 + r, the statistics take u_t, and the
    reward becomes r / sqrt(var(u) + 1e-8); `ended` is the authors' `terminated or
    truncated` of this transition. Returns `(scaled reward, u_t, statistics)`."""
    u_t = u_tm1 * gamma * (1.0 - ended) + reward
    stats = stats_add(stats, u_t)
    return reward / jnp.sqrt(stats_variance(stats) + STATS_EPS), u_t, stats


def epsilon(step, start, end, duration):
    """Stream-Q's exploration rate at its `step`-th action (counted from 1): linear from
    `start` to `end` over `duration` steps, then `end` (`stream_q.py`'s `linear_schedule`)."""
    return jnp.maximum((end - start) / duration * step + start, end)


def q_td_error(q_tm1_a, r_t, discount_t, q_t):
    """Stream-Q(lambda)'s TD error (the paper's Stream Q(lambda)): delta = r + gamma (1 -
    terminal) max_a q(s', a) - q(s, a), `q_tm1_a` = q(s, a), `discount_t` = gamma (1 -
    terminal)."""
    return r_t + discount_t * jnp.max(q_t).astype(jnp.float64) - q_tm1_a.astype(jnp.float64)


def v_td_error(v_tm1, r_t, discount_t, v_t):
    """Stream-AC(lambda)'s TD error (the paper's Stream AC(lambda)): delta = r + gamma (1 -
    terminal) v(s') - v(s)."""
    return r_t + discount_t * v_t.astype(jnp.float64) - v_tm1.astype(jnp.float64)


def gaussian_log_prob(mean, std, action):
    """log N(a; mu, sigma) summed over the action's components (`Normal.log_prob`)."""
    return jnp.sum(-((action - mean) ** 2) / (2.0 * std ** 2) - jnp.log(std)
                   - math.log(math.sqrt(2.0 * math.pi)))


def gaussian_entropy(std):
    """H(N(mu, sigma)) = 1/2 + 1/2 log(2 pi) + log sigma, summed (`Normal.entropy`)."""
    return jnp.sum(0.5 + 0.5 * math.log(2.0 * math.pi) + jnp.log(std))


def categorical_log_prob(preferences, action):
    """log pi(a|s) of the softmax of the actor's `preferences` (`Categorical.log_prob`)."""
    return jax.nn.log_softmax(preferences)[action]


def categorical_entropy(preferences):
    """H(pi(.|s)) = -sum_a pi(a|s) log pi(a|s) of the softmax of `preferences`
    (`Categorical.entropy`)."""
    log_pi = jax.nn.log_softmax(preferences)
    return -jnp.sum(jnp.exp(log_pi) * log_pi)


def actor_objective(log_prob, entropy, entropy_coef, sign_delta):
    """What stream-AC(lambda)'s actor trace accumulates the gradient of (Stream AC(lambda);
    `StreamAC.update_params`, negated there): log pi(a|s) + c_e sign(delta) H(pi(.|s)), of a
    Gaussian (`gaussian_log_prob`, `gaussian_entropy`; `stream_ac_continuous.py`) or a
    softmax policy (`categorical_log_prob`, `categorical_entropy`; `stream_ac_discrete.py`)."""
    return log_prob + entropy_coef * sign_delta * entropy
