"""`lwrl implementations`: the pairing from the registry, the translation of the settings,
the report's statistics and verdicts on synthetic results, the command's bad input, and a
tiny run end to end (slow: JAX compiles its programs)."""

import dataclasses
import math
import re

import numpy as np
import pandas as pd
import pytest

from conftest import run_cli
from lwrl import tasks
from lwrl.agent import jax_population, stable_baselines
from lwrl.studies.implementations import costs, plan, report

TASKS = ("mountain_car.cost_to_go", "pendulum.swingup")
needs_both = pytest.mark.skipif(
    jax_population.missing_jax() or bool(stable_baselines.missing_libraries()),
    reason="both implementations: the jax and baselines extras "
           "(pip install 'lwrl[jax,baselines]')")


def test_the_pairs_come_from_the_registry():
    """Each population learner beside the learner whose settings class its own subclasses,
    those of the kind of action asked (the study's default: discrete)."""
    assert plan.pairs() == [plan.Pair("ppo", "ppo_jax"), plan.Pair("dqn", "dqn_jax")]
    assert plan.pairs(actions="continuous") == [plan.Pair("sac", "sac_jax"),
                                                plan.Pair("td3", "td3_jax")]


def test_the_closest_reference_is_chosen():
    """Where several learners' settings classes are bases of the twin's, the most derived
    one is its reference; a population learner over no other's settings has no pair."""
    @dataclasses.dataclass(frozen=True)
    class Base:
        pass

    @dataclasses.dataclass(frozen=True)
    class Middle(Base):
        pass

    @dataclasses.dataclass(frozen=True)
    class Twin(Middle):
        pass

    @dataclasses.dataclass(frozen=True)
    class Alone:
        pass

    def learner(settings, population=False):
        return type("L", (), {"settings": settings, "population": population,
                              "actions": "discrete"})

    registry = {"base": learner(Base), "middle": learner(Middle),
                "twin": learner(Twin, True), "alone": learner(Alone, True)}
    assert plan.pairs(registry) == [plan.Pair("middle", "twin")]


def test_each_task_takes_the_papers_measure():
    assert plan.measure("mountain_car.cost_to_go") == plan.STEPS
    assert plan.measure("pendulum.swingup") == plan.UPTIME
    assert not plan.STEPS.higher_is_better and plan.UPTIME.higher_is_better


@needs_both
def test_both_implementations_take_the_same_zoo_settings():
    """The translation: every field the same for both, the tuned ones from the zoo's set."""
    cells = plan.cells(TASKS, 3)
    assert [(c.task, c.pair.slug) for c in cells] == [
        (task, slug) for task in TASKS for slug in ("ppo-ppo_jax", "dqn-dqn_jax")]
    for cell in cells:
        rows = plan.translation(cell)
        assert rows and all(row.same for row in rows), cell.key
        reference, twin = (cell.config(name, 0).settings for name in cell.pair.names)
        ours = {f.name for f in dataclasses.fields(reference)}
        assert {row.name for row in rows} == ours | {f.name for f in dataclasses.fields(twin)}
        assert [(row.name, row.reference, row.twin) for row in rows if row.name not in ours] == [
            ("normalize_observations", plan.ABSENT, False)]  # the twin's own, at its default
        for name, value in cell.settings.items():
            assert getattr(reference, name) == getattr(twin, name) == value
            assert cell.sources[name].startswith("the zoo's")
        assert all(row.help for row in rows)  # each field's meaning, from its docstring
    pendulum_ppo = next(c for c in cells if c.task == "pendulum.swingup" and c.pair.reference == "ppo")
    assert pendulum_ppo.settings["n_steps"] == 4096  # Acrobot-v1's set: the zoo's only swing-up


def test_a_twin_runs_as_its_reference_only_with_its_own_settings_at_their_default():
    from lwrl.runners.config import learner_settings
    twin = learner_settings("dqn_jax", {"learning_rate": 0.002})
    values = plan.reference_settings("dqn", twin)
    assert values["learning_rate"] == 0.002 and "normalize_observations" not in values
    normalising = learner_settings("dqn_jax", {"normalize_observations": True})
    with pytest.raises(ValueError, match="normalize_observations=True is not a setting of dqn"):
        plan.reference_settings("dqn", normalising)


