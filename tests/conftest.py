"""Shared fixtures: every (domain, task, plant) of the suite's dm_env environments, physical
parameter values away from the paper's, a command run in this process, an OpenGL
backend that renders headless; and the check that a call is refused in one line."""

import os
import subprocess
import sys

import numpy as np
import pytest

from lwrl import tasks
from lwrl.cli import main as cli

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


def one_step(domain, task, state, action, **options):
    """The analytic plant's state after `action` from `state`."""
    env = tasks.load(domain, task, plant="analytic", **options)
    env.reset()
    set_state(env, state)
    env.step(action)
    return env.physics.state_vector()


def off_nominal(domain: str, rng: np.random.Generator, count=None) -> np.ndarray:
    """Physical parameter values of `domain` away from the paper's: each nominal value times
    2^u, u ~ U[-1, 1] drawn for each, within the accepted range; `(count, P)` rows, or one
    vector `(P,)` where `count` is None."""
    parameters = tasks.domain(domain).parameters
    nominal = np.asarray(parameters.nominal)
    values = nominal * 2.0 ** rng.uniform(-1, 1, size=nominal.shape if count is None
                                          else (count, len(nominal)))
    return np.clip(values, [p.low for p in parameters.items], [p.high for p in parameters.items])


def run_cli(argv, capsys):
    """`(status, stdout, stderr lines)` of the command, in this process."""
    try:
        status = cli.main(argv)
    except SystemExit as exit_:
        status = exit_.code
    captured = capsys.readouterr()
    return status, captured.out, captured.err.strip().splitlines()


OPENGL_PROBE = ("from dm_control import mujoco\n"
                "physics = mujoco.Physics.from_xml_string('<mujoco><worldbody><light pos=\"0 0 1\"/>"
                "<geom size=\"0.1\"/></worldbody></mujoco>')\n"
                "assert physics.render(16, 16).std() > 0\n")


@pytest.fixture(scope="session")
def opengl():
    """`MUJOCO_GL` of a backend that renders headless here (EGL, else OSMesa), for child
    processes; skips the test where there is none."""
    for backend in ("egl", "osmesa"):
        probe = subprocess.run([sys.executable, "-c", OPENGL_PROBE], capture_output=True,
                               env={**os.environ, "MUJOCO_GL": backend}, timeout=120)
        if probe.returncode == 0:
            return backend
    pytest.skip("no headless OpenGL here: apt-get install libegl1 libegl-mesa0 "
                "libgl1-mesa-dri (EGL) or libosmesa6 (OSMesa)")


def one_line_error(call, *fragments):
    """`call()` raises a one-line ValueError holding each of `fragments`."""
    with pytest.raises(ValueError) as error:
        call()
    message = str(error.value)
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, message
