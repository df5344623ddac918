"""The mjx plant (MuJoCo's XLA port, `tasks.mjx_plant`) against the C engine, and a run on it.

From the same starts and random actions, MJX and `MujocoPlant` (the C engine, `mujoco`)
agree to round-off on every model; measured maxima over the seeds below (mujoco-mjx 3.17,
jax 0.10, 2 CPU cores) are in each test, the bounds far above them. These tests run where
the extra is installed (`pip install 'lwrl[mjx]'`).
"""

import numpy as np
import pytest

pytest.importorskip("mujoco.mjx", reason="the mjx plant needs MJX: pip install 'lwrl[mjx]'")

from lwrl import tasks  # noqa: E402
from lwrl.runners.config import RunConfig  # noqa: E402
from lwrl.runners.run import run  # noqa: E402
from lwrl.studies.compare.open_loop import random_trials, trajectories  # noqa: E402

SEEDS = range(20)
"""Every test steps batches of `len(SEEDS)`, so that JAX compiles each model's step once."""
MODEL_DOMAINS = [name for name, domain in tasks.DOMAINS.items() if domain.model]


def both_plants(domain, starts, controls):
    """`(mjx, mujoco)` trajectories `(B, T + 1, d)` from `starts` under `controls (B, T)`."""
    plants = tasks.domain(domain).plants
    return tuple(trajectories(plants.batch(plant, len(starts)), starts, controls)
                 for plant in ("mjx", "mujoco"))


def random_controls(definition, rng, steps):
    actions = rng.integers(definition.num_actions, size=(len(SEEDS), steps))
    return np.asarray(definition.controls)[actions]


def test_every_model_has_an_mjx_plant_for_batches_only():
    assert MODEL_DOMAINS == ["pendulum", "cartpole", "acrobot"]
    for domain in MODEL_DOMAINS:
        assert "mjx" in tasks.PLANTS[domain] and "mjx" not in tasks.ENVIRONMENT_PLANTS[domain]


@pytest.mark.parametrize("domain", MODEL_DOMAINS)
def test_mjx_agrees_with_the_c_engine_from_the_tasks_starts(domain):
    """300 random-action steps from the task's starts (the acrobot's four substeps and
    velocity limit included). Measured: at most 4.7e-13 (pendulum), 1.7e-12 (cart-pole,
    the pole falls and spins) and 2.6e-14 (acrobot)."""
    definition = tasks.definition(domain, next(iter(tasks.domain(domain).tasks)))
    starts, actions = random_trials(definition, SEEDS, 300)
    mjx_states, c_states = both_plants(domain, starts, np.asarray(definition.controls)[actions])
    worst = np.abs(mjx_states - c_states).max(axis=(0, 1))
    assert np.all(worst < 1e-10), worst


@pytest.mark.parametrize("domain", MODEL_DOMAINS)
def test_mjx_agrees_with_the_c_engine_from_random_states(domain):
    """From random states over the task's bounds (velocities within +-3) under random
    actions, 300 steps, or 10 for the chaotic acrobot (`test_plant_check`), whose velocity
    limit clips in them. Measured: at most 2.4e-13 (pendulum), 2.6e-11 (cart-pole) and
    1.9e-12 (acrobot)."""
    definition = tasks.definition(domain, next(iter(tasks.domain(domain).tasks)))
    rng = np.random.default_rng(1)
    low, high = (np.clip(bound, -3.0, 3.0) for bound in definition.bounds)
    starts = rng.uniform(low, high, size=(len(SEEDS), len(low)))
    steps = 10 if domain == "acrobot" else 300
    mjx_states, c_states = both_plants(domain, starts, random_controls(definition, rng, steps))
    worst = np.abs(mjx_states - c_states).max(axis=(0, 1))
    assert np.all(worst < 1e-9), worst


def test_fewer_states_than_the_batch_are_padded_not_recompiled():
    """A batched environment steps only its running episodes: those rows come out as in a
    full batch, bit for bit; more rows than the batch size, or none, are handled."""
    batch = len(SEEDS)
    plant = tasks.domain("cartpole").plants.batch("mjx", batch)
    rng = np.random.default_rng(0)
    states = rng.uniform(-0.2, 0.2, size=(batch, 4))
    controls = rng.choice([-10.0, 10.0], size=batch)
    full = plant.step(states, controls)
    np.testing.assert_array_equal(plant.step(states[:3], controls[:3]), full[:3])
    assert plant.step(states[:0], controls[:0]).shape == (0, 4)
    with pytest.raises(ValueError, match=f"{batch + 1} states for a plant of batch size {batch}"):
        plant.step(np.zeros((batch + 1, 4)), np.zeros(batch + 1))


def test_a_run_on_mjx_learns():
    """Cart-pole agents on the mjx plant (`runners.run`, through `BatchedEnv`) learn to
    balance: 14 steps on average in their first two episodes, 262 in episodes 6 to 8
    (measured, 20 agents)."""
    config = RunConfig(task="cartpole.balance", plant="mjx", agents=len(SEEDS), episodes=8)
    _, results = run(config)
    first, last = results.steps[:, :2].mean(), results.steps[:, -3:].mean()
    assert last > 100 and last > 5 * first, (first, last)
