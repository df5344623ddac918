"""The suite's contract, checked over every task and plant (SPEC.md, tasks 1-3)."""

import math

import dm_env
import numba
import numpy as np
import pytest
from dm_env import specs

from lwrl import tasks
from conftest import off_nominal



def random_episode_steps(env, rng, max_steps):
    """Step with random actions until LAST or `max_steps`; return the time steps."""
    steps = [env.reset()]
    while not steps[-1].last() and len(steps) <= max_steps:
        steps.append(env.step(int(rng.integers(env.action_spec().num_values))))
    return steps


def test_spec_conformance(task_plant):
    """Actions are a DiscreteArray mapping index i to the i-th control in ascending order;
    observations are the state variables, one float64 scalar each, matching their specs."""
    domain, task, plant = task_plant
    env = tasks.load(domain, task, plant=plant, seed=0)
    action_spec = env.action_spec()
    definition = tasks.definition(domain, task)
    assert isinstance(action_spec, specs.DiscreteArray)
    assert env.task.definition.controls == definition.controls
    assert action_spec.num_values == len(definition.controls)
    assert list(definition.controls) == sorted(definition.controls)
    observation_spec = env.observation_spec()
    assert tuple(observation_spec) == definition.state_names
    for ts in random_episode_steps(env, np.random.default_rng(0), 50):
        assert tuple(ts.observation) == definition.state_names
        for name, value in ts.observation.items():
            observation_spec[name].validate(value)
        if not ts.first():
            assert isinstance(ts.reward, float) and math.isfinite(ts.reward)
            assert ts.discount in (0.0, 1.0)


def test_each_action_applies_its_control(task_plant):
    """Action i sets the plant's control to the i-th force or torque."""
    domain, task, plant = task_plant
    env = tasks.load(domain, task, plant=plant, seed=0)
    for index, control in enumerate(tasks.definition(domain, task).controls):
        env.reset()
        env.step(index)
        applied = (env.physics.named.data.ctrl[env.physics.ACTUATOR] if plant == "mujoco"
                   else env.physics._control[0])
        assert applied == control


def test_deterministic_for_a_seed(task_plant):
    """The same seed and actions give the same time steps."""
    domain, task, plant = task_plant

    def trajectory(seed):
        env = tasks.load(domain, task, plant=plant, seed=seed)
        rng = np.random.default_rng(1)
        steps = []
        for _ in range(3):
            steps += random_episode_steps(env, rng, 40)
        return [(int(ts.step_type), ts.reward, ts.discount, tuple(ts.observation.values()))
                for ts in steps]

    assert trajectory(7) == trajectory(7)


def test_starts_are_the_tasks_and_follow_the_seed(task_plant):
    """Every start is one of the task's own (`initial_states`, within its bounds), the same
    for the same seed; random starts differ between episodes and between seeds (each
    domain's test file checks its distribution against the paper)."""
    domain, task, plant = task_plant
    definition = tasks.definition(domain, task)
    starts = [np.array(list(tasks.load(domain, task, plant=plant, seed=seed).reset().observation.values()))
              for seed in (3, 3, 4)]
    env = tasks.load(domain, task, plant=plant, seed=3)
    episodes = np.array([list(env.reset().observation.values()) for _ in range(20)])
    low, high = definition.bounds
    assert np.all(episodes >= low) and np.all(episodes <= high)
    np.testing.assert_array_equal(starts[0], starts[1])
    if len(np.unique(episodes, axis=0)) > 1:  # the task's starts are random
        assert not np.array_equal(starts[0], starts[2])
        assert len(np.unique(episodes, axis=0)) == len(episodes)


def test_time_limits_truncate(task_plant):
    """A time limit of 5 control steps ends an episode that reaches no terminal state in them
    with discount 1 (a truncation) on the fifth step, and the next step starts another."""
    domain, task, plant = task_plant
    definition = tasks.definition(domain, task)
    env = tasks.load(domain, task, plant=plant, seed=0, time_limit=5 * definition.control_timestep)
    assert env.task.definition.step_limit == 5
    env.reset()
    steps = [env.step(i % 2) for i in range(5)]
    assert [ts.step_type for ts in steps] == [dm_env.StepType.MID] * 4 + [dm_env.StepType.LAST]
    assert steps[-1].discount == 1.0
    assert env.step(0).first()


