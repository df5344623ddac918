"""`lwrl.testing`'s checks where other packages' authors run them: in an environment where the
toy learner (tests/toy_learner) and the toy domain (tests/toy_task) are installed by pip from
their pyproject.toml (`installed_toys`, tests/conftest.py), `check_learner` holds the toy
learner to the learner contract on every task of the suite (the toy domain's too), and
`check_domain` the toy domain to the task contract on each of its tasks and plants."""

import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
CHECKS = """
from lwrl import tasks
from lwrl.testing import check_domain, check_learner
from lwrl_toy.learner import LEARNER
from lwrl_toy_task.toy_mass import DOMAIN

check_domain(DOMAIN)
check_learner(LEARNER)
print(*tasks.TASK_NAMES)
"""


@pytest.mark.slow
def test_the_checks_hold_the_installed_toys(installed_toys, tmp_path):
    path = [*map(str, installed_toys.values()), *filter(None, [os.environ.get("PYTHONPATH")])]
    ran = subprocess.run([sys.executable, "-c", CHECKS], capture_output=True, text=True,
                         cwd=tmp_path, timeout=900,
                         env={**os.environ, "PYTHONPATH": os.pathsep.join(path)})
    assert ran.returncode == 0, ran.stderr[-3000:]
    assert "toy_mass.reach" in ran.stdout.split()