@needs_both
def test_the_study_runs_one_agent_per_run_on_the_same_seeds():
    cell = plan.cells(["pendulum.swingup"], 4, budgets={"pendulum.swingup": (30, {})})[0]
    for name in cell.pair.names:
        configs = cell.configs(name)
        assert [c.seeds for c in configs] == [[0], [1], [2], [3]]
        assert {c.episodes for c in configs} == {30} and {c.plant_name for c in configs} == {"analytic"}
    keys = {c.key for name in cell.pair.names for c in cell.configs(name)}
    assert len(keys) == 8


@needs_both
def test_overrides_replace_the_protocol_and_say_so():
    cell = plan.cells(["mountain_car.cost_to_go"], 2, episodes=3, timesteps=500, time_limit=40)[0]
    assert cell.episodes == 3 and cell.task_options == {"time_limit": 40.0}
    assert cell.settings["timesteps"] == 500 and "--timesteps" in cell.sources["timesteps"]


@pytest.mark.parametrize("actions", ["discrete", "continuous"])
def test_each_twin_states_what_differs(actions):
    """In its own module, or in the module its agents' classes come from (what `sac_jax` and
    `td3_jax` share)."""
    for pair in plan.pairs(actions=actions):
        module, text = plan.known_differences(pair.twin)
        assert text.startswith("What differs") and "random streams" in text
        assert f"`{pair.reference}`" in text.split(",")[0], text
        assert module.startswith("lwrl.agent.")


@needs_both
def test_the_continuous_pairs_run_on_the_tasks_made_with_continuous_actions():
    """`--action-kind continuous`: SAC's and TD3's pairs, their runs on the task made with
    continuous actions (the run key names it), the learners' own defaults (no tuned set) the
    same for both; the discrete study's runs keep their keys (no kind of action in them)."""
    cells = plan.cells(["pendulum.swingup"], 2, actions="continuous")
    assert [c.pair.slug for c in cells] == ["sac-sac_jax", "td3-td3_jax"]
    for cell in cells:
        assert cell.actions == "continuous" and cell.settings == {}
        rows = plan.translation(cell)
        assert rows and all(row.same and row.source == "the learner's default" for row in rows)
        for config in (cell.config(name, 0) for name in cell.pair.names):
            assert config.actions == config.task_spec.actions == "continuous"
            assert '"actions": "continuous"' in config.key_json()
    assert report.actions_lines(cells) and "`sac` has no tuned set" in report.untuned(cells)
    discrete = plan.cells(["pendulum.swingup"], 2)
    assert not report.actions_lines(discrete) and not report.untuned(discrete)
    for config in (c.config(name, 0) for c in discrete for name in c.pair.names):
        assert config.actions == "discrete" and '"actions"' not in config.key_json()


@needs_both
def test_the_timed_run_reaches_past_the_warm_up():
    """TD3 waits `learning_starts` steps before its first update: its cost is timed over
    that warm-up and `COST_STEPS` more, so that it is timed learning."""
    for cell in plan.cells(["pendulum.swingup"], 2, actions="continuous"):
        for name in cell.pair.names:
            config = costs.cost_config(cell, name)
            starts = getattr(config.settings, "learning_starts", 0)
            definition = tasks.definition(*tasks.split_name(config.task), **config.task_options)
            steps = config.episodes * definition.step_limit
            assert steps >= starts + costs.COST_STEPS, (name, starts, steps)
            assert steps - definition.step_limit < starts + costs.COST_STEPS, (name, starts, steps)


def test_identical_result_sets_give_one_half_and_no_difference():
    values = np.array([3.0, 5.0, 8.0, 1.0, 4.0, 4.0, 9.0, 2.0, 6.0, 7.0])
    for higher in (True, False):
        estimate = report.compare_values(values, values.copy(), higher)
        assert estimate.value == pytest.approx(0.5) and estimate.low < 0.5 < estimate.high
        sentence = report.verdict(estimate, "ref", "twin", {"ref": 10, "twin": 10})
        assert sentence.startswith("No difference found at this sample size (10 and 10 agents)")


