"""The suite's tasks in JAX (`lwrl.jax`) against the analytic plant: the same dynamics, start,
reward, termination, truncation and up-time, on every domain, at the paper's parameter values
and away from them; continuous actions against the NumPy environment's; gymnax's API (pure
`reset`/`step` that `jit` and `vmap`); bad input."""

import functools

import numpy as np
import pytest

jax = pytest.importorskip("jax", reason="the JAX tasks need the jax extra: pip install 'lwrl[jax]'")
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp  # noqa: E402

import lwrl.jax  # noqa: E402
from lwrl import tasks  # noqa: E402
from lwrl.tasks.batched import BatchedEnv, BatchedTimeStep  # noqa: E402
from lwrl.tasks.task_definition import ACTIONS  # noqa: E402
from tests.conftest import off_nominal  # noqa: E402

TOLERANCE = 1e-12
"""Per step, relative to the state's size: XLA contracts a * b + c into one fused
multiply-add where numba rounds twice, so the last bit may differ."""
FLOAT32_TOLERANCE = 1e-5
"""Per step, relative to the state's size: a float32 step's distance from the float64 plant,
from the same (float64) state rounded to float32. Measured on seed 5's episodes: 3.1e-6 on
the acrobot (four Euler substeps a step), 2.1e-7 on the pendulum, 8.4e-8 on the cart-pole,
2.7e-8 on Mountain-Car."""
CONTINUOUS_STEPS = 300
"""The time limit, in control steps, of the continuous episodes: whole episodes, kept short
because the NumPy environment steps them one Python call at a time."""


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


def jax_steps(env, states, actions, params, steps=None, uptime=None, sensors=None):
    """The JAX environment's `step_env` from each state of `states[:-1]` under `actions`, in
    order, each with its episode's step count and up-time before it (`steps`, `uptime`; by
    default the step's index and no up-time) and the sensors `sensors` (default: `make`'s)."""
    count = len(actions)
    steps = np.arange(count) if steps is None else steps
    uptime = np.full(count, env.definition.initial_uptime) if uptime is None else uptime
    return scanned_steps(env, jnp.asarray(states[:-1], env.dtype), jnp.asarray(steps, jnp.int32),
                         jnp.asarray(uptime, env.dtype), jnp.asarray(actions), params,
                         env.default_sensors if sensors is None else sensors)


@functools.partial(jax.jit, static_argnums=0)
def scanned_steps(env, physics, steps, uptime, actions, params, sensors):
    """`jax_steps` compiled, once per environment and shape: every step starts from the
    reference's plant state, step count and up-time (so a chaotic plant cannot drift apart
    from it), and from the transit buffer the step before left (so a delay acts as in an
    episode)."""
    def one(transit, row):
        physics, steps, uptime, action = row
        state = lwrl.jax.EnvState(physics=physics, steps=steps, uptime=uptime, transit=transit)
        stepped = env.step_env(jax.random.PRNGKey(0), state, action, params, sensors)
        return stepped[1].transit, stepped
    transit = jnp.zeros(sensors.max_delay, env.dtype)
    return jax.lax.scan(one, transit, (physics, steps, uptime, actions))[1]


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


def continuous_options(name):
    """The options of `DOMAIN.TASK`'s continuous episodes, for both environments: continuous
    actions and a time limit of `CONTINUOUS_STEPS` control steps."""
    definition = tasks.definition(*tasks.split_name(name))
    return {"actions": "continuous", "time_limit": CONTINUOUS_STEPS * definition.control_timestep}


def environment_episode(name, physical, seed, action_delay):
    """A whole episode of the NumPy environment with continuous actions (`BatchedEnv`, the
    analytic plant, `CONTINUOUS_STEPS` at most) at the parameter values `physical`, under
    random controls uniform over twice the actuator's range about its centre (about half of
    them outside it): the plant states `(T + 1, d)`, step counts and up-times before and
    after each step, the actions `(T,)` and the steps' time steps (a `BatchedTimeStep` of
    T rows)."""
    domain, task = tasks.split_name(name)
    env = BatchedEnv(domain, task, "analytic", seeds=[seed],
                     params=dict(zip(tasks.domain(domain).parameters.names, physical)),
                     action_delay=action_delay, **continuous_options(name))
    (low, high), rng = env.control_range[0], np.random.default_rng(seed)
    time_step, actions, time_steps = env.reset(), [], []
    episode = [(env.state[0].copy(), env.steps[0], env.uptime[0])]
    while not time_step.last()[0]:
        actions.append(rng.uniform(1.5 * low - 0.5 * high, 1.5 * high - 0.5 * low))
        time_step = env.step(np.array([actions[-1]]))
        time_steps.append(time_step)
        episode.append((env.state[0].copy(), env.steps[0], env.uptime[0]))
    states, steps, uptime = map(np.array, zip(*episode))
    return states, steps, uptime, np.array(actions), BatchedTimeStep(
        *(np.concatenate(field) for field in zip(*time_steps)))


