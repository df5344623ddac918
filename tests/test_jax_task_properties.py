"""The JAX tasks' `step` (`lwrl.jax`) over arbitrary states, actions and physical parameters
within their spaces (Hypothesis): on every task, with either kind of action, a state within
the task's observation bounds (`env.observation_space(params)`; any speed up to
`UNBOUNDED` where it bounds none, the pendulum's and the cart-pole's), an action of
`env.action_space(params)` and parameter values within their declared ranges
(`tasks.domain(d).parameters`) give a finite observation and reward, a finite up-time on
the tasks that keep one, and boolean flags. The one refusal: a state the equations overflow
from (the cart-pole's speeds beyond about 1e154) ends the episode as a failure, its last
observation NaN."""

import functools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

jax = pytest.importorskip("jax", reason="the JAX tasks need the jax extra: pip install 'lwrl[jax]'")
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp  # noqa: E402

import lwrl.jax  # noqa: E402
from lwrl import tasks  # noqa: E402
from lwrl.spaces import Discrete  # noqa: E402


UNBOUNDED = 1e300
"""The largest speed drawn where the observation space bounds none. Past about 1e305 the
pendulum's friction term (mu omega / (m l^2), l down to 0.1) leaves float's range and its
next state is not finite: such speeds are not reachable from any start under the torques
allowed, and the task states no bound of its own."""


@functools.cache
def stepped(name: str, actions: str):
    """`(env, step)`: the task with `actions` and its `step` from a plant state, compiled once
    (`step(key, physics, action, params)`)."""
    env, _ = lwrl.jax.make(name, actions=actions)

    def step(key, physics, action, params):
        _, state = env.start(key, physics)
        return env.step(key, state, action, params)

    return env, jax.jit(step)


@st.composite
def within(draw, name: str, actions: str):
    """`(physics, action, params)` within the task's spaces."""
    env, _ = stepped(name, actions)
    parameters = tasks.domain(env.definition.domain).parameters.items
    params = np.array([draw(st.floats(p.low, p.high)) for p in parameters])
    space = env.observation_space(params)
    physics = np.array([draw(st.floats(max(low, -UNBOUNDED), min(high, UNBOUNDED)))
                        for low, high in zip(space.low, space.high)])
    action_space = env.action_space(params)
    if isinstance(action_space, Discrete):
        action = draw(st.integers(0, action_space.n - 1))
    else:
        action = draw(st.floats(action_space.low[0], action_space.high[0]))
    return physics, action, params


@pytest.mark.parametrize("actions", ["discrete", "continuous"])
@pytest.mark.parametrize("name", tasks.TASK_NAMES)
def test_a_step_within_the_spaces_is_finite(name, actions):
    env, step = stepped(name, actions)

    @settings(max_examples=60, deadline=None)
    @given(within(name, actions), st.integers(0, 2 ** 32 - 1))
    def check(example, seed):
        physics, action, params = example
        observation, state, reward, terminated, truncated, info = step(
            jax.random.key(seed), jnp.asarray(physics), action, jnp.asarray(params))
        assert np.isfinite(np.asarray(observation)).all(), (observation, state)
        # a state the equations overflow from (the cart-pole's beyond 1e154) ends the
        # episode, a failure; the next starts afresh
        assert np.isfinite(np.asarray(info["final_observation"])).all() or terminated
        assert np.isfinite(np.asarray(reward))
        # a task without up-time (Mountain-Car) reports it as NaN
        assert np.isfinite(np.asarray(state.uptime)) == env.definition.has_uptime
        assert np.asarray(terminated).dtype == bool and np.asarray(truncated).dtype == bool

    check()
