"""Phase B of the physics as parameters: per-agent physics, sensors and actuators in the
compiled loop, randomisation while learning, the settings and flags that reach them, the
evaluation of kept agents through the sweep, and `lwrl robustness` with its C controller.

Each path is held to the others as `test_parameters.py` and `test_learners.py` hold them at
one set of values: the compiled loop, the batched stepper and a dm_env environment give the
same episodes and weights for the same seeds, whatever the options.
"""

import dataclasses
import importlib.util
import os
import pathlib

import numpy as np
import pytest

from lwrl import agent as learners
from lwrl import outputs, tasks
from lwrl.agent import io as agent_io
from lwrl.agent.jax_population import missing_jax
from lwrl.runners import sweep
from lwrl.runners.config import RunConfig, task_spec
from lwrl.runners.run import environment_options, make_agents, run, run_batched, run_compiled, run_dm_env
from lwrl.studies.robustness import controller, plan, study
from lwrl.studies.robustness.domains import ROBUSTNESS
from lwrl.tasks.batched import BatchedEnv
from lwrl.tasks.randomisation import check_ranges, draws, episode_values
from conftest import off_nominal, run_cli

PLANTS = ("analytic", "mujoco")
SENSING = {"observation_noise": {"pole_angle": [0.01, 0.0, 0.02]}, "action_delay": [0, 1, 3],
           "action_noise": [0.0, 2.0, 0.5]}
"""Sensor and actuator options, one per agent of three."""


def agent_options(options: dict, b: int) -> dict:
    """Agent b's own values of per-agent options (`{name: values}` or values)."""
    def own(value):
        if isinstance(value, dict):
            return {name: own(v) for name, v in value.items()}
        return value[b] if isinstance(value, (list, np.ndarray)) else value
    return {name: own(value) for name, value in options.items()}


def assert_same(a, b):
    for field in ("steps", "returns", "uptime", "truncated", "diverged_episode"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)


@pytest.mark.parametrize("plant", PLANTS)
def test_the_compiled_loop_gives_each_agent_its_physics_and_its_sensors(plant):
    """Three agents, each with parameter values and sensor and actuator options of its own:
    the compiled loop, the batched stepper and, agent by agent, a dm_env environment give
    the same episodes and weights; and not those of the paper's plant."""
    rows = off_nominal("cartpole", np.random.default_rng(11), 3)
    params = {name: rows[:, j] for j, name in enumerate(tasks.domain("cartpole").parameters.names)}
    options = {"params": params, **SENSING}
    config = RunConfig(task="cartpole.balance", plant=plant, agents=3, episodes=4, seed=3)
    compiled_agent, batched_agent, nominal_agent = (make_agents(config) for _ in range(3))
    compiled = run_compiled("cartpole", "balance", compiled_agent, 4, config.seeds, plant=plant,
                            **options)
    batched = run_batched(BatchedEnv("cartpole", "balance", plant, config.seeds, **options),
                          batched_agent, 4)
    assert_same(compiled, batched)
    np.testing.assert_array_equal(compiled_agent.weights, batched_agent.weights)
    for b, seed in enumerate(config.seeds):
        single_agent = make_agents(dataclasses.replace(config, agents=1, seed=seed))
        single = run_dm_env(tasks.load("cartpole", "balance", plant=plant, seed=seed,
                                       **agent_options(options, b)), single_agent, 4)
        np.testing.assert_array_equal(single.steps[0], compiled.steps[b])
        np.testing.assert_array_equal(single_agent.weights[0], compiled_agent.weights[b])
    nominal = run_compiled("cartpole", "balance", nominal_agent, 4, config.seeds, plant=plant)
    assert not np.array_equal(nominal.steps, compiled.steps)


