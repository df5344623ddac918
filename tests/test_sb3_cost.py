"""What the second benchmark's deep rows would have cost on Stable-Baselines3 alone
(benchmarks/sb3_cost.py, and the report's sentence, `twin_cost.sentence`), on tables of episodes
written at the runs' keys of Mountain-Car's first configuration of each deep row: the search's
training (3 agents of 1600 steps in 2 episodes) and its greedy evaluation (3 agents of 400
steps). The measurement is timed, its numbers not asserted; the report's arithmetic is, on
rates written by hand."""

import json

import numpy as np
import pytest

from lwrl.agent import jax_population
from lwrl.agent.stable_baselines import missing_libraries
from lwrl.runners.episodes import EpisodeResults
from lwrl.runners.store import RunStore
from lwrl.runners.sweep import results_table
from lwrl.studies.paper.benchmark import evaluation, protocol, report, search, twin_cost

pytestmark = [
    pytest.mark.skipif(bool(missing_libraries()), reason="the twins are Stable-Baselines3's: "
                       "pip install 'lwrl[baselines]' (the baselines extra)"),
    pytest.mark.skipif(jax_population.missing_jax(), reason="the deep rows' runs are of JAX "
                       "population learners: pip install 'lwrl[jax]' (the jax extra)")]

TASK = "mountain_car.cost_to_go"
TRAINING_STEPS = (800, 800)
EVALUATION_STEPS = (200, 200)


def write_runs(out_dir) -> dict:
    """The tables of the search's training and evaluation of configuration 0 of each deep row
    of `TASK` (see the module); `{label: (training, evaluation)}`."""
    store, runs, written = RunStore(out_dir), search.runs(TASK), {}
    for label in protocol.deep(TASK):
        training = runs[label, 0]
        written[label] = (training, evaluation.evaluation(training))
        for config, steps in zip(written[label], (TRAINING_STEPS, EVALUATION_STEPS)):
            results = EpisodeResults.empty(config.agents, len(steps))
            results.steps[:] = steps
            store.write(config, results_table(config, results))
    return written


