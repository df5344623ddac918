"""The batched stepper is B copies of the single environments, not a second task: the task
contract's checks of it are `lwrl.testing`'s, run here over every task and plant."""

import numpy as np
import pytest

from lwrl import testing
from lwrl.tasks.batched import BatchedEnv


def test_batched_equals_single_environments(task_plant):
    testing.check_task_batched(*task_plant)


def test_a_time_steps_observation_is_its_own(task_plant):
    testing.check_task_batched_observations_are_their_own(*task_plant)


def test_batched_reset_marks_first_and_steps_after_last_reset():
    """After LAST, the next step starts a new episode (FIRST) and ignores its action."""
    env = BatchedEnv("cartpole", "balance", "analytic", seeds=[0, 1])
    ts = env.reset()
    assert ts.first().all() and (ts.reward == 0).all()
    step = 0
    while not ts.last()[0]:
        ts = env.step([1, step % 2])  # the second cart-pole stays up longer
        step += 1
    assert ts.discount[0] == 0.0 and ts.reward[0] == -1.0
    ts = env.step([1, 1])
    assert ts.first()[0] and not ts.first()[1]
    np.testing.assert_array_equal(ts.observation[0], np.zeros(4))


def test_batched_bad_input():
    env = BatchedEnv("pendulum", "swingup", "analytic", seeds=[0, 1, 2])
    env.reset()
    with pytest.raises(ValueError, match=r"actions must have shape \(3,\)"):
        env.step([0, 1])
    with pytest.raises(ValueError, match="action must be an integer index in 0..1"):
        env.step([0, 1, 2])
    with pytest.raises(ValueError, match="state must be finite"):
        env.set_state(np.full((3, 2), np.nan))
    with pytest.raises(ValueError, match="seeds must name at least one"):
        BatchedEnv("pendulum", "swingup", seeds=[])
    with pytest.raises(ValueError, match="unknown plant"):
        BatchedEnv("mountain_car", "cost_to_go", "mujoco")