@pytest.mark.parametrize("plant", PLANTS)
def test_randomised_physics_is_the_same_on_every_path(plant):
    """`randomise`: each episode's values drawn from the agent's seed and the episode alone,
    so that the three paths agree; the draws lie in their ranges and change per episode."""
    ranges = {"pole_mass": (0.05, 0.4), "force": (5.0, 12.0)}
    config = RunConfig(task="cartpole.balance", plant=plant, agents=2, episodes=5, seed=8,
                       randomise=ranges, action_delay=1)
    compiled_agent, compiled = run(config)
    batched_agent = make_agents(config)
    batched = run_batched(BatchedEnv("cartpole", "balance", plant, config.seeds,
                                     **config.environment_options()), batched_agent, 5)
    assert_same(compiled, batched)
    np.testing.assert_array_equal(compiled_agent.weights, batched_agent.weights)
    single_agent = make_agents(dataclasses.replace(config, agents=1, seed=9))
    single = run_dm_env(tasks.load("cartpole", "balance", plant=plant, seed=9,
                                   **config.environment_options()), single_agent, 5)
    np.testing.assert_array_equal(single.steps[0], compiled.steps[1])
    np.testing.assert_array_equal(single_agent.weights[0], compiled_agent.weights[1])
    assert set(compiled.physical) == set(ranges)
    for name, (low, high) in ranges.items():
        drawn = compiled.physical[name]
        assert drawn.shape == (2, 5) and np.all((drawn >= low) & (drawn <= high))
        assert len(np.unique(drawn)) == drawn.size
    _, fixed = run(dataclasses.replace(config, randomise={}))
    assert not np.array_equal(fixed.steps, compiled.steps)


def test_the_draws_depend_on_the_seed_and_the_episode_alone():
    parameters = tasks.domain("pendulum").parameters
    ranges = check_ranges(parameters, {"torque": (2, 8), "mass": (0.5, 2)})
    assert list(ranges) == ["mass", "torque"]  # the domain's order
    rows = parameters.values(None, 3)
    all_at_once = draws(parameters, ranges, rows, [4, 5, 6], 6)
    np.testing.assert_array_equal(draws(parameters, ranges, rows[1:2], [5], 3), all_at_once[1:2, :3])
    untouched = [j for j, name in enumerate(parameters.names) if name not in ranges]
    np.testing.assert_array_equal(all_at_once[:, :, untouched],
                                  np.broadcast_to(rows[:, None, untouched], (3, 6, len(untouched))))


def test_the_draws_a_process_keeps_are_each_episodes_own():
    """`draws` keeps an integer seed's deviates for the process and extends them: asked for
    few episodes, then more, it gives what each episode draws alone (`episode_values`)."""
    parameters = tasks.domain("mountain_car").parameters
    ranges = check_ranges(parameters, {"thrust": (0.0008, 0.0012), "gravity": (0.002, 0.003)})
    rows, seeds = parameters.values(None, 2), [91_001, np.int64(91_002)]
    few, more = draws(parameters, ranges, rows, seeds, 4), draws(parameters, ranges, rows, seeds, 9)
    alone = [[episode_values(parameters, ranges, row, int(seed), k) for k in range(9)]
             for row, seed in zip(rows, seeds)]
    np.testing.assert_array_equal(more, np.array(alone))
    np.testing.assert_array_equal(few, more[:, :4])


def test_a_batch_draws_its_episodes_physics_before_its_clock_starts(monkeypatch):
    """`run_batch` draws every episode's physics of its agents' seeds into the process's keep
    before its training clock starts: what the clock measures does not depend on which run
    of the process drew first."""
    from lwrl.runners import records, sweep
    from lwrl.tasks import randomisation

    config = RunConfig(task="mountain_car.cost_to_go", agents=2, episodes=3, seed=93_000,
                       randomise={"thrust": (0.0008, 0.0012)})
    monkeypatch.setattr(randomisation, "_kept", {})
    kept, clock = [], records.TrainingClock
    monkeypatch.setattr(records, "TrainingClock",
                        lambda: kept.append({key: len(v) for key, v in randomisation._kept.items()})
                        or clock())
    sweep.run_batch([config])
    assert kept == [{(93_000, 1): 3, (93_001, 1): 3}]


@pytest.mark.parametrize("randomise, message", [
    ({"pole_mas": (0.1, 0.2)}, "unknown parameter 'pole_mas'; allowed: cart_mass"),
    ({"pole_mass": (0.2, 0.1)}, r"randomise\['pole_mass'\] must be a range \(low, high\), low <= high"),
    ({"pole_mass": (0.1, 2.0)}, r"within pole_mass \(m, kg\) in \[0.01, 1\]"),
    ({"pole_mass": 0.1}, "must be a range"),
    ({"pole_mass": (0.1, float("nan"))}, "must be a range"),
])
def test_a_bad_randomisation_is_one_line(randomise, message):
    with pytest.raises(ValueError, match=message) as error:
        RunConfig(task="cartpole.balance", randomise=randomise)
    assert "\n" not in str(error.value)
    with pytest.raises(ValueError, match=message):
        BatchedEnv("cartpole", "balance", "analytic", [0], randomise=randomise)


