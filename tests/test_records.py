"""What every run records beside its episodes (`runners.records`): each agent's share of its
batch's CPU of training, at each checkpoint of a family the CPU spent up to it; the counted
arithmetic of the steps it took; where it ran (lwrl's version and commit, the CPU, Python's
and the libraries' versions); and a run written before the records reads as not recorded."""

import platform
import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest

import lwrl
from lwrl import agent as learners
from lwrl.runners import records, sweep
from lwrl.runners.config import RunConfig
from lwrl.runners.store import RunStore, cpu, ledger_lines


def grid():
    """Three one-agent Mountain-Car runs that `sweep.batches` joins into one batch."""
    return [RunConfig(task="mountain_car.cost_to_go", alpha=alpha, agents=1, episodes=2, seed=4)
            for alpha in (0.5, 1.0, 2.0)]


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """The grid swept once: its directory and its runs' tables."""
    directory = tmp_path_factory.mktemp("swept")
    table, computed = sweep.run_sweep(grid(), directory)
    assert computed == 3
    return directory, table


def test_a_sweep_records_each_agent_s_share_of_its_batch_s_cpu(swept):
    directory, table = swept
    read = records.read(directory, grid())
    assert list(read.columns) == [*records.COLUMNS, "recorded"] and read["recorded"].all()
    assert list(read["run"]) == [config.key for config in grid()]
    steps = table.groupby("run", sort=False)["steps"].sum()
    np.testing.assert_array_equal(read["steps"], steps.loc[read["run"]])
    assert (read["cpu_shared_by"] == 3).all()  # the three runs' agents were one batch
    assert read["cpu_s"].nunique() == 1 and read["cpu_s"].iloc[0] > 0
    batch_cpu = read["cpu_s"].iloc[0] * 3
    (line,) = ledger_lines(directory)  # the whole batch, its writing among it
    assert batch_cpu <= line["cpu_s"] + 1e-3
    assert_counted(directory, grid())


def test_a_run_records_where_it_ran(swept):
    directory, _ = swept
    read = records.read(directory, grid())
    assert (read["lwrl_version"] == lwrl.__version__).all()
    assert (read["host_cpu"] == cpu()).all()
    assert (read["python"] == platform.python_version()).all()
    libraries = read["libraries"].iloc[0]
    assert libraries.startswith("numpy ") and "; numba " in libraries


def test_provenance_names_the_commit_of_the_checkout(swept):
    root = records.pathlib.Path(lwrl.__file__).resolve().parent.parent
    if not (root / ".git").exists() or shutil.which("git") is None:
        pytest.skip("lwrl does not run from a git checkout here")
    head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                          text=True, check=True).stdout.strip()
    commit = records.read(swept[0], grid())["lwrl_commit"].iloc[0]
    assert commit in (head, head + "+modified")


def test_a_changed_source_marks_the_commit_modified_and_an_output_does_not(tmp_path,
                                                                              monkeypatch):
    if shutil.which("git") is None:
        pytest.skip("no git here")
    git = lambda *words: subprocess.run(["git", "-C", str(tmp_path), *words], check=True,
                                        capture_output=True, text=True).stdout.strip()
    (tmp_path / "lwrl").mkdir()
    (tmp_path / "lwrl" / "__init__.py").write_text("")
    git("init", "-q")
    git("add", ".")
    git("-c", "user.name=lwrl", "-c", "user.email=lwrl@example.org", "commit", "-qm", "first")
    monkeypatch.setattr(lwrl, "__file__", str(tmp_path / "lwrl" / "__init__.py"))
    head = git("rev-parse", "HEAD")
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "run.csv").write_text("a study's output\n")
    assert records.commit.__wrapped__() == head
    (tmp_path / "lwrl" / "new.py").write_text("")
    assert records.commit.__wrapped__() == head + "+modified"


def test_a_package_outside_a_checkout_names_no_commit(tmp_path, monkeypatch):
    (tmp_path / "lwrl").mkdir()
    monkeypatch.setattr(lwrl, "__file__", str(tmp_path / "lwrl" / "__init__.py"))
    assert records.commit.__wrapped__() == records.UNKNOWN


