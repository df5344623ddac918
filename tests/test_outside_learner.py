"""A learner from another package joins lwrl through its entry point alone
(`agent.outside_learners`), with no lwrl file edited: the toy package `tests/toy_learner`
(`lwrl_toy`, written against the public learner contract) installed, `lwrl train` and `lwrl
eval` run it and the contract tests of tests/test_learners.py hold it to the contract; a bad
entry point is skipped with one warning line.

The toy is really installed (`installed_toys`, tests/conftest.py: pip, from its
pyproject.toml, into a directory of its own) for the checks that run lwrl with it; the check
of the entry points in this process and the distribution of bad entry points beside it are
written by hand, as an installer writes them: a `.dist-info` directory (METADATA,
entry_points.txt) in a directory on `sys.path`. The checks of an installed learner run in
child processes with that directory on PYTHONPATH: the registry is made once, as
`lwrl.agent` is imported, and read then by other modules (`runners.config`'s choice of
learner, the command's flags), so a learner installed into a process that has imported lwrl
would join it only part way.
"""

import csv
import importlib.metadata
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tomllib
import warnings

import pytest

from lwrl import agent, tasks

ROOT = pathlib.Path(__file__).resolve().parents[1]
TOY = pathlib.Path(__file__).resolve().parent / "toy_learner"
"""The toy package's project: its source (`lwrl_toy/`) and its pyproject.toml."""
WRONG = {"broken": ("lwrl_toy.missing:LEARNER",
                    "fails to import (ModuleNotFoundError: No module named 'lwrl_toy.missing')"),
         "memory": ("lwrl_toy.learner:memory",
                    "names a function, not a Learner (lwrl.agent.learner_contract)"),
         "misnamed": ("lwrl_toy.learner:LEARNER",
                      "names the learner 'toy': an entry point's name must be its learner's"),
         "sarsa": ("lwrl_toy.learner:LEARNER", "takes the name of lwrl.agent.sarsa's learner"),
         "toy": ("lwrl_toy.learner:LEARNER", "takes the name of lwrl_toy.learner's learner")}
"""`{name: (target, what is wrong)}`: the entry points of a distribution `lwrl-wrong`, which
comes after `lwrl-toy` (so its `toy` finds the name taken), in the order of their names."""


def install(site: pathlib.Path, name: str, version: str, entry_points: dict) -> None:
    """Write the metadata of distribution `name` (`{group: {entry point: target}}`) into
    `site`, as an installer does."""
    info = site / f"{name.replace('-', '_')}-{version}.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n")
    (info / "entry_points.txt").write_text("".join(
        f"[{group}]\n" + "".join(f"{point} = {target}\n" for point, target in points.items())
        for group, points in entry_points.items()))


def install_wrong(site: pathlib.Path) -> None:
    install(site, "lwrl-wrong", "0.1",
            {agent.ENTRY_POINT_GROUP: {point: target for point, (target, _) in WRONG.items()}})


def warned_as_expected(messages, group: str = agent.ENTRY_POINT_GROUP, wrong=None) -> bool:
    """The warnings of `wrong` (`WRONG`: entry points of `group` of `lwrl-wrong`), one line
    each, in order."""
    expected = [(f"{group} entry point '{point} = {target}' of lwrl-wrong 0.1 ", problem)
                for point, (target, problem) in (WRONG if wrong is None else wrong).items()]
    return len(messages) == len(expected) and all(
        message.startswith(start) and problem in message and message.endswith("; skipped")
        and "\n" not in message for message, (start, problem) in zip(messages, expected))


@pytest.fixture
def site(tmp_path) -> pathlib.Path:
    """A directory of installed distributions: the toy package, as its pyproject.toml
    declares it."""
    site = tmp_path / "site"
    project = tomllib.loads((TOY / "pyproject.toml").read_text())["project"]
    install(site, project["name"], project["version"], project["entry-points"])
    return site


@pytest.fixture
def installed_site(installed_toys, tmp_path) -> pathlib.Path:
    """A directory of installed distributions: the toy package as pip installed it."""
    site = tmp_path / "installed"
    shutil.copytree(installed_toys["toy_learner"], site)
    return site


@pytest.fixture
def toy_source(monkeypatch):
    """The toy's source importable in this process, and forgotten afterwards."""
    monkeypatch.syspath_prepend(str(TOY))
    yield
    for name in [name for name in sys.modules if name.split(".")[0] == "lwrl_toy"]:
        del sys.modules[name]