def test_the_settings_take_the_physics_and_the_sensors_keyed_only_where_set():
    """`RunConfig(params=..., action_delay=...)`: the key changes only where set, one
    spelling gives one key, and a bad name or value is one line."""
    nominal = RunConfig(task="cartpole.balance")
    heavy = RunConfig(task="cartpole.balance", params={"pole_mass": 0.2}, action_delay=1)
    assert heavy.key != nominal.key and "pole_mass" not in nominal.key_json()
    assert RunConfig(task="cartpole.balance", params={}, action_delay=0).key == nominal.key
    assert (RunConfig(task="cartpole.balance", params={"force": 8, "pole_mass": 0.2}).key
            == RunConfig(task="cartpole.balance", params={"pole_mass": 0.2, "force": 8.0}).key)
    assert heavy.environment_options() == {"params": {"pole_mass": 0.2}, "action_delay": 1}
    assert heavy.columns()["params.pole_mass"] == 0.2
    for values, message in (({"params": {"mass": 1.0}}, "unknown parameter 'mass'"),
                            ({"params": {"pole_mass": 5.0}}, r"within \[0.01, 1\] kg; got 5.0"),
                            ({"observation_noise": {"angle": 0.1}}, "unknown state variable 'angle'"),
                            ({"action_delay": -1}, "action_delay must be a finite whole number"),
                            ({"action_noise": -0.5}, "action_noise must be a finite number")):
        with pytest.raises(ValueError, match=message) as error:
            RunConfig(task="cartpole.balance", **values)
        assert "\n" not in str(error.value)


def test_a_batch_of_configurations_gives_each_agent_its_own():
    configs = [RunConfig(task="pendulum.swingup", agents=2, params={"mass": 2.0}),
               RunConfig(task="pendulum.swingup", agents=1, action_delay=2)]
    options = environment_options(configs)
    assert options["params"] == {"mass": [2.0, 2.0, 1.0]}
    assert options["action_delay"] == [0, 0, 2] and options["action_noise"] == [0.0] * 3
    assert environment_options(configs[:1]) == {"params": {"mass": 2.0}}


def test_lwrl_train_takes_the_physics_and_the_sensors(tmp_path, capsys):
    """The flags and their help come from the declarations; bad input is one line, exit 2;
    the draws of `--randomise` are columns of episodes.csv."""
    status, out, _ = run_cli(["train", "--help"], capsys)
    for domain in tasks.DOMAINS.values():
        for parameter in domain.parameters.items:
            assert parameter.allowed() in " ".join(out.split())
    base = ["train", "cartpole.balance", "--plant", "analytic", "--agents", "2", "--episodes", "3"]
    for flags, message in ((["--param", "pole_mas=0.2"], "unknown parameter 'pole_mas'"),
                           (["--param", "pole_mass=heavy"], "argument --param: must be a finite number"),
                           (["--param", "pole_mass"], "argument --param: must be NAME=VALUE"),
                           (["--param", "pole_mass=0.2", "--param", "pole_mass=0.3"],
                            "--param pole_mass is given more than once"),
                           (["--randomise", "force=5"], "must be a range LOW:HIGH"),
                           (["--observation-noise", "x=0.1"], "unknown state variable 'x'"),
                           (["--action-delay", "1.5"], "argument --action-delay: must be an integer")):
        status, _, err = run_cli(base + flags, capsys)
        assert status == 2 and len(err) == 1 and message in err[0], (flags, err)
    out_dir = tmp_path / "run"
    status, _, _ = run_cli(base + ["--param", "pole_mass=0.2", "--randomise", "force=5:12",
                                   "--action-delay", "1", "--observation-noise", "pole_angle=0.01",
                                   "--action-noise", "0.5", "--out", str(out_dir)], capsys)
    assert status == 0
    table = outputs.read_table(out_dir / "episodes.csv")
    assert list(table.columns)[-1] == "force" and table["force"].between(5, 12).all()
    config = RunConfig(task="cartpole.balance", plant="analytic", agents=2, episodes=3,
                       params={"pole_mass": 0.2}, randomise={"force": (5.0, 12.0)}, action_delay=1,
                       observation_noise={"pole_angle": 0.01}, action_noise=0.5)
    _, results = run(config)
    np.testing.assert_array_equal(table["steps"], results.steps.ravel())
    np.testing.assert_array_equal(table["force"], results.physical["force"].ravel())


