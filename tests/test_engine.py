"""MuJoCo's step from compiled code (`tasks.engine`) is `mujoco.rollout`'s, bit for bit."""

import mujoco
import numba
import numpy as np
import pytest

from lwrl import models, tasks
from lwrl.tasks.engine import close_workspace, engine_plant, open_workspace, step_state
from lwrl.tasks.plants import MujocoPlant


@numba.njit
def step_states(plant, states, controls, out):
    """`step_state` for each row of `states`, through one workspace."""
    workspace = open_workspace(plant)
    for i in range(states.shape[0]):
        step_state(plant, workspace, states[i], controls[i], out[i])
    close_workspace(plant, workspace)


@pytest.mark.parametrize("domain", [name for name, plants in tasks.PLANTS.items() if "mujoco" in plants])
def test_a_compiled_step_is_rollouts_step(domain):
    """Random states and controls, and states so fast that MuJoCo warns and resets on the
    first of several steps (rollout then stops stepping): the same next states as
    `MujocoPlant`'s `mujoco.rollout` call (without the domain's limit, applied after it)."""
    plants = tasks.domain(domain).plants
    definition = tasks.definition(domain, next(iter(tasks.domain(domain).tasks)))
    model = mujoco.MjModel.from_xml_string(models.read(plants.model))
    rollout = MujocoPlant(model, plants.mujoco_physics.ACTUATOR, 64, plants.substeps)
    plant = engine_plant(plants.model, plants.mujoco_physics.ACTUATOR, plants.substeps)
    rng = np.random.default_rng(0)
    states = rng.normal(scale=3.0, size=(64, len(definition.state_names)))
    states[:4, 1] = [1e11, -1e11, np.nan, 1e300]
    controls = rng.choice(np.asarray(definition.controls), size=64)
    ours = np.empty_like(states)
    step_states(plant, states, controls, ours)
    np.testing.assert_array_equal(ours, rollout.step(states, controls))