def padded(array, length):
    """`array` with its last row repeated up to `length` rows: every episode of a task one
    shape, so one compiled program steps them all."""
    return np.pad(array, [(0, length - len(array))] + [(0, 0)] * (array.ndim - 1), mode="edge")


@pytest.mark.parametrize("name", tasks.TASK_NAMES)
def test_continuous_episodes_are_the_numpy_environments(name):
    """Every step of whole episodes of random continuous actions, about half of them outside
    the actuator's range, is the NumPy environment's (`actions="continuous"`): the action
    clipped to the range at the step's `params` (the paper's values, and values away from
    them that move it, but Mountain-Car's fixed thrust), then delayed; without a delay and
    with one of two steps (deterministic; both in one program, whose transit buffer holds
    two commands), without noise (JAX's streams are not the numba loops')."""
    domain = tasks.split_name(name)[0]
    env, params = lwrl.jax.make(name, **continuous_options(name))
    sensors = env.sensors(2, action_delay=[0, 2])
    for physical in (np.asarray(params), off_nominal(domain, np.random.default_rng(7))):
        for row, delay in enumerate((0, 2)):
            states, steps, uptime, actions, expected = environment_episode(
                name, physical, seed=3, action_delay=delay)
            count = len(actions)
            observation, after, reward, terminated, truncated, info = jax.tree.map(
                lambda field: np.asarray(field)[:count], jax_steps(
                    env, padded(states, CONTINUOUS_STEPS + 1), padded(actions, CONTINUOUS_STEPS),
                    jnp.asarray(physical), padded(steps[:-1], CONTINUOUS_STEPS),
                    padded(uptime[:-1], CONTINUOUS_STEPS),
                    jax.tree.map(lambda option: option[row], sensors)))
            scale = np.maximum(1.0, np.abs(states[1:]))
            assert np.all(np.abs(after.physics - states[1:]) <= TOLERANCE * scale)
            assert np.all(np.abs(observation - expected.observation) <= TOLERANCE * scale)
            np.testing.assert_allclose(reward, expected.reward, rtol=TOLERANCE, atol=TOLERANCE)
            np.testing.assert_array_equal(info["discount"], expected.discount)
            np.testing.assert_array_equal(terminated, expected.discount == 0.0)
            np.testing.assert_array_equal(truncated, expected.last() & (expected.discount == 1.0))
            np.testing.assert_array_equal(after.steps, steps[1:])
            np.testing.assert_allclose(after.uptime, uptime[1:], rtol=TOLERANCE)


def test_the_action_range_is_the_tasks_at_each_params():
    """`action_range(params)`, traced and batched over rows of `params`, is the task's
    `control_range_at` for either kind of action: it moves with the torque or the force
    (Mountain-Car's thrust is fixed at [-1, 1])."""
    for name in tasks.TASK_NAMES:
        domain, task = tasks.split_name(name)
        rows = off_nominal(domain, np.random.default_rng(0), count=3)
        for actions in ACTIONS:
            env, _ = lwrl.jax.make(name, actions=actions)
            ranges = np.stack(jax.jit(jax.vmap(env.action_range))(jnp.asarray(rows)), axis=-1)
            np.testing.assert_array_equal(ranges, env.definition.control_range_at(rows))
            assert tuple(map(float, env.action_range())) == env.definition.control_range
        assert (domain == "mountain_car") == np.all(ranges == env.definition.control_range)


def test_continuous_actions_jit_and_vmap_over_agents_and_params():
    """One compiled program steps agents each with its own action, a number or an array of
    shape (1,), and its own parameter values or the same ones, each row its own single step:
    an action beyond the range is that row's own end (the torque limit moving with
    `torque`, above the paper's and below it)."""
    env, params = lwrl.jax.make("pendulum.swingup", actions="continuous")
    rows = jnp.asarray(off_nominal("pendulum", np.random.default_rng(2), count=4))
    keys = jax.random.split(jax.random.PRNGKey(0), 4)
    _, states = jax.jit(jax.vmap(env.reset))(keys, rows)
    actions = jnp.array([100.0, -100.0, 0.5, -100.0])
    single, over_params = jax.jit(env.step_env), jax.jit(jax.vmap(env.step_env))
    over_agents = jax.jit(jax.vmap(env.step_env, in_axes=(0, 0, 0, None)))
    batched, shared = over_params(keys, states, actions, rows), over_agents(keys, states, actions, params)
    low, high = env.definition.control_range_at(np.asarray(rows)).T
    assert high[0] > 5.0 and high[3] < 5.0  # the limit moved up and down from the paper's 5 N m
    for same in (over_params(keys, states, actions[:, None], rows),
                 over_params(keys, states, jnp.asarray(np.clip(actions, low, high)), rows)):
        np.testing.assert_array_equal(np.asarray(same[1].physics), np.asarray(batched[1].physics))
    for b in range(4):
        state = jax.tree.map(lambda x: x[b], states)
        for stepped, row in ((batched, rows[b]), (shared, params)):
            np.testing.assert_array_equal(np.asarray(stepped[1].physics[b]),
                                          np.asarray(single(keys[b], state, actions[b], row)[1].physics))