def test_kept_agents_are_evaluated_through_the_sweep_as_alone(tmp_path):
    """Training keeps its agents; evaluations over a grid (one batch, each cell's agents at
    its values) equal evaluating the trained agents cell by cell; a second sweep computes
    nothing; the randomised training's tables have a column per drawn parameter."""
    trained = RunConfig(task="cartpole.balance", plant="analytic", agents=2, episodes=4, seed=1,
                        randomise={"pole_mass": (0.05, 0.2)}, task_options={"time_limit": 4.0})
    table, computed = sweep.run_sweep([trained], tmp_path, keep_agents=True)
    assert computed == 1 and table["pole_mass"].between(0.05, 0.2).all()
    cells = [{"pole_mass": mass} for mass in (0.05, 0.4)] + [{}]
    evaluations = [dataclasses.replace(trained, randomise={}, params=params, trained=trained.key,
                                       learn=False, greedy=True, episodes=2, seed=50)
                   for params in cells]
    assert len(sweep.batches(evaluations)) == 1
    results, computed = sweep.run_sweep(evaluations, tmp_path)
    assert computed == 3
    agent, _ = run(trained)
    for config in evaluations:
        kept = make_agents(config)
        kept.weights[:] = agent.weights
        kept.arrays.streams[:] = agent.arrays.streams
        _, alone = run(config, agents=kept, learn=False, greedy=True)
        rows = results[results["run"] == config.key]
        np.testing.assert_array_equal(rows["steps"], alone.steps.ravel())
    assert sweep.run_sweep(evaluations, tmp_path)[1] == 0


def test_the_c_controller_acts_as_the_python_agent(tmp_path):
    """`lwrl_act` compiled as a shared library and called through ctypes picks the Python
    agent's greedy action on a grid of states, and its episodes over a small grid of
    parameter values are the Python agent's."""
    config = RunConfig(task="pendulum.swingup", plant="analytic", agents=1, episodes=5, seed=2,
                       task_options={"time_limit": 4.0})
    agent, _ = run(config)
    path = tmp_path / "agent.npz"
    agent_io.save(path, agent, {"config": dataclasses.asdict(config)})
    library = controller.build(path, str(tmp_path / "c"))
    c = controller.CController(library, 1)
    angles, speeds = np.meshgrid(np.linspace(-np.pi, np.pi, 15), np.linspace(-3, 3, 15))
    states = np.column_stack([angles.ravel(), speeds.ravel()])
    q = agent.action_values(states)[0]
    assert np.all(np.abs(q[:, 0] - q[:, 1]) > 0)  # no ties: the greedy action is one
    np.testing.assert_array_equal([c.act(state) for state in states], q.argmax(axis=1))
    cells = [dataclasses.replace(config, params=params, trained="x", learn=False, greedy=True,
                                 episodes=2)
             for params in ({"mass": 0.5}, {}, {"torque": 8.0, "mass": 2.0})]
    ours = controller.run_controller(library, cells, [config.seed] * len(cells))
    for b, cell in enumerate(cells):
        loaded, _ = agent_io.load(path)
        _, python = run(cell, agents=loaded, learn=False, greedy=True)
        np.testing.assert_array_equal(ours.steps[b], python.steps[0])
        np.testing.assert_array_equal(ours.returns[b], python.returns[0])


def test_each_domain_names_its_robustness_parameters():
    """One or two of its parameters, as the robustness page (docs/guide/robustness.md)
    lists them."""
    for name, domain in tasks.DOMAINS.items():
        axes = ROBUSTNESS.of(name).axes
        assert 1 <= len(axes) <= 2
        assert set(axes) <= set(domain.parameters.names)
    listed = "; ".join(f"{name} " + " x ".join(f"`{axis}`" for axis in ROBUSTNESS.of(name).axes)
                       for name in tasks.DOMAINS)
    page = (pathlib.Path(__file__).resolve().parents[1] / "docs" / "guide" / "robustness.md")
    assert listed in " ".join(page.read_text().split())


