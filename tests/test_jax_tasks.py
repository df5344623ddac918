"""The suite's tasks in JAX (`lwrl.jax`) against the analytic plant: the same dynamics, start,
reward, termination, truncation and up-time, on every domain, at the paper's parameter values
and away from them; gymnax's API (pure `reset`/`step` that `jit` and `vmap`); bad input."""

import numpy as np
import pytest

jax = pytest.importorskip("jax", reason="the JAX tasks need the jax extra: pip install 'lwrl[jax]'")
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp  # noqa: E402

import lwrl.jax  # noqa: E402
from lwrl import tasks  # noqa: E402
from tests.conftest import off_nominal  # noqa: E402

TOLERANCE = 1e-12
"""Per step, relative to the state's size: XLA contracts a * b + c into one fused
multiply-add where numba rounds twice, so the last bit may differ."""
FLOAT32_TOLERANCE = 1e-5
"""Per step, relative to the state's size: a float32 step's distance from the float64 plant,
from the same (float64) state rounded to float32. Measured on seed 5's episodes: 3.1e-6 on
the acrobot (four Euler substeps a step), 2.1e-7 on the pendulum, 8.4e-8 on the cart-pole,
2.7e-8 on Mountain-Car."""


def numpy_episode(name, physical, seed, cap=None):
    """A random-action episode of the analytic plant (NumPy): the states `(T + 1, d)`, the
    actions `(T,)` and the outcomes of each step, until it ends (terminal or its time limit)."""
    domain, task = tasks.split_name(name)
    definition = tasks.definition(domain, task)
    plant = tasks.domain(domain).plants.batch("analytic", 1, physical=physical)
    rng = np.random.default_rng(seed)
    limit = definition.step_limit if cap is None else min(cap, definition.step_limit)
    states = [definition.initial_states(rng, 1)[0]]
    actions = []
    while len(actions) < limit:
        action = rng.integers(definition.num_actions)
        control = definition.controls_at(physical)[action]
        states.append(plant.step(states[-1][None], np.array([control]))[0])
        actions.append(action)
        if definition.outcomes(states[-1], physical)[1]:
            break
    states = np.array(states)
    reward, terminal, up = definition.outcomes(states[1:], np.broadcast_to(physical, (len(actions), len(physical))))
    return definition, states, np.array(actions), reward, terminal, up


def jax_steps(env, states, actions, params):
    """The JAX environment's `step_env` from each state of `states[:-1]` under `actions`, all
    at once (`vmap`)."""
    def one(physics, action, steps):
        state = lwrl.jax.EnvState(physics=physics, steps=steps,
                                  uptime=jnp.asarray(env.definition.initial_uptime, env.dtype),
                                  transit=jnp.zeros(0, env.dtype))
        return env.step_env(jax.random.PRNGKey(0), state, action, params)
    steps = jnp.arange(len(actions), dtype=jnp.int32)
    return jax.jit(jax.vmap(one))(jnp.asarray(states[:-1], env.dtype), jnp.asarray(actions), steps)


@pytest.mark.parametrize("name", tasks.TASK_NAMES)
@pytest.mark.parametrize("nominal", [True, False], ids=["nominal", "off-nominal"])
def test_every_step_of_an_episode_is_the_analytic_plants(name, nominal):
    env, params = lwrl.jax.make(name)
    physical = (np.asarray(params) if nominal else
                off_nominal(tasks.split_name(name)[0], np.random.default_rng(7)))
    definition, states, actions, reward, terminal, up = numpy_episode(name, physical, seed=3)
    observation, after, jax_reward, jax_terminal, truncated, info = jax_steps(
        env, states, actions, jnp.asarray(physical))
    scale = np.maximum(1.0, np.abs(states[1:]))
    assert np.all(np.abs(np.asarray(after.physics) - states[1:]) <= TOLERANCE * scale)
    assert np.all(np.abs(np.asarray(observation) - definition.observe(states[1:])) <= TOLERANCE * scale)
    np.testing.assert_allclose(np.asarray(jax_reward), reward, rtol=TOLERANCE, atol=TOLERANCE)
    np.testing.assert_array_equal(np.asarray(jax_terminal), terminal)
    np.testing.assert_array_equal(np.asarray(info["discount"]), np.where(terminal, 0.0, 1.0))
    uptime = np.asarray(after.uptime)
    if definition.has_uptime:
        np.testing.assert_array_equal(uptime, definition.control_timestep * up)
    else:
        assert np.all(np.isnan(uptime))
    ends = np.flatnonzero(np.asarray(truncated))
    assert list(ends) == ([len(actions) - 1] if len(actions) == definition.step_limit
                          and not terminal[-1] else [])