def test_a_continuous_action_is_one_finite_number_where_it_is_concrete():
    """A NaN, an infinity, a bool, a string or two numbers are refused in one line where the
    action is concrete; in a traced program the shape and type still are, a NaN propagates
    into the state (as in gymnax) and an infinity is clipped. A continuous task has no
    `num_actions` for a learner of discrete actions."""
    env, params = lwrl.jax.make("pendulum.swingup", actions="continuous")
    _, state = env.reset(jax.random.PRNGKey(0), params)
    key = jax.random.PRNGKey(1)
    traced = jax.jit(env.step_env)
    for bad, step in [(np.nan, env.step_env), (np.inf, env.step), ([1.0, 2.0], env.step_env),
                      (True, env.step_env), ("torque", env.step_env),
                      (jnp.ones(2), traced), (jnp.array(True), traced)]:
        with pytest.raises(ValueError) as error:
            step(key, state, bad, params)
        assert "action must be one finite torque" in str(error.value)
        assert "\n" not in str(error.value)
    assert np.all(np.isnan(np.asarray(traced(key, state, jnp.nan, params)[1].physics)))
    np.testing.assert_array_equal(np.asarray(traced(key, state, jnp.inf, params)[1].physics),
                                  np.asarray(traced(key, state, 5.0, params)[1].physics))
    with pytest.raises(ValueError, match="allowed for such learners: actions='discrete'"):
        env.num_actions


@pytest.mark.parametrize("call, message", [
    (lambda: lwrl.jax.make("cartpole.swing"), "unknown task 'swing'"),
    (lambda: lwrl.jax.make("nothing.balance"), "unknown domain 'nothing'"),
    (lambda: lwrl.jax.make("cartpole.balance", track=1), "unknown option 'track'"),
    (lambda: lwrl.jax.make("cartpole.balance", dtype="int8"), "dtype must be float32 or float64"),
    (lambda: lwrl.jax.make("pendulum.swingup", integrator="rk4"), "unknown integrator 'rk4'"),
    (lambda: lwrl.jax.make("pendulum.swingup", params={"mass": -1}), "mass (m) must be"),
    (lambda: lwrl.jax.make("pendulum.swingup", actions="both"),
     "actions must be one of: discrete, continuous; got 'both'"),
    (lambda: lwrl.jax.make("cartpole.balance")[0].reset(jax.random.PRNGKey(0), jnp.ones(3)),
     "params must hold 7 values"),
])
def test_bad_input_gets_one_line(call, message):
    with pytest.raises(ValueError) as error:
        call()
    assert message in str(error.value) and "\n" not in str(error.value)


@pytest.mark.parametrize("name", tasks.TASK_NAMES)
@pytest.mark.parametrize("actions", ACTIONS)
def test_gymnaxs_spaces_are_the_tasks_spec(name, actions):
    env, params = lwrl.jax.make(name, actions=actions)
    spec = tasks.spec(name, actions=actions)
    assert env.action_space(params) == spec.action
    assert env.observation_space(params) == spec.observation


def test_the_continuous_action_space_follows_params():
    env, params = lwrl.jax.make("pendulum.swingup", actions="continuous")
    torque = tasks.domain("pendulum").parameters.index.torque
    assert env.action_space(params.at[torque].set(2.0)) == tasks.spec(
        "pendulum.swingup", actions="continuous", params={"torque": 2.0}).action


def test_observation_noise_unbounds_the_observation_space():
    env, params = lwrl.jax.make("cartpole.balance", observation_noise={"pole_angle": 0.01})
    space = env.observation_space(params)
    opened = [name for name, low in zip(env.definition.state_names, space.low) if low == -np.inf]
    assert "pole_angle" in opened and "cart_position" not in opened


def test_makes_example_runs():
    import doctest

    from lwrl.jax import environment
    finder, runner = doctest.DocTestFinder(), doctest.DocTestRunner(verbose=False)
    for test in finder.find(environment.make, "make", globs={}):
        runner.run(test)
    assert runner.failures == 0 and runner.tries > 5
