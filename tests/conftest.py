"""Shared fixtures: every (domain, task, plant) of the suite's dm_env environments; a command
run in this process."""

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


def run_cli(argv, capsys):
    """`(status, stdout, stderr lines)` of the command, in this process."""
    try:
        status = cli.main(argv)
    except SystemExit as exit_:
        status = exit_.code
    captured = capsys.readouterr()
    return status, captured.out, captured.err.strip().splitlines()