@pytest.mark.parametrize("higher_is_better", [True, False])
def test_a_clear_difference_names_the_better_implementation(higher_is_better):
    low, high = np.arange(10.0), np.arange(10.0) + 100
    better, worse = (high, low) if higher_is_better else (low, high)
    estimate = report.compare_values(worse, better, higher_is_better)  # the twin is better
    assert estimate.value == 1.0 and estimate.low > 0.5
    assert report.verdict(estimate, "ref", "twin", {"ref": 10, "twin": 10}).startswith("twin does better")
    estimate = report.compare_values(better, worse, higher_is_better)
    assert estimate.value == 0.0 and estimate.high < 0.5
    assert report.verdict(estimate, "ref", "twin", {"ref": 10, "twin": 10}).startswith("ref does better")


def test_too_few_agents_are_not_judged():
    one = report.compare_values(np.array([1.0]), np.array([2.0]), True)
    assert math.isnan(one.low)
    assert report.verdict(one, "ref", "twin", {"ref": 1, "twin": 1}).startswith("Not judged")
    none = report.compare_values(np.array([]), np.array([2.0, 3.0]), True)
    assert report.verdict(none, "ref", "twin", {"ref": 0, "twin": 2}).startswith("Not judged")


def synthetic_results(cell, draw) -> pd.DataFrame:
    """Results of every run of `cell`: `draw(name, seed)` -> each episode's measure."""
    rows = []
    for name in cell.pair.names:
        for config in cell.configs(name):
            for episode, value in enumerate(draw(name, config.seed), start=1):
                rows.append({"run": config.key, "seed": config.seed, "episode": episode,
                             "steps": value, "uptime_s": value, "diverged": False})
    return pd.DataFrame(rows)


@needs_both
def test_the_comparison_pairs_each_implementations_agents():
    """Two identical result sets: the same estimates, P = 0.5, no difference found; the
    agents counted per implementation from their own runs."""
    cell = plan.cells(["pendulum.swingup"], 6, episodes=4)[0]
    curve = lambda name, seed: [10.0 * seed + episode for episode in range(4)]  # noqa: E731
    comparison = report.compare(cell, synthetic_results(cell, curve))
    reference, twin = cell.pair.names
    assert comparison.agents == {reference: 6, twin: 6}
    assert np.array_equal(comparison.values[reference], comparison.values[twin])
    assert comparison.estimates[reference] == comparison.estimates[twin]
    assert comparison.improvement.value == pytest.approx(0.5) and comparison.outcome == 0
    assert comparison.tables[twin].shape == (6, 4)


@needs_both
def test_the_report_is_written_from_synthetic_results(tmp_path):
    """The report: the command at the top, a row per cell, the translation, a figure per
    cell, the verdicts; here the twin of the first pair is better by far."""
    cells = plan.cells(["pendulum.swingup"], 5, episodes=3)
    rng = np.random.default_rng(0)

    def draw(name, seed):
        shift = 20.0 if name == cells[0].pair.twin else 0.0
        return list(rng.uniform(0, 5, 3) + shift)
    results = pd.concat([synthetic_results(cell, draw) for cell in cells], ignore_index=True)
    path = report.write(cells, results, costs={}, timings={}, initialisations={},
                        out_dir=str(tmp_path), command="lwrl implementations pendulum.swingup",
                        seconds=1.0, total_seconds=2.0, computed=0, runs=20, finished=20,
                        notes="Checked: nothing.")
    text = open(path).read()
    assert text.splitlines()[2].startswith("Written by `lwrl implementations pendulum.swingup`")
    first, second = cells
    assert f"**{first.pair.twin} does better (5 and 5 agents)" in text
    assert "No difference found at this sample size (5 and 5 agents)" in text
    assert text.count("Every setting is the same for both implementations.") == 2
    for cell in cells:
        assert (tmp_path / "figures" / f"{cell.task}-{cell.pair.slug}.png").exists()
    assert "Checked: nothing." in text and "## What differs: ppo and ppo_jax" in text


