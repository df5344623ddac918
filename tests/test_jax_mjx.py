"""The JAX tasks on MuJoCo's model (`lwrl.jax.make(name, plant="mjx")`, `lwrl.jax.mjx`)
against the C engine: every step of whole random-action episodes of the NumPy environment on
the `mujoco` plant (`BatchedEnv`), as one jitted program vmapped over the episodes; a
population learner training on it (`runners.population`); the benchmark's deep rows on it
where its linear rows run on the C engine; bad input. Measured on mujoco-mjx 3.17, jax
0.10, 2 CPU cores. These tests run where the extra is installed (`pip install 'lwrl[mjx]'`).
"""

import dataclasses
import functools

import numpy as np
import pytest

pytest.importorskip("mujoco.mjx", reason="the mjx plant needs MJX: pip install 'lwrl[mjx]'")
jax = pytest.importorskip("jax", reason="the mjx plant needs MJX: pip install 'lwrl[mjx]'")
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp  # noqa: E402

import lwrl.jax  # noqa: E402
from lwrl import tasks  # noqa: E402
from lwrl.jax.mjx import MjxEnvironment  # noqa: E402
from lwrl.runners.config import RunConfig  # noqa: E402
from lwrl.runners.run import run  # noqa: E402
from lwrl.studies.paper.benchmark import protocol  # noqa: E402
from lwrl.tasks.batched import BatchedEnv  # noqa: E402
from conftest import one_line_error  # noqa: E402

TOLERANCE = 1e-13
"""Per step, relative to the state's size (max(1, |x|)): MJX and the C engine order the
arithmetic their own ways. Measured over the episodes below: at most 2.2e-16 (the pendulum,
the cart-pole) and 7.8e-16 (the acrobot, four substeps a step), a bit or a few."""
SEEDS = range(4)
STEPS = 200
"""The episodes' time limit, in control steps."""
CASES = [("pendulum.swingup", "continuous"), ("cartpole.balance", "discrete"),
         ("acrobot.swingup", "discrete")]
"""Each domain with a model, the pendulum with continuous actions (half of them beyond the
actuator's range), the others with the paper's discrete ones."""


def options(name, actions):
    """The options of both environments: the kind of action, a time limit of `STEPS`."""
    definition = tasks.definition(*tasks.split_name(name))
    return {"actions": actions, "time_limit": STEPS * definition.control_timestep}


def c_engine_episodes(name, actions):
    """One whole random-action episode per seed of `SEEDS` on the C engine (`BatchedEnv`,
    plant `mujoco`): per step (`(B, STEPS)`, each episode's first `lengths[b]` its own) the
    plant state, step count and up-time before it, the action, and after it the state, the
    step count, the up-time, the reward, the discount and whether it was the last."""
    domain, task = tasks.split_name(name)
    env = BatchedEnv(domain, task, "mujoco", seeds=list(SEEDS), **options(name, actions))
    rng = np.random.default_rng(1)
    (low, high) = env.control_range[0]
    env.reset()
    records = []
    for _ in range(STEPS):
        before = (env.state.copy(), env.steps.copy(), env.uptime.copy())
        if actions == "continuous":
            action = rng.uniform(1.5 * low - 0.5 * high, 1.5 * high - 0.5 * low, len(SEEDS))
        else:
            action = rng.integers(env.num_actions, size=len(SEEDS))
        time_step = env.step(action)
        records.append((*before, action, env.state.copy(), env.steps.copy(), env.uptime.copy(),
                        time_step.reward, time_step.discount, time_step.last()))
    fields = [np.stack(field, axis=1) for field in zip(*records)]
    lengths = np.argmax(fields[-1], axis=1) + 1
    assert np.all(fields[-1].any(axis=1)), "an episode outlived STEPS"
    return fields, lengths


@functools.partial(jax.jit, static_argnums=0)
def jax_steps(env, physics, steps, uptime, actions, params):
    """`env.step_env` from each plant state, step count and up-time of `(B, T)` episodes
    under their actions, jitted and vmapped over the episodes and their steps."""
    def one(physics, steps, uptime, action):
        state = lwrl.jax.EnvState(physics=physics, steps=steps, uptime=uptime,
                                  transit=jnp.zeros(0, env.dtype))
        return env.step_env(jax.random.PRNGKey(0), state, action, params)
    return jax.vmap(jax.vmap(one))(physics, steps, uptime, actions)