@pytest.mark.parametrize("name", tasks.TASK_NAMES)
def test_starts_follow_the_tasks_distribution(name):
    env, params = lwrl.jax.make(name)
    domain, task = tasks.split_name(name)
    definition = tasks.definition(domain, task)
    observation, state = jax.vmap(env.reset, in_axes=(0, None))(
        jax.random.split(jax.random.PRNGKey(1), 2000), params)
    starts = np.asarray(state.physics)
    reference = definition.initial_states(np.random.default_rng(1), 2000)
    for j in range(starts.shape[1]):  # the same box, filled alike
        assert starts[:, j].min() >= reference[:, j].min() - 0.01 * (np.ptp(reference[:, j]) + 1e-9)
        assert starts[:, j].max() <= reference[:, j].max() + 0.01 * (np.ptp(reference[:, j]) + 1e-9)
        assert abs(starts[:, j].mean() - reference[:, j].mean()) <= 0.05 * (np.ptp(reference[:, j]) + 1e-9)
    np.testing.assert_allclose(np.asarray(observation), definition.observe(starts), rtol=0, atol=1e-15)
    assert np.all(np.asarray(state.steps) == 0)


def test_an_episode_ends_in_a_new_start_with_the_last_observation_kept():
    env, params = lwrl.jax.make("cartpole.balance")
    observation, state = env.reset(jax.random.PRNGKey(0), params)
    step = jax.jit(env.step)
    for n in range(1, 500):  # pushing one way fails within a second or two
        observation, state, reward, terminated, truncated, info = step(
            jax.random.PRNGKey(n), state, 1, params)
        if terminated:
            break
    assert terminated and not truncated and reward == -1.0 and info["discount"] == 0.0
    assert abs(float(info["final_observation"][2])) > np.radians(12)  # the pole had fallen
    np.testing.assert_array_equal(np.asarray(observation), np.zeros(4))  # the paper's start
    assert int(state.steps) == 0 and int(info["steps"]) == n
    np.testing.assert_allclose(float(info["uptime"]), 0.02 * (n - 1))


def test_a_time_limit_is_a_truncation_not_a_terminal_state():
    env, params = lwrl.jax.make("pendulum.swingup", time_limit=0.1)
    _, state = env.reset(jax.random.PRNGKey(0), params)
    flags = []
    for n in range(5):
        _, state, _, terminated, truncated, info = env.step(jax.random.PRNGKey(n), state, 0, params)
        flags.append((bool(terminated), bool(truncated), float(info["discount"])))
    assert flags == [(False, False, 1.0)] * 4 + [(False, True, 1.0)]


def test_params_batch_over_vmap_as_one_program():
    env, params = lwrl.jax.make("cartpole.balance")
    rows = jnp.asarray(off_nominal("cartpole", np.random.default_rng(2), count=5))
    keys = jax.random.split(jax.random.PRNGKey(0), 5)
    _, states = jax.vmap(env.reset)(keys, rows)
    states = states._replace(physics=states.physics.at[:, 2].set(0.05))
    batched = jax.jit(jax.vmap(env.step_env, in_axes=(0, 0, None, 0)))(keys, states, 1, rows)
    for b in range(5):
        one = env.step_env(keys[b], jax.tree.map(lambda x: x[b], states), 1, rows[b])
        np.testing.assert_array_equal(np.asarray(batched[1].physics[b]), np.asarray(one[1].physics))
    assert len({float(x) for x in batched[1].physics[:, 3]}) == 5  # each its own physics


@pytest.mark.parametrize("name", tasks.TASK_NAMES)
def test_float32_steps_stay_within_float32_rounding(name):
    env, params = lwrl.jax.make(name, dtype="float32")
    _, states, actions, *_ = numpy_episode(name, np.asarray(params, np.float64), seed=5)
    _, after, *_ = jax_steps(env, states, actions, params)
    relative = np.abs(np.asarray(after.physics, np.float64) - states[1:]) / np.maximum(1.0, np.abs(states[1:]))
    assert after.physics.dtype == jnp.float32
    assert relative.max() <= FLOAT32_TOLERANCE


def test_action_delay_and_sensor_noise_act_as_the_options_say():
    env, params = lwrl.jax.make("cartpole.balance", action_delay=2,
                                observation_noise={"pole_angle": 0.01})
    observation, state = env.reset(jax.random.PRNGKey(0), params)
    assert observation[2] != 0.0 and np.all(np.asarray(observation)[[0, 1, 3]] == 0.0)
    velocities = []
    for n in range(3):
        _, state, *_ = env.step_env(jax.random.PRNGKey(n), state, 1, params)
        velocities.append(float(state.physics[1]))
    assert velocities[0] == 0.0 and velocities[1] == 0.0 and velocities[2] > 0.0  # +F arrives


@pytest.mark.parametrize("call, message", [
    (lambda: lwrl.jax.make("cartpole.swing"), "unknown task 'swing'"),
    (lambda: lwrl.jax.make("nothing.balance"), "unknown domain 'nothing'"),
    (lambda: lwrl.jax.make("cartpole.balance", track=1), "unknown option 'track'"),
    (lambda: lwrl.jax.make("cartpole.balance", dtype="int8"), "dtype must be float32 or float64"),
    (lambda: lwrl.jax.make("pendulum.swingup", integrator="rk4"), "unknown integrator 'rk4'"),
    (lambda: lwrl.jax.make("pendulum.swingup", params={"mass": -1}), "mass (m) must be"),
    (lambda: lwrl.jax.make("cartpole.balance")[0].reset(jax.random.PRNGKey(0), jnp.ones(3)),
     "params must hold 7 values"),
])
def test_bad_input_gets_one_line(call, message):
    with pytest.raises(ValueError) as error:
        call()
    assert message in str(error.value) and "\n" not in str(error.value)