def test_the_plan_covers_every_learner_and_cell():
    """Every learner that fits the task (the population learners where JAX is installed), a
    learner of continuous actions on the task made with them, but the population learners
    on a plant other than the analytic one."""
    task = "cartpole.balance"
    trainings = plan.trainings(task, "analytic")
    fitting = {name: learner for name, learner in learners.LEARNERS.items()
               if learner.fits(task_spec(task, actions=learner.actions)) is None
               and learner.unavailable() is None}
    assert {learner for learner, _ in trainings} == set(fitting)
    assert {config.actions for config in trainings.values()} == {"discrete", "continuous"}
    for (name, _), config in trainings.items():
        assert config.actions == learners.LEARNERS[name].actions
    assert set(plan.learners_for(task, "mujoco")) == {name for name, learner in fitting.items()
                                                      if not learner.population}
    cells = plan.cells(task)
    assert len(cells) == len(plan.FACTORS) ** 2 + len(plan.NOISE_LEVELS) - 1 + len(plan.DELAYS) - 1
    assert len({plan.evaluation(task, trainings[next(iter(trainings))], cell, 1).key
                for cell in cells}) == len(cells)
    heavy = plan.values(task, plan.Cell((4.0, 0.25)))
    assert heavy == {"pole_mass": 0.4, "force": 2.5}


def test_lwrl_robustness_writes_its_report_and_resumes(tmp_path, capsys):
    """`--quick` on Mountain-Car with a learner of each loop but the JAX populations' (whose
    own study test compiles their programs): the compiled loop's learners whose controllers
    run in C, and the stepped loop's first where one is installed (each learner's own cells:
    `test_every_learner_goes_on_with_its_kept_agents_in_several_cells_at_once`). The report
    names the command, every learner asked for, the C controller's agreement; a second call
    computes nothing and writes it again."""
    out = tmp_path / "study"
    stepped = [name for name in plan.learners_for("mountain_car.cost_to_go")
               if learners.learner(name).step is None and not learners.learner(name).population]
    names = [*study.C_LEARNERS, *stepped[:1]]  # none where the baselines are not installed
    argv = ["robustness", "mountain_car.cost_to_go", "--learners", ",".join(names), "--quick",
            "--out", str(out)]
    status, _, _ = run_cli(argv, capsys)
    assert status == 0
    report = (out / "report.md").read_text()
    assert f"lwrl robustness mountain_car.cost_to_go --learners {','.join(names)} --quick" in report
    for name in names:
        assert f"| {name} | nominal |" in report and f"| {name} | randomised |" in report
    cells = len(plan.cells("mountain_car.cost_to_go", quick=True))
    for name in study.C_LEARNERS:  # one of each kind of action
        assert (f"The C controller of {name} (`lwrl.export.c.export_c` of agent 0 of its nominal "
                "training") in report
    assert report.count(f"in {cells} of {cells} cells") == len(study.C_LEARNERS)
    assert os.path.exists(out / "figures" / "mountain_car_cost_to_go.png")
    status, _, _ = run_cli(argv, capsys)
    again = (out / "report.md").read_text()
    assert status == 0 and ", 0 computed by this command" in again
    assert "in 1 invocation of the command" in again  # the first call's time, kept
    for bad in (["mountain_car.climb"], ["pendulum.swingup", "--agents", "1"],
                ["pendulum.swingup", "--learners", "ase_ace"],
                ["pendulum.swingup", "--evaluation-episodes", "0"]):
        status, _, err = run_cli(["robustness", *bad, "--out", str(tmp_path / "bad")], capsys)
        assert status == 2 and len(err) == 1, (bad, err)
    assert not (tmp_path / "bad").exists()


@pytest.mark.skipif(importlib.util.find_spec("ray") is None,
                    reason="Ray is an optional extra: pip install -e '.[ray]' to run this test")
def test_a_study_on_ray_gives_the_local_results(tmp_path):
    """The trainings, whose agents are kept, and the evaluations that go on with them, sent
    to a local Ray instance (`lwrl robustness --backend ray`): every measure as on the local
    backend. One learner of each loop that Ray's workers run (the compiled loop's paper
    agent, the stepped loop's DQN where installed, the quicker of SB3's PPO and DQN): what
    Ray carries does not depend on which learner of a loop it is."""
    from lwrl.studies.robustness.study import study_task

    task = "mountain_car.cost_to_go"
    names = [name for name in plan.learners_for(task) if name in ("sarsa", "dqn")]
    local = study_task(task, str(tmp_path / "local"), quick=True, learners=names)
    on_ray = study_task(task, str(tmp_path / "ray"), quick=True, sweep={"backend": "ray"},
                        learners=names)
    assert on_ray.computed == local.computed == local.runs
    assert on_ray.per_agent.keys() == local.per_agent.keys()
    for key, values in local.per_agent.items():
        np.testing.assert_array_equal(on_ray.per_agent[key], values)


