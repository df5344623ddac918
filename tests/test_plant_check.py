"""The MuJoCo plants against the paper's equations (SPEC.md, "Integration").

From the same start and the same random actions, MuJoCo's Euler step and the analytic
semi-implicit Euler step agree to round-off; the explicit (literal) Euler reading does not.
Measured maxima over the seeds below (mujoco 3.17): see each test. The bounds are an order of
magnitude above them.

A note on long horizons: replaying a balancing controller's 12 000 actions open loop, the
plants agree to 1e-13 for 100 steps and then part at the rate the upright pole's instability
amplifies round-off (1e-9 at 200 steps, 1e-3 near 400): a property of the task, not of the
plants, so the whole-episode check uses random-action episodes, which end at failure. The
acrobot is chaotic once it swings high: from random high-energy states its plants part by
about a factor 10 every 3 steps after the first few (1e-12 at 10 steps, 1e-8 at 30, 1e-4 at
50), so its check from such states is over 10 steps.
"""

import numpy as np
import pytest

from lwrl import tasks
from lwrl.studies.compare.open_loop import plant, random_trials, trajectories

SEEDS = range(20)


def divergence(domain, seed, steps, integrator="semi_implicit", to_failure=False):
    """Per state variable, the largest |MuJoCo - analytic| over one random-action trial
    (`lwrl.studies.compare.open_loop.random_trials`), and the steps compared: all of them, or with
    `to_failure` those up to the failure, on which both plants must agree."""
    definition = tasks.definition(domain, next(iter(tasks.domain(domain).tasks)))
    starts, actions = random_trials(definition, [seed], steps)
    controls = np.asarray(definition.controls)[actions]
    mujoco_states = trajectories(plant(domain, "mujoco", 1), starts, controls)[0]
    analytic_states = trajectories(plant(domain, integrator, 1), starts, controls)[0]
    if to_failure:
        failed = [np.flatnonzero(definition.terminal(states[1:])) for states in
                  (mujoco_states, analytic_states)]
        assert len(failed[0]) and len(failed[1]), "the trial should end in a failure"
        assert failed[0][0] == failed[1][0], "the plants fail on different steps"
        steps = failed[0][0] + 1
    return np.abs(mujoco_states - analytic_states)[:steps + 1].max(axis=0), steps


def cartpole_divergence(seed, steps, integrator="semi_implicit", to_failure=False):
    return divergence("cartpole", seed, steps, integrator, to_failure)


def pendulum_divergence(seed, steps, integrator="semi_implicit"):
    return divergence("pendulum", seed, steps, integrator)[0]


def test_cartpole_plants_agree_over_50_steps():
    """Measured: at most 7.1e-15 in any state variable over 50 steps (20 seeds)."""
    worst = np.max([cartpole_divergence(seed, 50)[0] for seed in SEEDS], axis=0)
    assert np.all(worst < 1e-13), worst


def test_cartpole_plants_agree_over_whole_episodes():
    """Random-action episodes to failure (the MuJoCo plant and the analytic plant fail on
    the same step). Measured: at most 7.2e-14 over episodes of up to 75 steps (200 seeds);
    here 20 seeds."""
    results = [cartpole_divergence(seed, 200, to_failure=True) for seed in SEEDS]
    worst = np.max([divergence for divergence, _ in results], axis=0)
    assert max(length for _, length in results) > 30
    assert np.all(worst < 1e-12), worst


def test_pendulum_plants_agree_over_50_and_200_steps():
    """Measured: at most 7.0e-12 over 50 steps and 3.9e-11 over 200 (20 seeds). The
    pendulum's round-off floor is above the cart-pole's because its MJCF point mass carries
    an inertia of 1e-12 kg m^2 (MuJoCo needs a positive one)."""
    worst_50 = np.max([pendulum_divergence(seed, 50) for seed in SEEDS], axis=0)
    worst_200 = np.max([pendulum_divergence(seed, 200) for seed in SEEDS], axis=0)
    assert np.all(worst_50 < 5e-11), worst_50
    assert np.all(worst_200 < 5e-10), worst_200


def acrobot_divergence(seed, steps, integrator="semi_implicit"):
    return divergence("acrobot", seed, steps, integrator)[0]


def test_acrobot_plants_agree_over_50_and_200_steps():
    """From the task's start (at rest hanging down) under random torques, four MuJoCo Euler
    steps of 0.05 s and the velocity limit per action against the analytic plant's.
    Measured: at most 3.6e-15 over 50 steps and 2.2e-14 over 200 (20 seeds)."""
    worst_50 = np.max([acrobot_divergence(seed, 50) for seed in SEEDS], axis=0)
    worst_200 = np.max([acrobot_divergence(seed, 200) for seed in SEEDS], axis=0)
    assert np.all(worst_50 < 1e-13), worst_50
    assert np.all(worst_200 < 1e-12), worst_200


def test_acrobot_plants_agree_from_high_energy_states():
    """From random states over the task's bounds (any angles, speeds up to the limits) under
    random torques: the plants agree to round-off over 10 steps, in which the velocity limit
    clips 32 times (20 seeds). Measured: at most 1.6e-12; see the module's note on chaos."""
    definition = tasks.definition("acrobot", "swingup")
    worst, clipped = [], 0
    for seed in SEEDS:
        rng = np.random.default_rng(seed)
        start = rng.uniform(*definition.bounds, size=(1, 4))
        controls = np.asarray(definition.controls)[rng.integers(3, size=(1, 10))]
        mujoco_states = trajectories(plant("acrobot", "mujoco", 1), start, controls)[0]
        analytic_states = trajectories(plant("acrobot", "semi_implicit", 1), start, controls)[0]
        worst.append(np.abs(mujoco_states - analytic_states).max(axis=0))
        clipped += np.sum(np.abs(analytic_states[1:, 1]) == 4 * np.pi)
        clipped += np.sum(np.abs(analytic_states[1:, 3]) == 9 * np.pi)
    assert clipped > 20
    worst = np.max(worst, axis=0)
    assert np.all(worst < 2e-11), worst


@pytest.mark.parametrize("divergence", [
    lambda seed: cartpole_divergence(seed, 50, "explicit")[0],
    lambda seed: pendulum_divergence(seed, 50, "explicit"),
    lambda seed: acrobot_divergence(seed, 50, "explicit"),
], ids=["cartpole", "pendulum", "acrobot"])
def test_explicit_euler_departs_from_both(divergence):
    """The paper's literal (explicit) Euler is a different plant: within 50 steps it is
    more than 1e-3 away from MuJoCo (and so from the semi-implicit plant, which agrees with
    MuJoCo to round-off) in some state variable, for every seed. Measured: at least 0.20
    (cart-pole), 0.066 (pendulum) and 1.5 (acrobot) over the 20 seeds."""
    for seed in SEEDS:
        assert divergence(seed).max() > 1e-3
