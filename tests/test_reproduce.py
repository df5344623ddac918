"""Sweeps and the paper's reproduction: resumable, complete, on each backend."""

import importlib.util
import json
import os
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

from lwrl.agent import jax_population
from lwrl.runners import sweep
from lwrl.runners.config import RunConfig
from lwrl.runners.store import RunStore
from lwrl.studies.paper.items import ITEMS
from lwrl.studies.paper.reproduce import reproduce

SWEEP_SCRIPT = """
import sys
from lwrl.runners import sweep
from lwrl.runners.config import RunConfig
configs = [RunConfig(task="mountain_car.cost_to_go", plant="analytic", trace=trace, alpha=alpha,
                     lam=0.9, agents=10, episodes=30, seed=seed)
           for trace in ("replacing", "accumulating") for alpha in (0.5, 2.0) for seed in (0, 10, 20, 30)]
sweep.run_sweep(configs, sys.argv[1])[0].to_csv(sys.argv[2], index=False)
"""
"""16 runs of Mountain-Car agents, each a fraction of a second: a sweep to interrupt."""


def run_script(out_dir, table_path):
    return subprocess.Popen([sys.executable, "-c", SWEEP_SCRIPT, str(out_dir), str(table_path)],
                            stderr=subprocess.DEVNULL)


def test_a_killed_sweep_resumes_to_the_same_results(tmp_path):
    """Kill a sweep (SIGKILL) after some runs have finished; the same command then runs only
    the rest, and the results equal an uninterrupted sweep's."""
    runs_dir = tmp_path / "killed" / "runs"
    child = run_script(tmp_path / "killed", tmp_path / "never.csv")
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and child.poll() is None:
        finished = [name for name in os.listdir(runs_dir)] if runs_dir.exists() else []
        if len([n for n in finished if n.endswith(".csv.gz")]) >= 3:
            break
        time.sleep(0.02)
    child.kill()
    child.wait()
    done_before = sorted(n for n in os.listdir(runs_dir) if n.endswith(".csv.gz"))
    assert 3 <= len(done_before) < 16, "the sweep should be killed mid-way"
    stamps = {name: os.stat(runs_dir / name).st_mtime_ns for name in done_before}
    assert run_script(tmp_path / "killed", tmp_path / "resumed.csv").wait() == 0
    assert all(os.stat(runs_dir / name).st_mtime_ns == stamp for name, stamp in stamps.items()), \
        "finished runs must not be recomputed"
    assert run_script(tmp_path / "whole", tmp_path / "whole.csv").wait() == 0
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "resumed.csv"), pd.read_csv(tmp_path / "whole.csv"))


def test_quick_reproduction_writes_every_item(tmp_path):
    """`lwrl reproduce all --quick --agents-per-cell 3`: a report with every item and a
    verdict, the figures in PNG and SVG, per item a tidy results table with the configuration
    on every row, and the confirmation runs of the items that take them beside the rest."""
    report = reproduce("all", str(tmp_path), quick=True, agents_per_cell=3)
    text = open(report).read()
    for name, item in ITEMS.items():
        assert item.title in text
        assert os.path.exists(tmp_path / name / "results.csv.gz")
        assert os.path.exists(tmp_path / name / "configs.jsonl")
        assert os.path.exists(tmp_path / name / "confirmation.csv.gz") == (item.confirm is not None)
    confirmation = pd.read_csv(tmp_path / "fig8" / "confirmation.csv.gz")
    assert sorted(confirmation["seed"].unique()) == [2, 3, 4]  # fresh: the run's own are 0, 1
    assert "| quantity | ours, paper-sized run | ours, confirmation run | paper |" in text
    assert "The paper: “" in text and "Judged on: " in text
    for name in ("fig2", "fig3", "fig5", "fig6", "fig8"):
        assert os.path.exists(tmp_path / "figures" / f"{name}.png")
        assert os.path.exists(tmp_path / "figures" / f"{name}.svg")
    table = pd.read_csv(tmp_path / "fig2" / "results.csv.gz")
    assert {"task", "plant", "features", "trace", "alpha", "lam", "agent", "seed", "episode",
            "steps", "return", "uptime_s", "diverged"} <= set(table.columns)
    assert set(table["features"]) == {"nrbf", "cmac"}
    assert "Readings of SPEC.md's open points" in text and "| fig8 |" in text
    # Beside the paper's traces: true online Sarsa(lambda) on Fig. 6 and 8's grids, and the
    # rival Table 1 quotes, run under the same protocol, each with its fresh agents.
    assert set(pd.read_csv(tmp_path / "fig6" / "results.csv.gz")["trace"]) == {
        "replacing", "accumulating", "dutch"}
    assert "probability of improvement of dutch over replacing" in text
    assert "ASE/ACE (Barto, Sutton and Anderson 1983, their constants): episode by which" in text
    assert "| 80 (Barto et al., as Table 1 quotes them) |" in text
    table1 = pd.read_csv(tmp_path / "table1" / "confirmation.csv.gz")
    assert sorted(table1[table1["learner"] == "ase_ace"]["seed"].unique()) == [2, 3, 4]


