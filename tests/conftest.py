"""Shared fixtures: every (domain, task, plant) of the suite's dm_env environments, physical
parameter values away from the paper's, a command run in this process, an OpenGL
backend that renders headless; and the check that a call is refused in one line."""

import os
import re
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


# The quick loop -------------------------------------------------------------------------
# `pytest -m "not slow"` leaves out the tests below and runs in well under a minute on a
# 2-core machine once the compiled kernels are cached (~/.cache/lwrl/kernels; a first run
# compiles them); plain `pytest`, the README's command and CI's, runs every test. Each key
# is a regular expression matched from the start of a test's id below tests/
# ("test_file.py::test_name[parameters]"); its value says why those tests are slow. Every
# module these leave out is still exercised by faster tests of the loop.

DEEP = r"(dqn|ppo|dqn_jax|ppo_jax)"
"""The learners of neural networks (PyTorch, JAX): seconds a run where the others take
milliseconds."""

SLOW = {
    # Tools outside Python.
    r"test_wheel\.py::": "builds the wheel and installs it into a fresh virtual environment",
    r"test_web_viewer\.py::": "starts headless Chromium",
    r"[^:]*::[^\[]*chromium": "starts headless Chromium",
    r"test_docs_site\.py::test_the_site_builds_strictly": "builds the documentation site (mkdocs)",
    r"test_typing\.py::test_mypy_": "runs mypy on the package",
    r"test_device\.py::(test_the_emulated_cortex_m4_|test_costs_are_measured_on_both_"
    r"|test_libm_agreement)": "cross-compiles for the Cortex-M4 and runs it under QEMU",
    r"test_reproduce\.py::test_ray_backend": "starts a local Ray instance",
    r"test_robustness\.py::test_a_study_on_ray": "starts a local Ray instance",
    # Compiling afresh, in fresh processes (the quick loop keeps one damaged-cache case).
    r"test_kernels\.py::(test_a_second_process_compiles_nothing|test_cached_kernels_compute_)":
        "three processes compile the learning loops into empty caches",
    r"test_kernel_cache\.py::test_a_damaged_cache_file_is_compiled_again_and_replaced"
    r"\[(?!index-garbage\])": "two processes each; index-garbage stays in the quick loop",
    r"test_kernel_cache\.py::(test_a_process_killed_while_writing|test_training_heals)":
        "processes compiling into empty caches; `lwrl train` compiling its loop",
    # JIT-compiling MJX and JAX programs.
    r"test_mjx_plant\.py::test_mjx_agrees_with_the_c_engine_from_the_tasks_starts":
        "compiles MJX's step for each model",
    r"test_parameters\.py::test_the_mjx_plant_takes_one_set_of_values": "compiles MJX's step",
    r"test_population\.py::test_one_(ppo|dqn)_update_is_sb3s_train":
        "compiles a JAX update and trains SB3's model beside it",
    r"test_jax_peer\.py::(test_the_peer_learns_mountain_car|test_the_peer_updates_as_lwrls_"
    r"learner_step_by_step\[cartpole)": "compiles and runs the JAX peer's learning",
    # The learner contract for the network learners: each keeps its cheapest task,
    # cartpole.balance (its episodes end soonest), in the quick loop; dqn_jax none.
    rf"test_learners\.py::[^\[]*\[{DEEP}-(?!cartpole)": "trains networks over long episodes",
    r"test_learners\.py::[^\[]*\[dqn_jax-": "compiles and trains a JAX population of networks",
    rf"test_robustness\.py::test_every_learner_goes_on_with_its_kept_agents[^\[]*\[{DEEP}_jax":
        "compiles and trains a JAX population of networks",
    # Learning runs and whole commands.
    r"test_acrobot\.py::(test_train_command_smoke|test_agents_learn_to_swing_up)":
        "trains agents on the acrobot",
    r"test_ase_ace\.py::test_it_learns_to_balance": "trains agents on the cart-pole",
    r"test_learner_c\.py::(test_float_learner_learns_within|test_double_learner_is_the_python_"
    r"learner_bit_for_bit\[(pendulum|cartpole))": "trains agents in C and in Python",
    r"test_outputs\.py::test_ctrl_c_stops_the_work": "trains in a child process for seconds",
    r"test_claims\.py::test_two_trainings_aimed_at_one_directory": "two trainings in processes",
    r"test_robustness\.py::test_lwrl_robustness_writes_its_report": "a robustness study",
    r"test_reproduce\.py::(test_a_killed_sweep_resumes|test_quick_reproduction_writes)":
        "a reproduction sweep",
    r"test_config\.py::test_reproduce_sets_readings_from_the_command_line": "a reproduction sweep",
    r"test_compare\.py::(test_quick_cli_run_writes|test_recording_holds_an_entity)":
        "`lwrl compare --quick`",
    r"test_bench\.py::test_lwrl_bench_writes_its_report": "a benchmark study",
    r"test_benchmarks\.py::test_\w+_quick_prints_its_table": "a quick benchmark",
    r"test_gymnasium_envs\.py::test_observations_stay_inside_the_box\[lwrl/cartpole-":
        "rolls out ten policies over long cart-pole episodes",
}
SLOW_TESTS = re.compile("|".join(f"(?:{pattern})" for pattern in SLOW))


def pytest_collection_modifyitems(config, items):
    """Mark `slow` the tests that SLOW names."""
    root = config.rootpath / "tests"
    for item in items:
        name = item.path.relative_to(root).as_posix() + "::" + item.name
        if SLOW_TESTS.match(name):
            item.add_marker(pytest.mark.slow)