def test_the_wall_time_is_summed_over_the_invocations_that_computed_a_studys_runs(tmp_path):
    """A resumed study adds its time; one that computed nothing adds none; a study of the
    same task with other runs in the same directory, or one that found none of its runs
    (the record kept, the runs not), starts its own record."""
    from lwrl.studies.robustness.study import add_time

    assert add_time(tmp_path, "pendulum.swingup", ["a", "b"], 5.0)["seconds"] == 5.0
    assert add_time(tmp_path, "pendulum.swingup", ["b", "a"], 0.0)["invocations"] == 1
    resumed = add_time(tmp_path, "pendulum.swingup", ["a", "b"], 3.0)
    assert (resumed["seconds"], resumed["invocations"]) == (8.0, 2)
    grown = add_time(tmp_path, "pendulum.swingup", ["c", "a", "b"], 1.0)
    assert (grown["seconds"], grown["invocations"]) == (9.0, 3)  # a learner joined the study
    other = add_time(tmp_path, "pendulum.swingup", ["a", "c"], 2.0)
    assert (other["seconds"], other["invocations"]) == (2.0, 1)
    again = add_time(tmp_path, "pendulum.swingup", ["a", "c"], 4.0, resumed=False)
    assert (again["seconds"], again["invocations"]) == (4.0, 1)


def test_a_learner_of_the_stepped_loop_trains_the_benchmarks_agents_with_its_tuned_settings():
    """DQN and PPO (where installed) take part with at most `STEPPED_AGENTS` agents,
    rl-baselines3-zoo's sets and the benchmark's episodes (the cart-pole's 30 of 60 s), and
    are evaluated on the task's own episodes as every learner is; SAC and TD3 so too, with
    their defaults (the zoo's Pendulum-v1 sets); their JAX ports (where
    JAX is installed) with the same sets and episodes, but the count of agents asked for;
    the compiled loop's learners keep the count asked for, the paper's protocol and their
    defaults (their runs' keys unchanged)."""
    from lwrl.runners.config import tuned_settings
    from lwrl.studies.paper.episode_budgets import episode_budgets

    task = "cartpole.balance"
    stepped = episode_budgets()  # as lwrl robustness passes them
    trainings = plan.trainings(task, "analytic", agents=30, stepped=stepped)
    for (name, _), config in trainings.items():
        learner = learners.LEARNERS[name]
        if learner.compiles:
            assert config.agents == 30 and config == RunConfig(
                task=task, learner=name, plant="analytic", agents=30, randomise=config.randomise,
                actions=learner.actions)
        else:
            if learner.population:
                assert config.agents == 30
            else:
                assert config.agents == plan.STEPPED_AGENTS < 30
            assert (config.episodes, config.task_options) == (30, {"time_limit": 60.0}) == (
                stepped[task])
            assert tuned_settings(task, name) or not learner.tuned  # SAC, TD3: their defaults
            for setting, value in tuned_settings(task, name).items():
                assert getattr(config.settings, setting) == value
        evaluation = plan.evaluation(task, config, plan.cells(task)[0], 3)
        assert evaluation.task_options == {} and evaluation.episodes == 3
    assert plan.agents_for(task, "dqn", 2) == 2
    assert plan.agents_for(task, "dqn_jax") is None  # the task's protocol: 10 agents
    assert plan.agents_for(task, "dqn") == plan.STEPPED_AGENTS
    assert plan.stepped_protocol(task, "dqn", 7, quick=False, stepped=stepped) == (7, {})
    assert plan.stepped_protocol(task, "ppo_jax", None, quick=False, stepped=stepped) == (
        30, {"time_limit": 60.0})


