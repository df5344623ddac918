"""The pendulum swing-up (Främling 2008, section 4.2; SPEC.md "Task 2"): its spaces, limits
and starts, its reward and up-time at known states, and the author's code's equations."""

import math

import numpy as np
import pytest

from lwrl import tasks
from conftest import one_step, set_state


def test_the_task_is_the_papers():
    """State (theta, theta_dot), torques -5 and +5 N m, 60 s of 0.02 s steps."""
    definition = tasks.definition("pendulum", "swingup")
    assert definition.state_names == ("angle", "angular_velocity")
    assert definition.controls == (-5.0, 5.0)
    assert definition.control_timestep == 0.02 and definition.step_limit == 3000
    assert tasks.domain("pendulum").plants.substeps == 1  # one MuJoCo step per control step


@pytest.mark.parametrize("plant", ["mujoco", "analytic"])
def test_starts_hang_at_rest_at_a_uniform_angle(plant):
    """theta ~ U[-pi, pi], theta_dot = 0: uniform over the circle, other for another seed."""
    env = tasks.load("pendulum", "swingup", plant=plant, seed=3)
    starts = np.array([list(env.reset().observation.values()) for _ in range(200)])
    other = list(tasks.load("pendulum", "swingup", plant=plant, seed=4).reset().observation.values())
    assert np.all(np.abs(starts[:, 0]) <= np.pi) and np.all(starts[:, 1] == 0.0)
    assert abs(starts[:, 0].std() / (2 * np.pi) - 1 / np.sqrt(12)) < 0.05
    assert len(np.unique(starts[:, 0])) == len(starts) and other[0] != starts[0, 0]


def test_physics_accessors_name_the_quantities():
    for plant in ("mujoco", "analytic"):
        env = tasks.load("pendulum", "swingup", plant=plant)
        set_state(env, [2 * np.pi + 0.5, -1.0])
        assert (env.physics.angle(), env.physics.angular_velocity()) == pytest.approx((0.5, -1.0))


@pytest.mark.parametrize("plant", ["mujoco", "analytic"])
@pytest.mark.parametrize("angle, angular_velocity, expected", [
    (0.0, 0.0, 0.3),                                   # upright at rest: cos 0 - 0.7
    (np.pi / 5 - 1e-9, 1.0, np.cos(np.pi / 5 - 1e-9) - 0.7 - 1.0),  # inside pi/5: speed penalised
    (np.pi / 5 + 1e-3, 1.0, np.cos(np.pi / 5 + 1e-3) - 0.7),  # outside: r1 only
    (-np.pi / 2, -3.0, np.cos(-np.pi / 2) - 0.7),
    (np.pi, 0.0, -1.7),                                # hanging
])
def test_pendulum_reward_at_known_states(plant, angle, angular_velocity, expected):
    """r1 = cos(theta) - 0.7; within |theta| <= pi/5, r2 = r1 - |theta_dot| (section 4.2),
    read through the task for a state set in the plant; no state is terminal."""
    env = tasks.load("pendulum", "swingup", plant=plant, seed=0)
    set_state(env, [angle, angular_velocity])
    assert env.task.get_reward(env.physics) == pytest.approx(expected, abs=1e-12)
    assert env.task.get_termination(env.physics) is None


def test_kfnnet_pendulum_scales_the_acceleration_by_dt_twice():
    """The author's code's suspected slip (SPEC.md, "Known traps"): theta_d' = theta_d +
    dt^2 theta_dd, with theta_dd of m l^2 theta_dd = -mu theta_d + m g l sin(theta) + tau
    (m = l = 1); the paper's equations take dt once."""
    state, dt = [0.5, 1.2], 0.02
    acceleration = -0.01 * 1.2 + 9.81 * math.sin(0.5) + 5.0
    for equations, gain in (("paper", dt), ("kfnnet", dt * dt)):
        velocity = 1.2 + gain * acceleration
        np.testing.assert_allclose(one_step("pendulum", "swingup", state, 1, equations=equations),
                                   [0.5 + dt * velocity, velocity], rtol=1e-13)


def test_pendulum_uptime_counts_seconds_up():
    """Up-time adds 0.02 s for each step entering |theta| <= pi/2; none hanging down."""
    env = tasks.load("pendulum", "swingup", plant="analytic")
    set_state(env, [np.pi, 0.0])
    for _ in range(10):
        env.step(0)
    assert env.task.uptime == 0.0
    set_state(env, [0.0, 0.0])
    env.task._uptime = 0.0
    for _ in range(10):
        env.step(0)  # falls, but stays within pi/2 for 10 steps
    assert env.task.uptime == pytest.approx(0.2)


def test_pendulum_observation_wraps_the_angle():
    """The observed angle is wrapped to [-pi, pi]; the plant's own angle is not."""
    env = tasks.load("pendulum", "swingup", plant="mujoco")
    set_state(env, [3 * np.pi + 0.1, 0.0])
    assert env.task.get_observation(env.physics)["angle"] == pytest.approx(-np.pi + 0.1)
    assert env.physics.state_vector()[0] == pytest.approx(3 * np.pi + 0.1)
