"""Hardware in the loop over the device link (`export.hil`): the C learner, built for the
host in double and answering over the link, learns what lwrl's own learner learns, step
for step, on the analytic plant and on MuJoCo's."""

import subprocess

import numpy as np
import pytest

from lwrl import tasks
from lwrl.export.hil import build_host_program, run_session
from lwrl.export.link import HostLink, PipePort
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agent, run_dm_env


@pytest.mark.parametrize("task, plant, episodes", [("mountain_car.cost_to_go", "analytic", 3),
                                                   ("pendulum.swingup", "mujoco", 2)])
def test_the_device_learns_over_the_link_what_lwrl_learns(task, plant, episodes, tmp_path):
    """The same agent (seed 3) on the same episodes (environment seed 11): every episode's
    steps, return and up-time equal lwrl's learner's in its own loop (`run_dm_env`); no
    deadline was missed and every byte is counted."""
    command = build_host_program(task, tmp_path, seed=3)
    device = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    try:
        link = HostLink(PipePort(device), timeout=5.0)
        session = run_session(link, task, episodes, seed=11, plant=plant)
    finally:
        device.kill()
        device.wait()
    domain, name = tasks.split_name(task)
    agent = make_agent(RunConfig(task=task, agents=1, seed=3))
    own = run_dm_env(tasks.load(domain, name, plant=plant, seed=11), agent, episodes)
    np.testing.assert_array_equal(session.steps, own.steps[0])
    np.testing.assert_array_equal(session.returns, own.returns[0])
    np.testing.assert_array_equal(session.uptime, own.uptime[0])  # NaN where a task has none
    assert session.held == 0 and link.counts.missed == 0
    assert link.counts.answered == sum(session.steps) + episodes


def test_duplicated_observations_teach_the_device_nothing_twice(tmp_path):
    """Observations written twice on the link: the device answers the copy with the same
    action and learns from it nothing, so the session is still lwrl's learner's, step for
    step; the copies' answers are counted as duplicates."""
    from tests.test_link import FaultyPort

    task = "mountain_car.cost_to_go"
    command = build_host_program(task, tmp_path, seed=3)
    device = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    try:
        port = FaultyPort(PipePort(device), {step: "duplicate" for step in (0, 5, 77)})
        link = HostLink(port, timeout=5.0)
        session = run_session(link, task, 2, seed=11)
    finally:
        device.kill()
        device.wait()
    agent = make_agent(RunConfig(task=task, agents=1, seed=3))
    own = run_dm_env(tasks.load("mountain_car", "cost_to_go", seed=11), agent, 2)
    np.testing.assert_array_equal(session.steps, own.steps[0])
    assert link.counts.exchanges > 78 and link.counts.duplicates == 3


def test_lwrl_device_hil_prints_the_episodes_and_the_link(capsys):
    from lwrl.cli.main import main

    assert main(["device", "hil", "mountain_car.cost_to_go", "--episodes", "2", "--seed", "3",
                 "--env-seed", "11"]) == 0
    out = capsys.readouterr().out
    assert "on the analytic plant (seed 11)" in out and "0 missed deadlines" in out
    assert out.count("\n      ") >= 2 and "baud at one step per" in out
    assert main(["device", "hil", "mountain_car.cost_to_go", "--timeout", "0"]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "--timeout must be a positive number" in error[0]


@pytest.mark.skipif(bool(__import__("lwrl.export.device", fromlist=["missing_tools"]).missing_tools()),
                    reason="needs gcc-arm-none-eabi, libnewlib-arm-none-eabi and qemu-system-arm")
def test_the_emulated_board_learns_over_its_uart_what_the_host_build_learns(tmp_path):
    """The float learner on the emulated Cortex-M4, its UART the link, against the same
    program built for the host, on MuJoCo's pendulum (2 episodes of 4 s: the emulated UART
    takes about 10 ms a round trip): the same steps, returns and up-times in every episode
    (the device's expf is newlib's, the host's glibc's; they agree on these episodes)."""
    from lwrl.export.hil import build_emulated_program

    task, plant, options, sessions = "pendulum.swingup", "mujoco", {"time_limit": 4.0}, []
    for build, target in ((tmp_path / "host", build_host_program),
                          (tmp_path / "m4", build_emulated_program)):
        build.mkdir()
        device = subprocess.Popen(target(task, build, seed=3, dtype="float"),
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                  stderr=subprocess.DEVNULL)
        try:
            link = HostLink(PipePort(device), timeout=5.0)
            sessions.append(run_session(link, task, 2, seed=11, plant=plant, **options))
        finally:
            device.kill()
            device.wait()
        assert link.counts.missed == 0 and link.counts.late == 0
    host, emulated = sessions
    assert emulated.steps == host.steps and emulated.returns == host.returns
    np.testing.assert_array_equal(emulated.uptime, host.uptime)
