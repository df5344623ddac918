"""The ecosystem's conventions: dm_control's spelling of `load`, named cameras and headless
pixels, and the `lwrl` namespace as users import it."""

import os
import subprocess
import sys

import mujoco
import numpy as np
import pytest

import lwrl
from lwrl import models, tasks

MUJOCO_TASKS = [(domain, task) for domain, task in tasks.ALL_TASKS if tasks.domain(domain).model]


def test_load_takes_dm_controls_spelling():
    """`task_kwargs={"random": seed}` seeds like `seed=`, task options ride along, and
    `environment_kwargs` reach `control.Environment`."""
    ours = tasks.load("pendulum", "swingup", plant="analytic", seed=3)
    theirs = tasks.load("pendulum", "swingup", plant="analytic",
                        task_kwargs={"random": 3, "time_limit": 1.0})
    np.testing.assert_array_equal(ours.reset().observation["angle"], theirs.reset().observation["angle"])
    assert theirs.task.definition.step_limit == 50
    flat = tasks.load("cartpole", "balance", environment_kwargs={"flat_observation": True})
    observation = flat.reset().observation
    assert list(observation) == ["observations"] and observation["observations"].shape == (4,)
    with pytest.raises(ValueError, match="give the seed once"):
        tasks.load("pendulum", "swingup", seed=1, task_kwargs={"random": 1})
    with pytest.raises(ValueError, match="unknown option 'gravity'"):
        tasks.load("pendulum", "swingup", task_kwargs={"gravity": 1.0})


@pytest.mark.parametrize("name", models.names())
def test_every_model_has_two_named_cameras(name):
    model = mujoco.MjModel.from_xml_string(models.read(name))
    names = [model.camera(i).name for i in range(model.ncam)]
    assert len(names) >= 2 and all(names), names


RENDER = """
import numpy as np
from lwrl import tasks
env = tasks.load({domain!r}, {task!r}, plant="mujoco", seed=0)
env.reset()
for camera in range(env.physics.model.ncam):
    pixels = env.physics.render(48, 64, camera_id=camera)
    assert pixels.shape == (48, 64, 3) and pixels.dtype == np.uint8, pixels.shape
    assert pixels.std() > 1.0, "a blank picture"
print("rendered")
"""


@pytest.mark.parametrize("domain, task", MUJOCO_TASKS)
def test_physics_renders_pixels_headless(opengl, domain, task):
    """`env.physics.render(height, width, camera_id)` gives a picture from every camera."""
    result = subprocess.run([sys.executable, "-c", RENDER.format(domain=domain, task=task)],
                            env={**os.environ, "MUJOCO_GL": opengl}, capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 0 and "rendered" in result.stdout, result.stderr[-2000:]


def test_the_namespace_imports_its_rooms_on_first_use():
    assert lwrl.tasks is tasks and lwrl.models is models
    assert set(lwrl.SUBPACKAGES) <= set(dir(lwrl))
    with pytest.raises(AttributeError, match="has no attribute 'experiments'"):
        lwrl.experiments