def test_lwrl_robustness_gives_the_stepped_learners_the_benchmarks_episodes(tmp_path, capsys,
                                                                            monkeypatch):
    """The command passes the benchmark's episodes on to the study, and its sweep flags."""
    from lwrl.studies.paper.episode_budgets import episode_budgets
    from lwrl.studies.robustness import robustness

    passed = {}
    monkeypatch.setattr(robustness, "robustness", lambda *args, **options: passed.update(options)
                        or str(tmp_path / "report.md"))
    status, _, _ = run_cli(["robustness", "cartpole.balance", "--out", str(tmp_path / "study"),
                            "--backend", "ray", "--workers", "2"], capsys)
    assert status == 0
    assert passed["stepped"] == episode_budgets()
    assert passed["stepped"]["cartpole.balance"] == (30, {"time_limit": 60.0})
    assert passed["sweep"] == {"backend": "ray", "workers": 2, "address": None}


TAKE_OVER = "dqn_jax"
"""The population learner the take-over is checked on: the JAX populations share one
`take_over` (`PopulationAgents`, a copy of every leaf of the state), and DQN's state holds
the most kinds of leaf (networks, target, optimiser, replay buffer)."""


@pytest.mark.parametrize("name", [name for name, learner in learners.LEARNERS.items()
                                  if learner.fits(RunConfig(task="mountain_car.cost_to_go").task_spec) is None
                                  and learner.unavailable() is None
                                  and (not learner.population or name == TAKE_OVER)])
def test_every_learner_goes_on_with_its_kept_agents_in_several_cells_at_once(name, tmp_path):
    """An evaluation batch over two cells takes over the kept agents twice
    (`Agents.take_over`): each cell's greedy episodes equal those of the kept agents, loaded
    from their file and run alone in that cell. Of the population learners, `TAKE_OVER`."""
    from lwrl.runners.config import tuned_settings

    task = "mountain_car.cost_to_go"
    trained = RunConfig(task=task, learner=name, agents=2, episodes=2, seed=3,
                        task_options={"time_limit": 40.0}, **tuned_settings(task, name))
    sweep.run_sweep([trained], tmp_path, keep_agents=True)
    cells = [dataclasses.replace(trained, params=params, trained=trained.key, learn=False,
                                 greedy=True, episodes=2, seed=40)
             for params in ({"thrust": 0.0015}, {})]
    assert len(sweep.batches(cells)) == 1
    results, _ = sweep.run_sweep(cells, tmp_path)
    for config in cells:
        kept, _ = agent_io.load(sweep.RunStore.agents_file(tmp_path, trained.key))
        _, alone = run(config, agents=kept, learn=False, greedy=True)
        rows = results[results["run"] == config.key]
        np.testing.assert_array_equal(rows["steps"], alone.steps.ravel())
        np.testing.assert_array_equal(rows["return"], alone.returns.ravel())
    with pytest.raises(ValueError, match="whole multiple"):
        make_agents(dataclasses.replace(trained, agents=3)).take_over(kept)


@pytest.mark.skipif(missing_jax(), reason="the population learners need the jax extra: "
                    "pip install 'lwrl[jax]'")
def test_the_population_learners_share_one_take_over():
    """Why `TAKE_OVER` alone of the population learners is checked taking over in several
    cells: none has a `take_over` of its own."""
    import importlib

    from lwrl.agent.jax_population import PopulationAgents
    for name, learner in learners.LEARNERS.items():
        if learner.population:
            module = importlib.import_module(learner.make.__module__)
            kinds = [kind for kind in vars(module).values()
                     if isinstance(kind, type) and issubclass(kind, PopulationAgents)]
            assert kinds and all(kind.take_over is PopulationAgents.take_over for kind in kinds), name


def test_diverged_kept_agents_are_taken_over_as_they_ended():
    """A kept agent whose weights diverged to NaN is taken over with its NaN (an evaluation
    of a search's diverged configuration), not refused as a learner's foreign arrays."""
    config = RunConfig(task="mountain_car.cost_to_go", agents=2, seed=3)
    kept = make_agents(config)
    kept.saved()[1]["weights"][0] = np.nan
    agents = make_agents(dataclasses.replace(config, agents=4))
    agents.take_over(kept)
    weights = agents.saved()[1]["weights"]
    assert np.isnan(weights[[0, 2]]).all() and not np.isnan(weights[[1, 3]]).any()


@pytest.mark.skipif(missing_jax(), reason="the population learners need the jax extra: "
                    "pip install 'lwrl[jax]'")
