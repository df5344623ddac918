"""Shared fixtures: every (domain, task, plant) of the suite's dm_env environments, and
physical parameter values away from the paper's."""

import numpy as np
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


def off_nominal(domain: str, rng: np.random.Generator, count=None) -> np.ndarray:
    """Physical parameter values of `domain` away from the paper's: each nominal value times
    2^u, u ~ U[-1, 1] drawn for each, within the accepted range; `(count, P)` rows, or one
    vector `(P,)` where `count` is None."""
    parameters = tasks.domain(domain).parameters
    nominal = np.asarray(parameters.nominal)
    values = nominal * 2.0 ** rng.uniform(-1, 1, size=nominal.shape if count is None
                                          else (count, len(nominal)))
    return np.clip(values, [p.low for p in parameters.items], [p.high for p in parameters.items])