@pytest.mark.parametrize("call, message", [
    (lambda: tasks.load("cartpol", "balance"), "unknown domain 'cartpol'; available: mountain_car, pendulum, cartpole"),
    (lambda: tasks.load("cartpole", "swingup"), "unknown task 'swingup' of domain 'cartpole'; available: balance"),
    (lambda: tasks.load("mountain_car", "cost_to_go", plant="mujoco"), "unknown plant 'mujoco' for mountain_car; available: analytic"),
    (lambda: tasks.load("pendulum", "swingup", plant="mjx"), "the mjx plant steps batches only (lwrl train, tasks.batched); one environment runs on: mujoco, analytic"),
    (lambda: tasks.load("cartpole", "balance", plant="mujoco", integrator="explicit"), "unknown option 'integrator'"),
    (lambda: tasks.load("cartpole", "balance", plant="analytic", integrator="rk4"), "unknown integrator 'rk4'; allowed: semi_implicit, explicit"),
    (lambda: tasks.load("pendulum", "swingup", plant="mujoco", equations="kfnnet"), "unknown option 'equations'"),
    (lambda: tasks.load("pendulum", "swingup", plant="analytic", equations="R"), "unknown equations 'R'; allowed: paper, kfnnet"),
    (lambda: tasks.load("pendulum", "swingup", frobnicate=1), "allowed: plant, seed, time_limit"),
    (lambda: tasks.load("pendulum", "swingup", time_limit=-1), "time_limit must be a positive number"),
    (lambda: tasks.load("cartpole", "balance", track_limit=0), "track_limit must be a positive number"),
])
def test_bad_names_and_options_say_what_is_allowed(call, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        call()


@pytest.mark.parametrize("action", [-1, "num_actions", 1.5, "1", np.array([0, 1]), None])
def test_bad_action_is_refused(task_plant, action):
    """An action index out of range, or not one integer, raises naming the allowed range."""
    domain, task, plant = task_plant
    env = tasks.load(domain, task, plant=plant)
    env.reset()
    num_actions = env.action_spec().num_values
    if isinstance(action, str) and action == "num_actions":
        action = num_actions
    with pytest.raises(ValueError, match=f"action must be .*integer index in 0..{num_actions - 1}"):
        env.step(action)


def test_nan_state_is_refused(task_plant):
    """A NaN given to a plant raises, naming the state variables."""
    domain, task, plant = task_plant
    env = tasks.load(domain, task, plant=plant)
    env.reset()
    names = tasks.definition(domain, task).state_names
    state = np.zeros(len(names))
    state[-1] = np.nan
    with pytest.raises(ValueError, match=f"state must be finite.*{names[-1]}"):
        env.physics.set_state_vector(state)
    with pytest.raises(ValueError, match="2 entries"):
        tasks.load("pendulum", "swingup", plant=plant if plant in tasks.PLANTS["pendulum"] else "analytic"
                   ).physics.set_state_vector([0.0, 0.0, 0.0])


@pytest.mark.parametrize("domain, task", tasks.ALL_TASKS)
@pytest.mark.parametrize("integrator", ["semi_implicit", "explicit"])
@pytest.mark.parametrize("equations", ["paper", "kfnnet"])
@pytest.mark.parametrize("physics", ["nominal", "off_nominal"])
def test_transition_is_the_plant_step_and_the_task(domain, task, integrator, equations, physics):
    """The compiled loops' `transition` (run here compiled by numba) gives the analytic
    plant's next state, the task's observation, reward, termination and up-time, exactly:
    at the paper's parameter values, and at values of each state's own (`off_nominal`),
    with each action's control at those values."""
    definition = tasks.definition(domain, task)
    options = {name: value for name, value in (("integrator", integrator), ("equations", equations))
               if name in tasks.plant_option_names(domain, "analytic")}
    plant = tasks.domain(domain).plants.batch("analytic", 200, **options)
    transition = numba.njit(definition.transition)
    rng = np.random.default_rng(0)
    low, high = map(np.asarray, (definition.defaults.low, definition.defaults.high))
    # States within twice the normalisation ranges: past the ranges, the limits (the
    # acrobot's speeds) and the terminal states.
    states = rng.uniform(-1, 1, size=(200, len(low))) * 2 * np.maximum(np.abs(low), np.abs(high))
    rows = (np.tile(definition.physical, (200, 1)) if physics == "nominal"
            else off_nominal(domain, rng, 200))
    controls = definition.controls_at(rows)[np.arange(200),
                                            rng.integers(definition.num_actions, size=200)]
    expected = plant.step(states, controls, None if physics == "nominal" else rows)
    semi_implicit = integrator == "semi_implicit"
    params = np.array(definition.params, dtype=np.float64)
    outcomes = definition.outcomes(expected, rows)
    for i, (state, control, next_expected) in enumerate(zip(states, controls, expected)):
        next_state, observation = np.empty_like(state), np.empty_like(state)
        reward, terminal, up = transition(state, control, next_state, observation,
                                          plant.timestep, semi_implicit,
                                          equations == "kfnnet", (params, rows[i]))
        np.testing.assert_array_equal(next_state, next_expected)
        np.testing.assert_array_equal(observation, definition.observe(next_expected[None])[0])
        assert (reward, terminal) == (outcomes[0][i], outcomes[1][i])
        if definition.has_uptime:
            assert up == outcomes[2][i]