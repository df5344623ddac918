"""The cart-pole (Barto, Sutton and Anderson 1983, as Främling 2008, section 4.3; SPEC.md
"Task 3"): its spaces, limits and start, its failures at known states, the track limit, and
the author's code's equations written out."""

import math

import numpy as np
import pytest

from lwrl import tasks
from conftest import one_step, set_state


def test_the_task_is_the_papers():
    """State (x, x_dot, theta, theta_dot), forces -10 and +10 N, 240 s of 0.02 s steps, every
    episode from rest at zero."""
    definition = tasks.definition("cartpole", "balance")
    assert definition.state_names == ("cart_position", "cart_velocity", "pole_angle",
                                      "pole_angular_velocity")
    assert definition.controls == (-10.0, 10.0)
    assert definition.control_timestep == 0.02 and definition.step_limit == 12_000
    assert tasks.domain("cartpole").plants.substeps == 1  # one MuJoCo step per control step
    for plant in ("mujoco", "analytic"):
        for seed in (3, 4):
            env = tasks.load("cartpole", "balance", plant=plant, seed=seed)
            assert all(list(env.reset().observation.values()) == [0.0] * 4 for _ in range(20))


def test_physics_accessors_name_the_quantities():
    for plant in ("mujoco", "analytic"):
        env = tasks.load("cartpole", "balance", plant=plant)
        set_state(env, [0.1, 0.2, 0.03, 0.4])
        physics = env.physics
        assert (physics.cart_position(), physics.cart_velocity(), physics.pole_angle(),
                physics.pole_angular_velocity()) == pytest.approx((0.1, 0.2, 0.03, 0.4))


@pytest.mark.parametrize("plant", ["mujoco", "analytic"])
@pytest.mark.parametrize("state, fails", [
    ([0.0, 0.0, 0.0, 0.0], False),
    ([0.0, 0.0, math.radians(11.99), 0.0], False),
    ([0.0, 0.0, math.radians(12.01), 0.0], True),
    ([0.0, 0.0, -math.radians(12.01), 0.0], True),
    ([2.39, 0.0, 0.0, 0.0], False),
    ([-2.41, 0.0, 0.0, 0.0], True),
])
def test_cartpole_failure_at_known_states(plant, state, fails):
    """Failure (reward -1, discount 0) when |theta| > 12 deg or |x| > 2.4 m, else reward 0."""
    env = tasks.load("cartpole", "balance", plant=plant, seed=0)
    set_state(env, state)
    assert env.task.get_reward(env.physics) == (-1.0 if fails else 0.0)
    assert env.task.get_termination(env.physics) == (0.0 if fails else None)


def test_cartpole_track_limit_option():
    """`track_limit=None` removes the track limit; the angle limit stays."""
    env = tasks.load("cartpole", "balance", plant="analytic", track_limit=None)
    set_state(env, [100.0, 0.0, 0.0, 0.0])
    assert env.task.get_termination(env.physics) is None
    set_state(env, [100.0, 0.0, 0.3, 0.0])
    assert env.task.get_termination(env.physics) == 0.0
    env = tasks.load("cartpole", "balance", plant="analytic", track_limit=1.0)
    set_state(env, [1.01, 0.0, 0.0, 0.0])
    assert env.task.get_termination(env.physics) == 0.0


def test_kfnnet_cartpole_takes_the_cart_mass_in_the_spin_term():
    """The author's code's suspected slip: mc l theta_d^2 sin(theta) where the paper has
    m l theta_d^2 sin(theta), in both equations (section 4.3, written out here)."""
    x_dot, theta, theta_dot, force = 0.3, 0.1, -2.0, 10.0
    for equations, spin_mass in (("paper", 0.1), ("kfnnet", 1.0)):
        spin = spin_mass * 0.5 * theta_dot ** 2 * math.sin(theta)
        theta_dd = (9.81 * math.sin(theta) + math.cos(theta) * (-force - spin + 0.0005) / 1.1
                    - 0.000002 * theta_dot / 0.05) / (0.5 * (4 / 3 - 0.1 * math.cos(theta) ** 2 / 1.1))
        x_dd = (force + spin - 0.05 * theta_dd * math.cos(theta) - 0.0005) / 1.1
        expected_velocities = [x_dot + 0.02 * x_dd, theta_dot + 0.02 * theta_dd]
        state = one_step("cartpole", "balance", [0.0, x_dot, theta, theta_dot], 1,
                          equations=equations)
        np.testing.assert_allclose(state[1::2], expected_velocities, rtol=1e-12)
    at_rest = [one_step("cartpole", "balance", [0.0, 0.3, 0.1, 0.0], 1, equations=equations)
               for equations in ("paper", "kfnnet")]
    np.testing.assert_array_equal(*at_rest)  # without spin the equations are the same


def test_cartpole_failing_step_ends_the_episode():
    """Pushing one way from rest tips the pole over: the episode ends on the failing step
    with reward -1 and discount 0, and the up-time counts the steps before it."""
    env = tasks.load("cartpole", "balance", plant="mujoco")
    steps = [env.reset()]
    while not steps[-1].last():
        steps.append(env.step(1))
    assert [ts.reward for ts in steps[1:-1]] == [0.0] * (len(steps) - 2)
    assert steps[-1].reward == -1.0 and steps[-1].discount == 0.0
    assert steps[-1].observation["pole_angle"] < -math.radians(12)
    assert env.task.uptime == pytest.approx(0.02 * (len(steps) - 2))
