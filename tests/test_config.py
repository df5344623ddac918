"""Run configurations: the open readings of SPEC.md they can set, and the keys of results."""

import itertools
import subprocess
import sys

import numpy as np
import pytest

from lwrl.runners.config import RunConfig
from lwrl.studies.paper.items import ITEMS
from lwrl.studies.paper.reproduce import with_alphas, with_readings
from lwrl.runners.run import run


def test_edge_centroids_are_the_grid_from_end_to_end():
    """`centroids="edges"`: features of centroids at i / (n - 1) over the ranges, with the
    configuration's r^2, computed directly here."""
    config = RunConfig(task="cartpole.balance", centroids="edges", r2=0.02)
    low, high = map(np.array, config.ranges)
    centres = np.array(list(itertools.product(*[np.arange(6) / 5] * 4)))
    states = np.random.default_rng(1).uniform(-1.3, 1.3, (50, 4)) * high
    distances = ((((states - low) / (high - low))[:, None, :] - centres[None]) ** 2).sum(axis=2)
    phi = np.exp(-distances / 0.02)
    np.testing.assert_allclose(config.feature_map().features(states),
                               phi / phi.sum(axis=1, keepdims=True), atol=1e-12)
    midpoints = RunConfig(task="cartpole.balance", r2=0.02).feature_map().features(states)
    assert np.abs(midpoints - config.feature_map().features(states)).max() > 0.1


def test_ranges_default_to_the_paper_and_can_be_set():
    config = RunConfig(task="pendulum.swingup", low=(-3, -3), high=(3, 3))
    assert config.feature_map().low == (-3.0, -3.0) and config.feature_map().high == (3.0, 3.0)
    assert RunConfig(task="pendulum.swingup").feature_map().high[1] == 1.5
    with pytest.raises(ValueError, match="low must have one value per state variable of "
                                         "pendulum.swingup \\(2\\)"):
        RunConfig(task="pendulum.swingup", low=(-1, -1, -1))
    with pytest.raises(ValueError, match="unknown centroids 'corners'; allowed: midpoints, edges"):
        RunConfig(task="pendulum.swingup", centroids="corners")


def test_optional_readings_enter_a_runs_key_only_when_set():
    """Results computed before a reading existed keep their key; setting it changes the key."""
    plain = RunConfig(task="cartpole.balance")
    assert "centroids" not in plain.key_json() and "task_options" not in plain.key_json()
    keys = {config.key for config in (
        plain, RunConfig(task="cartpole.balance", centroids="edges"),
        RunConfig(task="cartpole.balance", task_options={"track_limit": None}),
        RunConfig(task="cartpole.balance", low=(-3, -2, -0.3, -3)))}
    assert len(keys) == 4


def test_task_options_reach_the_task_on_both_plants():
    """A 0.1 s time limit (5 steps; the pole cannot fall that fast from upright) cuts every
    episode at 5 steps, on both plants."""
    for plant in ("analytic", "mujoco"):
        config = RunConfig(task="cartpole.balance", plant=plant, agents=3, episodes=2,
                           task_options={"time_limit": 0.1})
        results = run(config)[1]
        assert np.all(results.steps == 5) and results.truncated.all()
    with pytest.raises(ValueError, match="unknown option 'friction' for cartpole.balance"):
        run(RunConfig(task="cartpole.balance", agents=1, episodes=1, task_options={"friction": 0}))


def test_readings_apply_to_the_runs_that_have_them():
    configs = ITEMS["fig2"].configs("analytic", True, "semi_implicit") + \
        ITEMS["fig8"].configs("analytic", True, "semi_implicit")
    changed = with_readings(configs, {"r2": 0.05, "epsilon": 0.0, "track_limit": None})
    for before, after in zip(configs, changed):
        assert after.r2 == (0.05 if before.features == "nrbf" else before.r2)
        assert after.epsilon == 0.0
        assert after.task_options == ({"track_limit": None} if before.domain == "cartpole" else {})
    with pytest.raises(ValueError, match="no run of these items has the reading 'track_limit'"):
        with_readings(ITEMS["fig2"].configs("analytic", True, "semi_implicit"), {"track_limit": 3})


def test_the_author_codes_equations_apply_to_analytic_pendulum_and_cartpole_runs():
    configs = ITEMS["fig2"].configs("analytic", True, "semi_implicit") + \
        ITEMS["fig6"].configs("analytic", True, "semi_implicit")
    changed = with_readings(configs, {"equations": "kfnnet"})
    assert [c.equations for c in changed] == [
        "kfnnet" if c.domain == "pendulum" else "paper" for c in configs]
    assert '"equations": "kfnnet"' in changed[-1].key_json()
    assert "equations" not in configs[-1].key_json()
    with pytest.raises(ValueError, match="no run of these items has the reading 'equations': it "
                                         "applies to the pendulum and cart-pole on the analytic "
                                         "plant \\(--plant analytic\\)"):
        with_readings(ITEMS["fig6"].configs("mujoco", True, "semi_implicit"), {"equations": "kfnnet"})
    with pytest.raises(ValueError, match="equations 'kfnnet' applies to the analytic plant of the "
                                         "tasks that have it; cartpole.balance on the mujoco plant "
                                         "has no plant options"):
        RunConfig(task="cartpole.balance", equations="kfnnet")
    with pytest.raises(ValueError, match="integrator 'explicit' applies to the analytic plant"):
        RunConfig(task="pendulum.swingup", plant="mujoco", integrator="explicit")
    with pytest.raises(ValueError, match="unknown equations 'R'; allowed: paper, kfnnet"):
        RunConfig(task="cartpole.balance", plant="analytic", equations="R")
    paper, kfnnet = (run(RunConfig(task="cartpole.balance", plant="analytic", agents=2,
                                   episodes=3, equations=equations))[1]
                     for equations in ("paper", "kfnnet"))
    assert not np.array_equal(paper.steps, kfnnet.steps)


def test_an_alpha_grid_replaces_the_nrbf_runs_alphas_only():
    configs = ITEMS["fig2"].configs("analytic", True, "semi_implicit")
    changed = with_alphas(configs, (0.05, 0.1))
    nrbf = [c for c in configs if c.features == "nrbf"]
    cmac = [c for c in configs if c.features == "cmac"]
    distinct = {(c.trace, c.lam) for c in nrbf}
    assert [c for c in changed if c.features == "cmac"] == cmac
    assert sorted((c.trace, c.lam, c.alpha) for c in changed if c.features == "nrbf") == \
        sorted((trace, lam, alpha) for trace, lam in distinct for alpha in (0.05, 0.1))
    with pytest.raises(ValueError, match="alphas must name at least one learning rate"):
        with_alphas(configs, ())


def test_reproduce_sets_readings_from_the_command_line(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "lwrl.cli", "reproduce", "fig8", "--quick", "--out",
         str(tmp_path), "--set", "track_limit=none", "--set", "centroids=edges", "--alphas",
         "0.05,0.1"],
        capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    report = (tmp_path / "report.md").read_text()
    assert ("readings departing from the defaults: track_limit = None, centroids = edges; "
            "NRBF α grid 0.05, 0.1") in report
    configs = (tmp_path / "fig8" / "configs.jsonl").read_text()
    assert '"track_limit": null' in configs and '"centroids": "edges"' in configs
    bad = subprocess.run([sys.executable, "-m", "lwrl.cli", "reproduce", "fig8", "--quick",
                          "--out", str(tmp_path), "--set", "r2"], capture_output=True, text=True)
    assert bad.returncode == 2 and "must be NAME=VALUE" in bad.stderr.strip().splitlines()[-1]