def test_unknown_item_and_backend():
    with pytest.raises(ValueError, match="unknown item 'fig4'; allowed: fig2, fig3"):
        reproduce("fig4", "unused")
    with pytest.raises(ValueError, match="agents per cell must be at least 2"):
        reproduce("fig5", "unused", agents_per_cell=1)
    with pytest.raises(ValueError, match="unknown backend 'spark'; allowed: local, ray"):
        sweep.run_sweep([], "unused", backend="spark")


@pytest.mark.skipif(importlib.util.find_spec("ray") is None,
                    reason="Ray is an optional extra: pip install -e '.[ray]' to run this test")
def test_ray_backend_gives_the_local_results(tmp_path):
    """The same runs on a local Ray instance and on the local backend: equal tables."""
    configs = [RunConfig(task="mountain_car.cost_to_go", plant="analytic", alpha=alpha, lam=0.9,
                         agents=3, episodes=5) for alpha in (1.0, 3.9)]
    local, _ = sweep.run_sweep(configs, str(tmp_path / "local"))
    on_ray, computed = sweep.run_sweep(configs, str(tmp_path / "ray"), backend="ray")
    assert computed == 2
    pd.testing.assert_frame_equal(local, on_ray)


SEARCH = [RunConfig(task="mountain_car.cost_to_go", learner="dqn_jax", net_arch="8", timesteps=300,
                   learning_starts=10, batch_size=4, buffer_size=64, agents=2, seed=seed,
                   learning_rate=rate, task_options={"time_limit": 2.0})
          for seed, rate in ((0, 1e-3), (10, 3e-3), (20, 1e-2))]
"""A population learner's runs that differ only in per-agent settings (a search's
configurations): one program trains them."""


@pytest.fixture(scope="module")
def searched(tmp_path_factory):
    """`(directory, table, runs computed)` of a local sweep of `SEARCH` with its agents kept,
    computed once for the tests that hold it to each run alone and to the Ray backend."""
    directory = tmp_path_factory.mktemp("joined")
    return (directory, *sweep.run_sweep(SEARCH, str(directory), keep_agents=True))


@pytest.mark.skipif(importlib.util.find_spec("ray") is None or jax_population.missing_jax(),
                    reason="Ray and JAX are optional extras: pip install -e '.[ray,jax]'")
def test_ray_backend_gives_the_local_results_of_population_runs_with_their_agents(tmp_path,
                                                                                  searched):
    """The benchmark's deep trainings (JAX populations, their agents kept for the greedy
    evaluations; here a search's runs, trained as one program) on Ray: the local tables,
    the agents kept."""
    _, local, _ = searched
    on_ray, computed = sweep.run_sweep(SEARCH, str(tmp_path / "ray"), backend="ray",
                                       keep_agents=True)
    assert computed == len(SEARCH)
    pd.testing.assert_frame_equal(local, on_ray)
    assert all(RunStore.agents_file(tmp_path / "ray", config.key).exists() for config in SEARCH)


@pytest.mark.skipif(jax_population.missing_jax(), reason="the population learners need the jax "
                    "extra: pip install 'lwrl[jax]'")
