"""The spaces and the task spec (`tasks.spaces`): what they accept, and that every face of a
task (the spec, Gymnasium, the JAX environment) gives the same spaces."""

import numpy as np
import pytest

from lwrl import tasks
from lwrl.tasks.spaces import Box, Discrete, TaskSpec


def test_a_discrete_space_holds_its_indices_and_no_other_value():
    space = Discrete(3)
    assert [space.contains(i) for i in (-1, 0, 2, 3)] == [False, True, True, False]
    assert not space.contains(1.0) and not space.contains([1])
    rng = np.random.default_rng(0)
    assert {space.sample(rng) for _ in range(200)} == {0, 1, 2}


def test_a_box_holds_the_vectors_within_its_bounds():
    space = Box((-1.0, -np.inf), (1.0, np.inf))
    assert space.shape == (2,) and not space.bounded
    assert space.contains([0.5, 1e300]) and not space.contains([1.5, 0.0])
    assert not space.contains([0.0]) and not space.contains(["a", "b"])
    with pytest.raises(ValueError, match="infinite bound"):
        space.sample(np.random.default_rng(0))
    bounded = Box((-1.0, 0.0), (1.0, 2.0))
    draws = np.array([bounded.sample(np.random.default_rng(seed)) for seed in range(100)])
    assert all(bounded.contains(draw) for draw in draws)
    assert draws[:, 1].min() < 0.5 and draws[:, 1].max() > 1.5


@pytest.mark.parametrize("make, message", [
    (lambda: Discrete(0), "n >= 1"), (lambda: Discrete(2.0), "whole number"),
    (lambda: Discrete(True), "whole number"), (lambda: Box((1.0,), (0.0,)), "low <= high"),
    (lambda: Box((0.0, 0.0), (1.0,)), "as many low as high"),
    (lambda: Box((np.nan,), (1.0,)), "low <= high")])
def test_a_space_out_of_shape_is_refused_in_one_line(make, message):
    with pytest.raises(ValueError, match=message) as error:
        make()
    assert "\n" not in str(error.value)


def test_unbounding_a_box_opens_only_the_elements_asked_for():
    space = Box((-1.0, -2.0), (1.0, 2.0)).unbounded_where([False, True])
    assert space == Box((-1.0, -np.inf), (1.0, np.inf))


@pytest.mark.parametrize("name", tasks.TASK_NAMES)
@pytest.mark.parametrize("actions", ["discrete", "continuous"])
def test_the_spec_is_what_the_task_definition_says(name, actions):
    definition = tasks.definition(*tasks.split_name(name), actions=actions)
    spec = tasks.spec(name, actions=actions)
    assert isinstance(spec, TaskSpec) and spec.name == name
    assert spec.state_names == definition.state_names
    assert (spec.observation.low, spec.observation.high) == tuple(map(tuple, definition.bounds))
    assert spec.control_timestep == definition.control_timestep
    assert spec.step_limit == definition.step_limit
    assert tuple(spec.parameters.values()) == tuple(definition.physical)
    assert tuple(spec.parameters) == tasks.domain(definition.domain).parameters.names
    assert spec.continuous == (actions == "continuous")
    if spec.continuous:
        assert spec.action == Box((definition.control_range[0],), (definition.control_range[1],))
    else:
        assert spec.action == Discrete(len(definition.controls))


def test_the_spec_follows_the_tasks_options():
    spec = tasks.spec("pendulum.swingup", actions="continuous", params={"torque": 2.0},
                      time_limit=10.0)
    assert spec.action == Box((-2.0,), (2.0,))
    assert spec.parameters["torque"] == 2.0 and spec.step_limit == 500


@pytest.mark.parametrize("actions", ["discrete", "continuous"])
def test_gymnasiums_spaces_are_the_specs(actions):
    gym = pytest.importorskip("lwrl.gym", reason="needs the gymnasium extra")
    env = gym.SuiteEnv("cartpole", "balance", "analytic", actions=actions,
                       observation_noise={"pole_angle": 0.01})
    spec = tasks.spec("cartpole.balance", actions=actions)
    assert env.task_spec == spec
    assert env.action_space == gym.gymnasium_space(spec.action)
    noisy = np.array(spec.state_names) == "pole_angle"
    assert env.observation_space == gym.gymnasium_space(spec.observation.unbounded_where(noisy))
    vector = gym.SuiteVectorEnv("cartpole", "balance", "analytic", num_envs=2, actions=actions,
                                observation_noise={"pole_angle": 0.01})
    assert vector.single_observation_space == env.observation_space
    assert vector.single_action_space == env.action_space
