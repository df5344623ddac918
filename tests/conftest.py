"""Shared fixtures: every (domain, task, plant) of the suite's dm_env environments."""

import pytest

from lwrl import tasks

TASK_PLANTS = [(domain, task, plant) for domain, task in tasks.ALL_TASKS
               for plant in tasks.ENVIRONMENT_PLANTS[domain]]


@pytest.fixture(params=TASK_PLANTS, ids=lambda p: f"{p[0]}.{p[1]}-{p[2]}")
def task_plant(request):
    """A `(domain, task, plant)` triple; tests using it run over the whole suite."""
    return request.param


def set_state(env, state):
    """Put a dm_env environment of the suite in `state` (after a reset)."""
    env.reset()
    with env.physics.reset_context():
        env.physics.set_state_vector(state)
