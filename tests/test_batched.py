"""The batched stepper is B copies of the single environments, not a second task."""

import numpy as np
import pytest

from lwrl import tasks
from lwrl.tasks.batched import LAST, BatchedEnv

SHORT_STEPS = 40
"""A time limit of so many control steps: auto-resets happen within the test."""


def test_batched_equals_single_environments(task_plant):
    """B batched environments, given the seeds and actions of B single dm_env environments,
    return identical step types, rewards, discounts, observations and up-times over several
    episodes (including terminal and truncated ends and the auto-resets after them)."""
    domain, task, plant = task_plant
    seeds = [3, 5, 8, 13, 21]
    options = {"time_limit": SHORT_STEPS * tasks.definition(domain, task).control_timestep}
    batched = BatchedEnv(domain, task, plant, seeds, **options)
    singles = [tasks.load(domain, task, plant=plant, seed=seed, **options) for seed in seeds]
    rng = np.random.default_rng(0)
    batched_ts = batched.reset()
    single_ts = [env.reset() for env in singles]
    ends = 0
    for _ in range(120):
        actions = rng.integers(batched.num_actions, size=len(seeds))
        batched_ts = batched.step(actions)
        single_ts = [env.step(int(a)) for env, a in zip(singles, actions)]
        for i, ts in enumerate(single_ts):
            assert batched_ts.step_type[i] == int(ts.step_type)
            np.testing.assert_array_equal(batched_ts.observation[i], list(ts.observation.values()))
            if not ts.first():
                assert batched_ts.reward[i] == ts.reward
                assert batched_ts.discount[i] == ts.discount
            np.testing.assert_array_equal(batched.uptime[i], singles[i].task.uptime)
            assert batched.steps[i] == singles[i].task.steps
        ends += int(np.sum(batched_ts.step_type == LAST))
    assert ends >= len(seeds), "the test should cover episode ends and auto-resets"


def test_a_time_steps_observation_is_its_own(task_plant):
    """The observations a batch returns share no memory with its state: the next steps
    leave them as they were (as dm_env's suite requires of its environments)."""
    domain, task, plant = task_plant
    env = BatchedEnv(domain, task, plant, seeds=[0, 1])
    steps = [env.reset()] + [env.step([1, 0]) for _ in range(3)]
    kept = [step.observation.copy() for step in steps]
    env.step([0, 1])
    for step, observation in zip(steps, kept):
        np.testing.assert_array_equal(step.observation, observation)
        assert not np.shares_memory(step.observation, env.state)


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