def test_a_quick_study_trains_evaluates_and_reports_a_population_learner(tmp_path, monkeypatch):
    """`dqn_jax` in the cart-pole's quick study (alone, to keep it short: every learner is in
    `test_lwrl_robustness_writes_its_report_and_resumes`'s): trained on the paper's plant
    and with randomised physics (its draws in the table) and kept, then evaluated greedily
    from the kept agents in every cell at once (one batch of cells of their own physics,
    noise and delays: two compiled programs in all), measured and reported."""
    from lwrl.studies.robustness import report
    from lwrl.studies.robustness.study import study_task

    task = "cartpole.balance"
    assert "dqn_jax" in plan.learners_for(task)
    monkeypatch.setattr(plan, "learners_for", lambda task, plant: ["dqn_jax"])
    result = study_task(task, str(tmp_path), quick=True)
    assert result.computed == result.runs == 2 * (1 + len(result.cells))
    randomised = result.trainings["dqn_jax", "randomised"]
    assert randomised.agents == plan.QUICK["agents"]
    drawn = sweep.RunStore(tmp_path).read([randomised])
    for name, (low, high) in randomised.randomise.items():
        assert drawn[name].between(low, high).all() and drawn[name].nunique() == len(drawn)
    kept, _ = agent_io.load(sweep.RunStore.agents_file(tmp_path, randomised.key))
    assert kept.learner.name == "dqn_jax" and kept.batch_size == plan.QUICK["agents"]
    uptime = {cell: result.per_agent["dqn_jax", "nominal", cell, "uptime_s"]
              for cell in result.cells}
    assert all(values.shape == (2,) and np.all(np.isfinite(values)) for values in uptime.values())
    late = next(cell for cell in result.cells if cell.delay)
    assert len({tuple(uptime[cell]) for cell in result.grid_cells()}) > 1  # each its physics
    assert not np.array_equal(uptime[late], uptime[plan.Cell((1.0, 1.0))])  # and its delay
    section = report.section(result, "figure.png")
    assert "| dqn_jax | nominal |" in section and "| dqn_jax | randomised |" in section
    assert report.figure(result, str(tmp_path / "figures"))


def test_a_quick_study_trains_evaluates_and_reports_a_continuous_learner(tmp_path):
    """`actor_critic` alone in the pendulum's quick study: trained on the task made with
    continuous actions (the torque in [-1, 1] of its range), on the paper's plant and with
    randomised physics, evaluated greedily in every cell, measured and reported, and its
    exported C controller, whose `lwrl_act` returns a real (`CController` with a double
    return type), run in every cell through ctypes: its episodes are the Python agent's, the
    same steps and the returns to round-off (`study.CONTINUOUS_RETURNS`): the double
    controller's action differs from the Python agent's by an ulp or so (its sums run in
    another order), which the plant carries into the return's last bits (2.4e-16 of it in
    one of the cells here)."""
    from lwrl.studies.robustness import report

    task = "pendulum.swingup"
    assert "actor_critic" in plan.learners_for(task)
    result = study.study_task(task, str(tmp_path), quick=True, learners=["actor_critic"])
    assert result.computed == result.runs == 2 * (1 + len(result.cells))
    assert {config.actions for config in result.trainings.values()} == {"continuous"}
    assert list(result.controllers) == ["actor_critic"] == [
        name for name in study.C_LEARNERS if learners.LEARNERS[name].actions == "continuous"]
    ran = result.controllers["actor_critic"]
    assert ran["same"] == ran["cells"] == len(result.cells)
    assert all(values.shape == (2,) and np.all(np.isfinite(values))
               for (_, _, _, column), values in result.per_agent.items() if column == "uptime_s")
    source = pathlib.Path(ran["source"]).read_text()
    assert "lwrl_real lwrl_act(const lwrl_real *state)" in source
    section = report.section(result, "figure.png")
    assert "| actor_critic | nominal |" in section and "| C actor_critic |" in section
    assert f"in {len(result.cells)} of {len(result.cells)} cells" in section


def test_an_interrupted_study_that_finished_no_run_adds_no_time(tmp_path, monkeypatch):
    """Its interrupted batch is computed again by the next call, which counts that time."""
    from lwrl.studies.robustness import study

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt
    monkeypatch.setattr(study, "run_sweep", interrupted)
    with pytest.raises(KeyboardInterrupt):
        study.study_task("mountain_car.cost_to_go", str(tmp_path), quick=True)
    assert not (tmp_path / study.TIMINGS).exists()