def test_runs_of_one_program_train_as_one_population_and_are_kept_apart(tmp_path, searched):
    """With their agents kept, a population learner's runs that differ only in per-agent
    settings (`SEARCH`) train as one batch: each run's table and kept agents are those of
    the run alone, and its records share the batch's CPU among its agents."""
    from lwrl.agent import io as agent_io
    assert sweep.populations(sweep.families(SEARCH)) == [SEARCH]
    directory, joined, computed = searched
    assert computed == 3
    for config in SEARCH:
        alone, _ = sweep.run_sweep([config], str(tmp_path / config.key), keep_agents=True)
        pd.testing.assert_frame_equal(
            joined[joined["run"] == config.key].reset_index(drop=True), alone)
        (kept_document, kept), (own_document, own) = (
            agent_io.load(RunStore.agents_file(root, config.key))[0].saved()
            for root in (directory, tmp_path / config.key))
        assert kept_document == own_document and kept.keys() == own.keys()
        for name, values in own.items():
            np.testing.assert_array_equal(kept[name], values, err_msg=name)
        shared = pd.read_csv(RunStore.records_file(directory, config.key))
        assert (shared["cpu_shared_by"] == 6).all()
    lines = [json.loads(line) for line in (directory / "compute.jsonl").open()]
    assert [sorted(line["runs"]) for line in lines] == [sorted(c.key for c in SEARCH)]


@pytest.mark.parametrize("learner, shaping", [
    ("dqn_jax", [dict(train_freq=4), dict(train_freq=16), dict(train_freq=16, gradient_steps=4)]),
    ("sac_jax", [dict(batch_size=64), dict(batch_size=128), dict(batch_size=64, gradient_steps=2)]),
])
def test_runs_whose_per_agent_settings_shape_the_program_are_not_joined(learner, shaping):
    """Per-agent settings that give what shapes a population learner's program
    (`Learner.shared`: the gradient steps of a training call, the minibatches' size) keep
    runs apart: a search over them joins only the runs that agree (a batch of both would be
    refused when its agents are made), and the step size still joins."""
    task, actions = (("cartpole.balance", "discrete") if learner == "dqn_jax"
                     else ("pendulum.swingup", "continuous"))
    configs = [RunConfig(task=task, actions=actions, learner=learner, learning_rate=rate,
                         **{"gradient_steps": -1, **chosen})
               for chosen in shaping for rate in (1e-3, 3e-3)]
    joined = sweep.populations(sweep.families(configs))
    assert [[config.settings.learning_rate for config in batch] for batch in joined] == [[1e-3, 3e-3]] * 3
    assert [batch[0] for batch in joined] == configs[::2]
    assert sweep.batches(configs) == joined


def test_batched_runs_equal_runs_alone(tmp_path):
    """A sweep joins runs that differ in trace, alpha, lambda, epsilon and seeds into one
    batch; each run's table equals that of the run alone."""
    configs = [RunConfig(task="mountain_car.cost_to_go", plant="analytic", trace=trace,
                         alpha=alpha, lam=lam, epsilon=epsilon, agents=agents, episodes=6, seed=seed)
               for trace, alpha, lam, epsilon, agents, seed in (
                   ("replacing", 3.9, 0.9, 0.0, 3, 0), ("accumulating", 1.0, 0.5, 0.1, 2, 7),
                   ("replacing", 2.0, 0.0, 0.0, 1, 3))]
    assert len(sweep.batches(configs)) == 1
    assert [len(batch) for batch in sweep.batches(configs, max_agents=4)] == [1, 2]
    table, computed = sweep.run_sweep(configs, str(tmp_path))
    assert computed == 3
    alone = pd.concat([one for config in configs for one, _ in sweep.run_batch([config])],
                      ignore_index=True)
    pd.testing.assert_frame_equal(table, alone)


def test_mujoco_runs_batch_too(tmp_path):
    """On the MuJoCo plant (the batched stepper) as well."""
    configs = [RunConfig(task="cartpole.balance", plant="mujoco", alpha=alpha, lam=0.7,
                         agents=2, episodes=3) for alpha in (0.5, 1.0)]
    table, _ = sweep.run_sweep(configs, str(tmp_path))
    alone = pd.concat([one for config in configs for one, _ in sweep.run_batch([config])],
                      ignore_index=True)
    pd.testing.assert_frame_equal(table, alone)


@pytest.mark.parametrize("level, settle, verdict", [
    (60.0, 40, "yes"), (60.0, 5, "partly"), (120.0, 40, "partly"), (120.0, 5, "no")])
def test_fig3_verdict_counts_both_conditions(tmp_path, level, settle, verdict):
    """A curve at 300 steps until episode `settle`, then at `level`: the verdict needs the
    level within 50 to 75 steps and the settling episode within 20 to 60."""
    rows = [{"agent": agent, "seed": agent, "episode": episode,
             "steps": 300.0 if episode < settle else level}
            for agent in range(3) for episode in range(1, 101)]
    section = ITEMS["fig3"].analyse(pd.DataFrame(rows), str(tmp_path))
    assert section.verdict == verdict
