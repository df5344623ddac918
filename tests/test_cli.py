"""Smoke tests of the `lwrl` command with tiny budgets."""

import subprocess
import sys

import pytest

from experiments import cli


def test_tasks_lists_every_task_and_plant(capsys):
    assert cli.main(["tasks"]) == 0
    out = capsys.readouterr().out
    assert "mountain_car.cost_to_go" in out and "plants: analytic" in out
    assert "pendulum.swingup" in out and "cartpole.balance" in out
    assert out.count("plants: mujoco, analytic") == 2


@pytest.mark.parametrize("argv", [
    ["rollout", "cartpole.balance", "--plant", "mujoco", "--steps", "60", "--seed", "1"],
    ["rollout", "pendulum.swingup", "--plant", "analytic", "--integrator", "explicit", "--steps", "20"],
    ["rollout", "mountain_car.cost_to_go", "--steps", "20"],
])
def test_rollout_prints_a_summary(capsys, argv):
    assert cli.main(argv) == 0
    out = capsys.readouterr().out
    assert "random policy" in out and "episode" in out
    assert ("finished episodes" in out) or ("no episode finished" in out)


def test_rollout_reports_finished_cartpole_episodes(capsys):
    """Random pushes tip the pole within 60 steps: episodes end terminal with return -1."""
    assert cli.main(["rollout", "cartpole.balance", "--steps", "200", "--seed", "0"]) == 0
    out = capsys.readouterr().out
    assert "terminal" in out and "mean return -1.000" in out


@pytest.mark.parametrize("argv, message", [
    (["rollout", "cartpole"], "task must be written DOMAIN.TASK"),
    (["rollout", "cartpole.swing"], "unknown task 'swing'"),
    (["rollout", "mountain_car.cost_to_go", "--plant", "mujoco"], "unknown plant 'mujoco'"),
    (["rollout", "pendulum.swingup", "--steps", "0"], "must be a positive integer"),
    (["frobnicate"], "invalid choice"),
])
def test_bad_input_is_one_line_and_status_2(argv, message):
    """No traceback: one line on standard error naming what is wrong, exit status 2."""
    result = subprocess.run([sys.executable, "-m", "experiments.cli", *argv],
                            capture_output=True, text=True)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], result.stderr


@pytest.mark.parametrize("argv", [["--help"], ["rollout", "--help"], ["tasks", "--help"]])
def test_help(capsys, argv):
    with pytest.raises(SystemExit) as exit_info:
        cli.main(argv)
    assert exit_info.value.code == 0
    assert "usage: lwrl" in capsys.readouterr().out
