"""Run configurations: the open readings of SPEC.md they can set, and the keys of results."""

import itertools
import subprocess
import sys

import numpy as np
import pytest

import dataclasses

from lwrl import agent
from lwrl.agent.paper_settings import PAPER_SETTINGS, paper_settings
from lwrl.runners.config import ProtocolSettings, RunConfig, task_defaults, unset_per_task
from lwrl.studies.paper.items import ITEMS
from lwrl.studies.paper.reproduce import with_alphas, with_readings
from lwrl.runners.run import make_agents, run


def test_edge_centroids_are_the_grid_from_end_to_end():
    """`centroids="edges"`: features of centroids at i / (n - 1) over the ranges, with the
    configuration's r^2, computed directly here."""
    config = RunConfig(task="cartpole.balance", centroids="edges", r2=0.02)
    low, high = map(np.array, (config.task_spec.ranges.low, config.task_spec.ranges.high))
    centres = np.array(list(itertools.product(*[np.arange(6) / 5] * 4)))
    states = np.random.default_rng(1).uniform(-1.3, 1.3, (50, 4)) * high
    distances = ((((states - low) / (high - low))[:, None, :] - centres[None]) ** 2).sum(axis=2)
    phi = np.exp(-distances / 0.02)
    edges = make_agents(config).features
    np.testing.assert_allclose(edges.features(states), phi / phi.sum(axis=1, keepdims=True),
                               atol=1e-12)
    midpoints = make_agents(RunConfig(task="cartpole.balance", r2=0.02)).features.features(states)
    assert np.abs(midpoints - edges.features(states)).max() > 0.1


def test_ranges_default_to_the_paper_and_can_be_set():
    config = RunConfig(task="pendulum.swingup", low=(-3, -3), high=(3, 3))
    assert make_agents(config).value_box() == ((-3.0, -3.0), (3.0, 3.0))
    assert make_agents(RunConfig(task="pendulum.swingup")).value_box()[1][1] == 1.5
    with pytest.raises(ValueError, match="low must have one value per state variable of "
                                         "pendulum.swingup \\(2\\)"):
        RunConfig(task="pendulum.swingup", low=(-1, -1, -1))
    with pytest.raises(ValueError, match="unknown centroids 'corners'; allowed: midpoints, edges"):
        RunConfig(task="pendulum.swingup", centroids="corners")


def test_a_run_takes_the_paper_agents_settings_on_its_task_and_what_it_is_given():
    """The one rule of a run's defaults: given values, else the paper agent's settings on
    the task (`agent.paper_settings`), field by field."""
    paper = paper_settings("mountain_car.cost_to_go")
    config = RunConfig(task="mountain_car.cost_to_go", alpha=0.25)
    assert (config.settings.alpha, config.settings.n, config.settings.trace, config.settings.lam,
            config.settings.epsilon, config.settings.gamma, config.episodes, config.agents) == (
        0.25, paper.n, paper.trace, paper.lam, paper.epsilon, paper.gamma, paper.episodes,
        paper.agents)
    assert task_defaults("mountain_car.cost_to_go") == dataclasses.asdict(paper)


def test_a_task_without_the_paper_agents_settings_takes_the_fields_own():
    """A task with no entry (an outside one) gets each `per_task` field's own value; the
    paper's settings asked for it are refused in one line naming the group to register
    under."""
    own = {field.name: field.metadata["per_task"] for cls in
           (agent.learner("sarsa").settings, ProtocolSettings)
           for field in dataclasses.fields(cls) if "per_task" in field.metadata}
    assert set(own) == {"n", "trace", "alpha", "lam", "epsilon", "gamma", "episodes", "agents"}
    filled = {**unset_per_task(agent.learner("sarsa").settings(), {}),
              **unset_per_task(ProtocolSettings(), {})}
    assert filled == own
    given = agent.learner("sarsa").settings(alpha=2.0)
    assert unset_per_task(given, {"alpha": 3.0, "n": 4})["n"] == 4
    assert "alpha" not in unset_per_task(given, {"alpha": 3.0})
    with pytest.raises(ValueError) as refused:
        paper_settings("nowhere.reach")
    message = str(refused.value)
    assert "\n" not in message and "'nowhere'" in message
    assert f"of the group '{PAPER_SETTINGS.group}'" in message
    with pytest.raises(ValueError, match="for the task 'pendulum.balance' .*swingup"):
        paper_settings("pendulum.balance")


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
        assert after.settings.r2 == (0.05 if before.settings.features == "nrbf" else before.settings.r2)
        assert after.settings.epsilon == 0.0
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
    nrbf = [c for c in configs if c.settings.features == "nrbf"]
    cmac = [c for c in configs if c.settings.features == "cmac"]
    distinct = {(c.settings.trace, c.settings.lam) for c in nrbf}
    assert [c for c in changed if c.settings.features == "cmac"] == cmac
    assert sorted((c.settings.trace, c.settings.lam, c.settings.alpha) for c in changed
                  if c.settings.features == "nrbf") == \
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