def child(site: pathlib.Path, *argv) -> subprocess.CompletedProcess:
    """`python *argv` at the repository's root, with the distributions of `site` installed
    (their packages in it); a pytest it runs takes only its own options (not the caller's
    PYTEST_ADDOPTS, whose --durations listed the toy's tests among its output's lines)."""
    path = [str(site), *filter(None, [os.environ.get("PYTHONPATH")])]
    env = {key: value for key, value in os.environ.items() if key != "PYTEST_ADDOPTS"}
    return subprocess.run([sys.executable, *argv], capture_output=True, text=True, cwd=ROOT,
                          env={**env, "PYTHONPATH": os.pathsep.join(path)}, timeout=900)


def admitted(site: pathlib.Path, group: str, outside, registry: dict) -> tuple[dict, list]:
    """`(what it admits, the messages it warns)` of `outside(registry, entry points)`
    (`agent.outside_learners`, `tasks.outside_domains`) over the entry points of `group`
    that the distributions installed in `site` declare; `registry` is left as it was."""
    points = [point for dist in importlib.metadata.distributions(path=[str(site)])
              for point in dist.entry_points if point.group == group]
    registered = dict(registry)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        found = outside(registry, points)
    assert registry == registered
    return found, [str(warning.message) for warning in caught]


def test_bad_entry_points_are_skipped_with_one_warning_line_each(site, toy_source):
    """From the installed distributions' own entry points: the toy joins; each bad one is
    skipped with one line naming it, its distribution and what is wrong, in the order of
    their names; the registry it is added beside is left as it was."""
    install_wrong(site)
    found, messages = admitted(site, agent.ENTRY_POINT_GROUP, agent.outside_learners,
                               agent.LEARNERS)
    from lwrl_toy import learner as toy

    assert found == {"toy": toy.LEARNER}
    assert warned_as_expected(messages)


@pytest.mark.slow
def test_an_installed_learner_joins_the_registry_as_lwrl_agent_is_imported(installed_site):
    """After lwrl's own learners; the bad entry points warn then, and `-W` makes them errors."""
    install_wrong(installed_site)
    shown = child(installed_site, "-c", "from lwrl import agent; print(*agent.LEARNER_NAMES)")
    assert shown.returncode == 0, shown.stderr
    assert shown.stdout.split() == [*agent.LEARNER_NAMES, "toy"]
    assert warned_as_expected([line.split("UserWarning: ", 1)[1]
                               for line in shown.stderr.splitlines() if "UserWarning: " in line])
    strict = child(installed_site, "-W", f"error:{agent.ENTRY_POINT_GROUP} entry point", "-c",
                   "import lwrl.agent")
    assert strict.returncode == 1
    assert "UserWarning: lwrl.learners entry point 'broken" in strict.stderr


@pytest.mark.slow
def test_lwrl_train_and_eval_run_the_installed_learner(installed_site, tmp_path):
    """`lwrl train --learner toy` (with a flag of the toy's own settings) writes what every
    run writes, and `lwrl eval` runs the agents it saved."""
    out, saved = tmp_path / "run", tmp_path / "agents.npz"
    trained = child(installed_site, "-m", "lwrl.cli", "train", "mountain_car.cost_to_go",
                    "--learner", "toy", "--cells", "5", "--agents", "2", "--episodes", "2",
                    "--out", str(out), "--save", str(saved))
    assert trained.returncode == 0, trained.stderr
    assert "toy tabular Sarsa(0) over 5^2 cells" in trained.stdout
    config = json.loads((out / "config.json").read_text())
    assert config["learner"] == "toy"
    assert config["settings"] == {"alpha": 0.5, "epsilon": 0.05, "gamma": 1.0, "cells": 5}
    with open(out / "episodes.csv") as file:
        rows = list(csv.DictReader(file))
    assert len(rows) == 4 and {"agent", "episode", "steps", "return"} <= set(rows[0])
    evaluated = child(installed_site, "-m", "lwrl.cli", "eval", str(saved), "--episodes", "1")
    assert evaluated.returncode == 0, evaluated.stderr
    assert "2 saved agents, greedy" in evaluated.stdout


@pytest.mark.slow
def test_the_contract_tests_hold_the_installed_learner(installed_site):
    """tests/test_learners.py parametrises over the registry as it collects: with the toy
    installed, each of its checks over (learner, task) takes the toy on every task, and its
    checks of the registry take it too."""
    ran = child(installed_site, "-m", "pytest", "tests/test_learners.py", "-v", "-p",
                "no:cacheprovider", "-k", "toy or registry_names or settings_shared")
    assert ran.returncode == 0, ran.stdout[-3000:]
    toy = [line.split("::")[1] for line in ran.stdout.splitlines() if "[toy-" in line]
    assert toy and all(" PASSED" in line for line in toy)
    assert {line.split("[toy-")[1].split("]")[0] for line in toy} == set(tasks.TASK_NAMES)
    assert "test_the_registry_names_each_learner_once PASSED" in ran.stdout