def test_a_run_written_before_the_records_reads_as_not_recorded(tmp_path):
    configs = grid()[:2]
    sweep.run_sweep(configs, tmp_path)
    RunStore.records_file(tmp_path, configs[0].key).unlink()  # as the second benchmark's runs
    read = records.read(tmp_path, configs)
    assert list(read["recorded"]) == [False, True]
    old = read.iloc[0]
    assert old["run"] == configs[0].key and old["seed"] == configs[0].seeds[0]
    assert old[["steps", "cpu_s", "cpu_shared_by", "multiply_adds", "lwrl_commit"]].isna().all()
    _, computed = sweep.run_sweep(configs, tmp_path)  # its table stands: the run is finished
    assert computed == 0


@pytest.fixture(scope="module")
def family(tmp_path_factory):
    """ARS (a population learner with counts) at three budgets, computed as one run whose
    smaller budgets are its checkpoints: its directory and configurations."""
    pytest.importorskip("jax", reason="ARS needs the jax extra: pip install 'lwrl[jax]'")
    from lwrl.runners.population import CHUNK
    directory = tmp_path_factory.mktemp("family")
    configs = [RunConfig(task="mountain_car.cost_to_go", learner="ars", agents=3, episodes=100,
                         seed=1, task_options={"time_limit": 200.0}, directions=2,
                         delta_std=0.5, learning_rate=0.1, budget=budget)
               for budget in (300, CHUNK, 3 * CHUNK + 77)]
    assert len(sweep.families(configs)) == 1
    _, computed = sweep.run_sweep(configs, directory, keep_agents=True)
    assert computed == 3
    return directory, configs


def test_the_cpu_grows_along_a_family_s_checkpoints(family):
    directory, configs = family
    read = records.read(directory, configs)
    at = read.groupby("run", sort=False)["cpu_s"]
    assert (at.nunique() == 1).all()  # one share for every agent of a run
    shares = at.first().loc[[config.key for config in configs]].to_numpy()
    assert shares[0] > 0 and np.all(np.diff(shares) >= 0)
    assert (read["cpu_shared_by"] == 3).all()
    (line,) = ledger_lines(directory)
    assert shares[-1] * 3 <= line["cpu_s"] + 1e-3


def assert_counted(directory, configs):
    """Each agent's counted arithmetic is its learner's count per agent-step of learning
    (`Learner.arithmetic` for the steps it took, read from its run's table) times those
    steps."""
    read = records.read(directory, configs).set_index(["run", "agent"])
    tables = RunStore(directory).read(configs)
    for config in configs:
        arithmetic = learners.learner(config.learner).arithmetic
        steps = tables[tables["run"] == config.key].groupby("agent")["steps"].sum()
        for agent, taken in steps.items():
            row = read.loc[(config.key, agent)]
            step = arithmetic(config.settings, config.task_spec, int(taken)).step
            assert row["steps"] == taken
            assert row["multiply_adds"] == pytest.approx(step.macs * taken, rel=1e-12)
            assert row["transcendentals"] == pytest.approx(step.exps * taken, rel=1e-12)
            assert row["multiply_adds"] > 0


def test_the_arithmetic_is_the_learner_s_count_of_the_steps_taken(family):
    directory, configs = family
    tables = RunStore(directory).read(configs)
    for config in configs:  # every agent spent its budget
        steps = tables[tables["run"] == config.key].groupby("agent")["steps"].sum()
        np.testing.assert_array_equal(steps, config.budget)
    assert_counted(directory, configs)


def test_settings_without_a_count_record_none(tmp_path):
    """CMAC features have no count (`NotCounted`): their arithmetic is missing, not 0."""
    config = RunConfig(task="mountain_car.cost_to_go", features="cmac", agents=2, episodes=1)
    sweep.run_sweep([config], tmp_path)
    read = records.read(tmp_path, [config])
    assert read[["multiply_adds", "transcendentals"]].isna().all().all()
    assert (read["cpu_s"] > 0).all() and read["recorded"].all()