KEPT_KEYS = {
    "mountain_car.cost_to_go-default-nrbf-replacing-a3.9-l0.9-s0-a95bbdc9b805":
        dict(task="mountain_car.cost_to_go"),
    "mountain_car.cost_to_go-default-cmac-replacing_reset-a0.5-l0.9-s0-59145ff71df3":
        dict(task="mountain_car.cost_to_go", features="cmac", trace="replacing_reset", alpha=0.5,
             normalise_alpha=True, agents=30, episodes=20),
    "pendulum.swingup-mujoco-nrbf-replacing-a1.5-l0.4-s0-0ad35ea099a0":
        dict(task="pendulum.swingup", plant="mujoco", trace="replacing", alpha=1.5, lam=0.4),
    "pendulum.swingup-analytic-nrbf-replacing-a1.5-l0.4-s0-b28760c86b26":
        dict(task="pendulum.swingup", plant="analytic", equations="kfnnet"),
    "cartpole.balance-analytic-nrbf-accumulating-a0.5-l0.7-s0-7a4015b81103":
        dict(task="cartpole.balance", plant="analytic", integrator="explicit", r2=0.05),
    "cartpole.balance-default-nrbf-accumulating-a0.5-l0.7-s0-b39b90f673ad":
        dict(task="cartpole.balance", centroids="edges", low=(-3, -2, -0.3, -3),
             high=(3, 2, 0.3, 3), task_options={"track_limit": None}),
    "acrobot.swingup-default-nrbf-replacing-a1-l0.9-s10-88444a8e383e":
        dict(task="acrobot.swingup", seed=10, agents=50),
}
"""Keys of runs computed before the learners were open (the file names of kept runs), with
every reading the paper's study sets."""


@pytest.mark.parametrize("key", KEPT_KEYS)
def test_kept_runs_keep_their_keys(key):
    """A kept run is found again, not recomputed: its key is derived from the settings'
    fields as it was from the old hand-kept order. A field added with a default, unless its
    metadata says the key names it only where set (`lwrl.settings.WHEN_SET`), fails here."""
    assert RunConfig(**KEPT_KEYS[key]).key == key


def test_a_new_setting_changes_no_key_where_it_is_not_set():
    """The rule the test above holds: a setting named `WHEN_SET` enters the key only where a
    run departs from its default; one without that metadata enters every key."""
    import dataclasses

    from lwrl.agent.sarsa import SarsaSettings
    from lwrl.settings import WHEN_SET, setting

    @dataclasses.dataclass(frozen=True, kw_only=True)
    class Quiet(SarsaSettings):
        momentum: float = setting(0.0, key=WHEN_SET)

    @dataclasses.dataclass(frozen=True, kw_only=True)
    class Loud(SarsaSettings):
        momentum: float = 0.0

    plain = RunConfig(task="mountain_car.cost_to_go")
    assert RunConfig(task="mountain_car.cost_to_go", settings=Quiet()).key == plain.key
    assert RunConfig(task="mountain_car.cost_to_go", settings=Quiet(momentum=0.5)).key != plain.key
    assert RunConfig(task="mountain_car.cost_to_go", settings=Loud()).key != plain.key