@pytest.mark.parametrize("name, actions", CASES)
def test_every_step_of_an_episode_is_the_c_engines(name, actions):
    """The plant state after each step within `TOLERANCE`; the observation, reward,
    termination, truncation, step count and up-time the NumPy environment's."""
    env, params = lwrl.jax.make(name, plant="mjx", **options(name, actions))
    assert isinstance(env, MjxEnvironment)
    (state, steps, uptime, action, after, after_steps, after_uptime, reward, discount,
     last), lengths = c_engine_episodes(name, actions)
    observation, stepped, jax_reward, terminated, truncated, info = jax.tree.map(
        np.asarray, jax_steps(env, jnp.asarray(state), jnp.asarray(steps, jnp.int32),
                              jnp.asarray(uptime), jnp.asarray(action), params))
    ran = np.arange(STEPS)[None, :] < lengths[:, None]
    scale = np.maximum(1.0, np.abs(after))
    distance = np.where(ran[..., None], np.abs(stepped.physics - after) / scale, 0.0)
    assert distance.max() <= TOLERANCE
    np.testing.assert_allclose(observation[ran], env.definition.observe(after[ran]),
                               rtol=TOLERANCE, atol=TOLERANCE)
    np.testing.assert_allclose(jax_reward[ran], reward[ran], rtol=TOLERANCE, atol=TOLERANCE)
    np.testing.assert_array_equal(terminated[ran], discount[ran] == 0.0)
    np.testing.assert_array_equal(truncated[ran], last[ran] & (discount[ran] == 1.0))
    np.testing.assert_array_equal(stepped.steps[ran], after_steps[ran])
    np.testing.assert_allclose(stepped.uptime[ran], after_uptime[ran], rtol=TOLERANCE)


def test_a_population_trains_on_mjx_through_the_runners(monkeypatch):
    """`lwrl train --learner dqn_jax --plant mjx`'s path: the population's program steps the
    MJX environment, and every agent's episodes are recorded; values per agent or episode
    are refused, the one model's values taken."""
    made, make = [], lwrl.jax.make

    def spied(*arguments, **options):
        made.append(make(*arguments, **options))
        return made[-1]

    monkeypatch.setattr(lwrl.jax, "make", spied)
    config = RunConfig(task="pendulum.swingup", learner="dqn_jax", plant="mjx", agents=2,
                       episodes=2, task_options={"time_limit": 1.0}, timesteps=200,
                       buffer_size=100, learning_starts=20, net_arch="16")
    _, results = run(config)
    assert [type(env) for env, _ in made] == [MjxEnvironment]
    np.testing.assert_array_equal(results.steps, 50)
    assert results.truncated.all() and np.isfinite(results.returns).all()
    one_line_error(lambda: run(dataclasses.replace(config, randomise={"mass": (0.5, 2.0)})),
                   "the mjx plant steps one model", "mass")


def test_the_benchmark_on_mujoco_trains_deep_rows_on_mjx():
    """On MuJoCo's model the linear rows run on the C engine and the deep rows (JAX
    populations) on MJX; on the analytic plant every row on it."""
    for task in protocol.BUDGETS:
        if not tasks.domain(tasks.split_name(protocol.variant(task)[0])[0]).plants.model:
            continue
        for row in protocol.rows(task):
            deep = row.label in protocol.deep(task)
            for plant, expected in (("mujoco", "mjx" if deep else "mujoco"),
                                    ("analytic", "analytic")):
                config = protocol.training(task, row, row.settings, 0, 2, plant=plant)
                assert config.plant == expected, (task, row.label, plant)


@pytest.mark.parametrize("call, fragments", [
    (lambda: lwrl.jax.make("mountain_car.cost_to_go", plant="mjx"),
     ("mountain_car has none", "pendulum, cartpole, acrobot")),
    (lambda: lwrl.jax.make("pendulum.swingup", plant="mujoco"),
     ("plant must be one of: analytic, mjx",)),
    (lambda: lwrl.jax.make("pendulum.swingup", plant="mjx", integrator="explicit"),
     ("the mjx plant steps MuJoCo's model and has none",)),
    (lambda: lwrl.jax.make("pendulum.swingup", plant="mjx", dtype="float32"),
     ("in float64",)),
    (lambda: lwrl.jax.make("pendulum.swingup", plant="mjx")[0].action_range(
        np.asarray(tasks.domain("pendulum").parameters.nominal) * 2.0),
     ("the mjx plant steps one model", "got mass 2.0 where it has 1.0")),
])
def test_bad_input_gets_one_line(call, fragments):
    one_line_error(call, *fragments)
