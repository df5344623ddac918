"""The spaces and the task spec (`lwrl.spaces`): what they accept, and that every face of a
task (the spec, Gymnasium, the JAX environment) gives the same spaces."""

import json

import numpy as np
import pytest

from lwrl import tasks
from lwrl.spaces import Box, Discrete, TaskSpec, spec_document, spec_of_document


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
    assert spec.ranges == Box(*definition.ranges)
    assert spec.actions == actions


@pytest.mark.parametrize("actions", ["discrete", "continuous"])
def test_a_spec_goes_through_json_and_back(actions):
    """An agent file keeps its agents' spec as JSON (`spec_document`), infinite bounds too."""
    spec = tasks.spec("pendulum.swingup", actions=actions)
    assert spec_of_document(json.loads(json.dumps(spec_document(spec)))) == spec


@pytest.mark.parametrize("old", [
    ["cartpole.balance", ["x", "x_dot"], 2, [-2.4, -1.5], [2.4, 1.5]],
    ["cartpole.balance", ["x", "x_dot"], 2, [-2.4, -1.5], [2.4, 1.5], "discrete"],
    {"name": "cartpole.balance", "state_names": ["x", "x_dot"], "num_actions": 2,
     "low": [-2.4, -1.5], "high": [2.4, 1.5], "actions": "discrete"}])
def test_a_task_as_files_before_specs_described_it_reads_as_a_spec(old):
    """Before specs an agent file described its task by name, state names, discrete actions
    and normalisation ranges (a list, or a dict): read, the spec holds those and says it
    knows nothing else (unbounded observation, no timestep, no step limit, no parameters)."""
    spec = spec_of_document(old)
    assert (spec.name, spec.state_names, spec.action) == ("cartpole.balance", ("x", "x_dot"),
                                                          Discrete(2))
    assert spec.ranges == Box((-2.4, -1.5), (2.4, 1.5))
    assert spec.observation == Box((-np.inf,) * 2, (np.inf,) * 2)
    assert np.isnan(spec.control_timestep) and spec.step_limit == np.inf and not spec.parameters


def test_a_continuous_task_before_specs_reads_as_a_box_of_unknown_range():
    spec = spec_of_document({"name": "pendulum.swingup", "state_names": ["a", "w"],
                             "num_actions": 0, "low": [-3.0, -1.5], "high": [3.0, 1.5],
                             "actions": "continuous"})
    assert spec.continuous and spec.action == Box((-np.inf,), (np.inf,))


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