@pytest.mark.parametrize("argv, fragment", [
    (["implementations", "nowhere.nothing"], "invalid choice: 'nowhere.nothing'"),
    (["implementations", "pendulum.swingup", "--action-kind", "sideways"],
     "invalid choice: 'sideways'"),
    (["implementations", "pendulum.swingup", "--agents", "1"], "an interval needs two agents"),
    (["implementations", "pendulum.swingup", "--time-limit", "-1"], "seconds > 0"),
    (["implementations", "pendulum.swingup", "--episodes", "0"], "must be a positive integer"),
])
def test_bad_input_is_one_line_and_status_2(argv, fragment, capsys, tmp_path):
    status, out, err = run_cli(argv + ["--out", str(tmp_path / "out")], capsys)
    assert status == 2 and len(err) == 1 and fragment in err[0], err
    assert not (tmp_path / "out").exists()


def test_a_time_limit_that_is_no_whole_number_of_steps_is_one_line(capsys, tmp_path):
    status, _, err = run_cli(["implementations", "pendulum.swingup", "--time-limit", "0.033",
                              "--out", str(tmp_path / "out")], capsys)
    assert status == 2 and len(err) == 1 and "whole number of control steps" in err[0], err


@pytest.fixture
def tiny_costs(monkeypatch):
    """4 untrained agents at initialisation; costs timed over 60 steps in one episode or more
    (not `COST_EPISODES`): the tiny studies' own 2 episodes of 30 steps, so that a population
    learner's timed runs and its study's runs are one compiled program."""
    monkeypatch.setattr(plan, "INIT_AGENTS", 4)
    monkeypatch.setattr(costs, "COST_EPISODES", 1)
    monkeypatch.setattr(costs, "timed_steps", lambda config: 60)


@needs_both
@pytest.mark.slow
def test_a_tiny_study_runs_end_to_end_and_resumes(tmp_path, capsys, tiny_costs):
    """1 task, 2 agents, 2 episodes of 30 steps, 100 steps of learning, `tiny_costs`: the
    runs, the costs, the report and its figures; the same command again computes nothing."""
    out = tmp_path / "study"
    argv = ["implementations", "mountain_car.cost_to_go", "--agents", "2", "--episodes", "2",
            "--time-limit", "30", "--timesteps", "100", "--out", str(out)]
    status, printed, err = run_cli(argv, capsys)
    assert status == 0, err
    assert len(list((out / "runs").glob("*.csv.gz"))) == 8
    text = (out / "report.md").read_text()
    assert f"Written by `lwrl {' '.join(argv)}`" in text and "computed 8 of the 8 runs" in text
    assert len(list((out / "figures").glob("*.png"))) == 2
    assert (out / "costs.json").exists() and (out / "timings.json").exists()
    status, printed, err = run_cli(argv, capsys)
    assert status == 0, err
    assert "computed 0 of the 8 runs" in (out / "report.md").read_text()
    assert re.search(r"done in .*: wrote", printed)


@needs_both
@pytest.mark.slow
def test_a_tiny_continuous_study_runs_end_to_end(tmp_path, capsys, tiny_costs):
    """`--action-kind continuous`: SAC's and TD3's pairs on the pendulum made with continuous
    actions, 2 agents, 2 episodes of 30 steps, 100 steps of learning, `tiny_costs`: the runs,
    the report's table and its sections; the continuous actor's one output ranks no
    actions."""
    out = tmp_path / "study"
    argv = ["implementations", "pendulum.swingup", "--action-kind", "continuous", "--agents", "2",
            "--episodes", "2", "--time-limit", "0.6", "--timesteps", "100", "--out", str(out)]
    status, printed, err = run_cli(argv, capsys)
    assert status == 0, err
    assert len(list((out / "runs").glob("*.csv.gz"))) == 8
    text = (out / "report.md").read_text()
    assert "computed 8 of the 8 runs" in text and "- Actions: continuous" in text
    for reference, twin in (("sac", "sac_jax"), ("td3", "td3_jax")):
        assert f"| pendulum.swingup | {reference} / {twin} | mean up-time" in text
        assert f"## What differs: {reference} and {twin}" in text
    assert text.count("(what ranks the actions) | — | — |") == 2
    assert len(list((out / "figures").glob("*.png"))) == 2