def test_every_configuration_is_measured_once_and_a_rerun_measures_what_is_missing(
        tmp_path, monkeypatch, capsys):
    from benchmarks import sb3_cost

    written = write_runs(tmp_path)
    sb3_cost.main([str(tmp_path), "--steps", "40"])
    path = tmp_path / twin_cost.SB3_COST
    measured = json.loads(path.read_text())
    assert set(measured) == {training.key for training, _ in written.values()}
    for label, (training, _) in written.items():
        entry = measured[training.key]
        assert (entry["task"], entry["row"], entry["configuration"]) == (TASK, label, 0)
        assert (entry["learner"], entry["twin"]) == (training.learner, label)
        settings = training.settings
        assert entry["settings"]["net_arch"] == settings.net_arch
        warm_up = getattr(settings, "learning_starts", 0)
        period = getattr(settings, "n_steps", None) or settings.train_freq
        assert entry["warm_up_steps"] == entry["steps"]["warm_up"] == warm_up
        assert entry["steps"]["learning"] == max(2 * period, -(-40 // period) * period)
        assert entry["steps"]["greedy"] == 40
        assert all(rate > 0 for name, rate in entry["cpu_s_per_step"].items()
                   if entry["steps"][name])
        assert entry["host"] and entry["lwrl"] and entry["command"].endswith("--steps 40")
    assert "With Stable-Baselines3 alone" in capsys.readouterr().out

    kept = measured.pop(written["dqn"][0].key)
    path.write_text(json.dumps(measured))
    calls = []

    def stub(config, least):
        calls.append(config.learner)
        return {key: kept[key] for key in ("warm_up_steps", "steps", "cpu_s_per_step")}
    monkeypatch.setattr(sb3_cost, "measure", stub)
    sb3_cost.main([str(tmp_path), "--steps", "40"])
    assert calls == ["dqn"]
    again = json.loads(path.read_text())
    assert set(again) == set(measured) | {written["dqn"][0].key}
    assert again[written["ppo"][0].key] == measured[written["ppo"][0].key]


RATES = {"warm_up": 0.36, "learning": 3.6, "greedy": 0.036}
COMMAND = "python -m benchmarks.sb3_cost X"


def priced(tmp_path, ledger: list) -> tuple:
    """`(runs, measured rates, the report's cost line)`: a DQN and a PPO row's runs, their
    twins' rates (`RATES`; DQN warms up for 1000 steps), and the ledger's lines `ledger`
    (`runs` as run labels: `dqn`, `dqn greedy`, or another run's key)."""
    written = write_runs(tmp_path)
    measured = {training.key: {"plant": training.plant, "twin": label, "warm_up_steps": warm_up,
                               "cpu_s_per_step": RATES, "command": COMMAND}
                for (label, (training, _)), warm_up in zip(written.items(), (1000, 0))}
    (tmp_path / twin_cost.SB3_COST).write_text(json.dumps(measured))
    keys = {"dqn": written["dqn"][0].key, "dqn greedy": written["dqn"][1].key}
    lines = [dict(line, runs=[keys.get(run, run) for run in line["runs"]]) for line in ledger]
    (tmp_path / "compute.jsonl").write_text("".join(json.dumps(line) + "\n" for line in lines))
    return written, measured, report.cost_line(str(tmp_path))


def test_the_report_multiplies_each_runs_steps_by_its_configurations_rates(tmp_path):
    """DQN: 3 agents x (1000 warm-up steps at 0.36 s + 600 learning at 3.6 s) + 1200 greedy
    at 0.036 s = 7603.2 s; PPO, no warm-up: 4800 x 3.6 + 1200 x 0.036 = 17323.2 s; 6.92 h
    in all. The ledger's line of DQN's training (the other names a run of no deep row) cost
    2 h on JAX; its estimate is 7560 s, 2.10 h."""
    written, measured, line = priced(tmp_path, [
        {"runs": ["dqn"], "wall_s": 100.0, "cpu_s": 7200.0, "host": "h"},
        {"runs": ["dqn greedy", "another-run"], "wall_s": 1.0, "cpu_s": 1.0, "host": "h"}])
    assert "3 of the 4 runs in `runs/`" in line
    assert ("the deep rows would have cost about 6.92 h of CPU for their 9,600 agent-steps of "
            "training and 2,400 agent-steps of greedy evaluation (dqn 2.11 h, ppo 4.81 h)") in line
    assert ("the ledger counts 1 of their 4 runs, which cost 2.00 h of CPU and would have cost "
            "about 2.10 h") in line
    assert f"measured by `{COMMAND}`" in line
    assert report.cost_line(str(tmp_path), [TASK]) == line  # a report of this task alone
    extra = dict(measured[written["dqn"][0].key], twin="sac", command="python -m elsewhere")
    (tmp_path / twin_cost.SB3_COST).write_text(json.dumps({**measured, "another-run": extra}))
    assert report.cost_line(str(tmp_path)) == line  # a twin of no run here is not named
    assert report.cost_line(str(tmp_path), ["acrobot.swingup"]).endswith(
        "as that run's first steps. No deep row's run is in `runs/`.")  # of other tasks: none of these
    configurations = twin_cost.deep_configurations(str(tmp_path))
    assert [(c.label, c.index, len(c.trainings), len(c.evaluations)) for c in configurations] == [
        ("dqn", 0, 1, 1), ("ppo", 0, 1, 1)]
    table = RunStore(tmp_path).read([written["ppo"][0]])
    assert np.isclose(twin_cost.twin_cpu_s(written["ppo"][0], table, measured[written["ppo"][0].key]),
                      3 * 1600 * 3.6)


def test_a_run_resumed_across_processes_counts_once_with_every_processs_cpu(tmp_path):
    """A run stopped and resumed has two lines (`runners.resume`): the earlier processes'
    hour and this one's two. It is one run of the ledger's, of 3 h of CPU, whose twin
    would have cost 2.10 h, not twice that."""
    _, _, line = priced(tmp_path, [
        {"runs": ["dqn"], "wall_s": 50.0, "cpu_s": 3600.0, "host": "h"},
        {"runs": ["dqn"], "wall_s": 100.0, "cpu_s": 7200.0, "host": "h"}])
    assert "1 of the 4 runs in `runs/`, 0.04 h of wall time and 3.00 h of CPU" in line
    assert ("the ledger counts 1 of their 4 runs, which cost 3.00 h of CPU and would have cost "
            "about 2.10 h") in line


def test_without_measurements_the_report_gives_the_command(tmp_path):
    write_runs(tmp_path)
    line = report.cost_line(str(tmp_path))
    assert f"`python -m benchmarks.sb3_cost {tmp_path}` measures it" in line


@pytest.mark.parametrize("argv", [["nowhere"], [".", "--steps", "0"]])
def test_a_bad_out_dir_or_step_count_is_one_line_and_status_2(argv, tmp_path, monkeypatch, capsys):
    from benchmarks import sb3_cost

    (tmp_path / "runs").mkdir()
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exit_:
        sb3_cost.main(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("python -m benchmarks.sb3_cost: error: ")


def test_on_mujocos_model_the_configurations_are_those_of_its_tasks(tmp_path):
    """The benchmark on MuJoCo's model has no Mountain-Car (`protocol.tasks_on`): its deep
    configurations are found among the tasks with a model, whose deep rows train on mjx."""
    RunStore(tmp_path)
    assert twin_cost.deep_configurations(str(tmp_path), "mujoco") == []
    pendulum = search.runs("pendulum.swingup", "mujoco")["dqn", 0]
    assert pendulum.plant == "mjx"
    RunStore(tmp_path).write(pendulum, results_table(pendulum, EpisodeResults.empty(3, 1)))
    found, = twin_cost.deep_configurations(str(tmp_path), "mujoco")
    assert (found.task, found.label, found.index, found.key) == ("pendulum.swingup", "dqn", 0,
                                                                 pendulum.key)
    assert twin_cost.deep_configurations(str(tmp_path), "mujoco", ["cartpole.balance"]) == []


def test_runs_given_on_the_way_by_a_longer_run_count_once(tmp_path):
    """A row's fractions computed as one family (`runners.sweep.families`): the ledger line
    that names them makes the shorter ones given on the way; a line joining runs of one
    budget, or of other settings, gives none."""
    row = next(row for row in protocol.rows(TASK) if row.label == "dqn")
    settings = search.configurations(TASK, row)
    fractions = [protocol.training(TASK, row, settings[0], 0, protocol.AGENTS, fraction)
                 for fraction in protocol.FRACTIONS]
    other = protocol.training(TASK, row, settings[1], 0, protocol.AGENTS, 0.1)
    ledger = [{"runs": [config.key for config in fractions[1:]], "cpu_s": 1.0},
              {"runs": [fractions[0].key, other.key], "cpu_s": 1.0}]
    (tmp_path / "compute.jsonl").write_text("".join(json.dumps(line) + "\n" for line in ledger))
    assert twin_cost.on_the_way(str(tmp_path), fractions + [other]) == {
        fractions[1].key, fractions[2].key}


def test_checkpoints_written_before_an_interruption_are_given_on_the_way(tmp_path):
    """A family stopped after its shorter fractions were written and resumed to its end
    (`runners.resume`): no ledger line names the shorter runs, whose steps are the longest
    run's first, so they count nothing on the twin's side either; a run no line names
    without a longer run of its family stays counted."""
    row = next(row for row in protocol.rows(TASK) if row.label == "dqn")
    settings = search.configurations(TASK, row)
    fractions = [protocol.training(TASK, row, settings[0], 0, protocol.AGENTS, fraction)
                 for fraction in protocol.FRACTIONS]
    alone = protocol.training(TASK, row, settings[1], 0, protocol.AGENTS, 0.1)
    ledger = [{"runs": [fractions[-1].key], "cpu_s": 2.0}, {"runs": [fractions[-1].key], "cpu_s": 1.0}]
    (tmp_path / "compute.jsonl").write_text("".join(json.dumps(line) + "\n" for line in ledger))
    assert twin_cost.on_the_way(str(tmp_path), fractions + [alone]) == {
        config.key for config in fractions[:-1]}
