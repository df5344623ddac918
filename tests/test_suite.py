"""The suite's contract, checked over every task and plant (SPEC.md, tasks 1-3) through the
checks lwrl ships (`lwrl.testing`); what is about lwrl's own domains (their names and options
refused) and the compiled loops' transition stay here."""

import dataclasses

import numba
import numpy as np
import pytest

from lwrl import tasks, testing
from conftest import off_nominal


def test_spec_conformance(task_plant):
    testing.check_task_spec(*task_plant)


def test_each_action_applies_its_control(task_plant):
    testing.check_task_actions_apply_controls(*task_plant)


def test_deterministic_for_a_seed(task_plant):
    testing.check_task_deterministic(*task_plant)


def test_starts_are_the_tasks_and_follow_the_seed(task_plant):
    testing.check_task_starts(*task_plant)


def test_time_limits_truncate(task_plant):
    testing.check_task_time_limit(*task_plant)


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


def test_bad_action_is_refused(task_plant):
    """An action index out of range, or not one integer, raises naming the allowed range."""
    testing.check_task_refuses_bad_actions(*task_plant)


def test_nan_state_is_refused(task_plant):
    """A NaN given to a plant raises, naming the state variables; a state of the wrong length
    says how many entries the pendulum's has."""
    _, _, plant = task_plant
    testing.check_task_refuses_nan_state(*task_plant)
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
    low, high = map(np.asarray, definition.ranges)
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

def test_a_broken_contract_is_one_line_naming_the_domain_the_task_and_the_check(monkeypatch):
    """A task whose plant takes a NaN state breaks the contract: the check says so in one line
    naming the domain, the task, the plant and the check; a domain that is not the registry's
    is refused as such."""
    domain, task, plant = "mountain_car", "cost_to_go", "analytic"
    env = tasks.load(domain, task, plant=plant)
    monkeypatch.setattr(type(env.physics), "set_state_vector", lambda physics, state: None)
    with pytest.raises(testing.ContractError) as error:
        testing.check_task_refuses_nan_state(domain, task, plant)
    assert str(error.value) == (f"domain {domain!r}, task {task!r} on the {plant} plant: "
                                f"check_task_refuses_nan_state: a NaN state is taken")
    stranger = dataclasses.replace(tasks.domain(domain))
    with pytest.raises(testing.ContractError, match="not in lwrl's registry; declare its DOMAIN "
                                                    "under the entry-point group 'lwrl.tasks'"):
        testing.check_domain(stranger)


def test_check_domain_runs_every_check_on_every_task_and_plant(monkeypatch):
    """`check_domain` checks the declaration, then each task on each plant of a single
    environment with each of `TASK_CHECKS`."""
    checks, called = testing.TASK_CHECKS, []
    monkeypatch.setattr(testing, "TASK_CHECKS", tuple(
        lambda *case, check=check: called.append((check.__name__, *case)) for check in checks))
    testing.check_domain(tasks.domain("cartpole"))
    assert called == [(check.__name__, "cartpole", task, plant)
                      for task in tasks.domain("cartpole").tasks
                      for plant in tasks.ENVIRONMENT_PLANTS["cartpole"] for check in checks]
    assert len(checks) == 9
