"""Smoke tests of the `lwrl` command with tiny budgets."""

import csv
import json
import re
import subprocess
import sys

import pytest

from lwrl.cli import main as cli


def test_tasks_lists_every_task_and_plant(capsys):
    assert cli.main(["tasks"]) == 0
    out = capsys.readouterr().out
    assert "mountain_car.cost_to_go" in out and "plants: analytic" in out
    assert "pendulum.swingup" in out and "cartpole.balance" in out and "acrobot.swingup" in out
    assert out.count("plants: mujoco, analytic, mjx (batched only)") == 3


def test_tasks_prints_every_domains_parameters(capsys):
    """`lwrl tasks --parameters`: a table per domain, a row per parameter."""
    from lwrl import tasks

    assert cli.main(["tasks", "--parameters"]) == 0
    out = capsys.readouterr().out
    for name, domain in tasks.DOMAINS.items():
        assert f"`{name}`" in out
        for parameter in domain.parameters.items:
            assert f"| `{parameter.name}` | {parameter.symbol} | {parameter.unit} |" in out


@pytest.mark.parametrize("argv", [
    ["rollout", "cartpole.balance", "--plant", "mujoco", "--steps", "60", "--seed", "1"],
    ["rollout", "pendulum.swingup", "--plant", "analytic", "--integrator", "explicit", "--steps", "20"],
    ["rollout", "cartpole.balance", "--plant", "analytic", "--equations", "kfnnet", "--steps", "20"],
    ["rollout", "mountain_car.cost_to_go", "--steps", "20"],
])
def test_rollout_prints_a_summary(capsys, argv):
    assert cli.main(argv) == 0
    out = capsys.readouterr().out
    assert "random policy" in out and "episode" in out
    assert ("finished episode" in out) or ("no episode finished" in out)
    assert "nan" not in out


def test_rollout_reports_finished_cartpole_episodes(capsys):
    """Random pushes tip the pole within 60 steps: episodes end terminal with return -1."""
    assert cli.main(["rollout", "cartpole.balance", "--steps", "200", "--seed", "0"]) == 0
    out = capsys.readouterr().out
    assert "terminal" in out and "mean return -1.000" in out


@pytest.mark.parametrize("argv, message", [
    (["rollout", "cartpole"], "task must be written DOMAIN.TASK"),
    (["rollout", "cartpole.swing"], "unknown task 'swing'"),
    (["rollout", "mountain_car.cost_to_go", "--plant", "mujoco"], "unknown plant 'mujoco'"),
    (["rollout", "pendulum.swingup", "--steps", "0"], "must be a positive integer"),
    (["rollout", "pendulum.swingup", "--plant", "mjx"], "the mjx plant steps batches only"),
    (["frobnicate"], "invalid choice"),
    (["train", "cartpole.balance", "--alpha", "0"], "alpha must be a finite number > 0; got 0.0"),
    (["train", "cartpole.balance", "--lambda", "1.5"], "lambda must be a number in [0, 1]; got 1.5"),
    (["train", "cartpole.balance", "--epsilon", "2"], "epsilon must be a number in [0, 1]; got 2.0"),
    (["train", "cartpole.balance", "--trace", "eligible"],
     "must be one of replacing, accumulating, replacing_reset"),
    (["train", "cartpole.balance", "--learner", "nobody"], "argument --learner: must be one of sarsa"),
    (["train", "cartpole.balance", "--alpha", "inf"], "argument --alpha: must be a finite number; got 'inf'"),
    (["reproduce", "fig8", "--quick", "--set", "r2=abc"], "--set r2 must be a finite number; got 'abc'"),
    (["train", "cartpole.balance", "--n", "1"], "must be an integer >= 2; got 1"),
    (["train", "pendulum.swing"], "invalid choice: 'pendulum.swing'"),
    (["eval", "/nonexistent.npz"], "no such agent file"),
    (["export", "/nonexistent.npz", "--c", "/tmp/unused"], "no such agent file"),
    (["reproduce", "fig4"], "invalid choice: 'fig4'"),
])
def test_bad_input_is_one_line_and_status_2(argv, message):
    """No traceback: one line on standard error naming what is wrong, exit status 2."""
    result = subprocess.run([sys.executable, "-m", "lwrl.cli", *argv],
                            capture_output=True, text=True)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], result.stderr


def test_mjx_without_jax_names_the_extra():
    """Without JAX (hidden here), `--plant mjx` ends with one line naming the extra."""
    hide_jax = ("import sys; sys.modules['jax'] = None; from lwrl.cli import main; "
                "sys.exit(main.main(['train', 'cartpole.balance', '--plant', 'mjx', "
                "'--agents', '1', '--episodes', '1']))")
    result = subprocess.run([sys.executable, "-c", hide_jax], capture_output=True, text=True)
    assert result.returncode == 2
    assert result.stderr.strip() == ("lwrl train: error: the mjx plant needs JAX and MuJoCo MJX: "
                                     "pip install 'lwrl[mjx]'"), result.stderr


@pytest.mark.parametrize("argv", [["--help"], ["rollout", "--help"], ["tasks", "--help"],
                                  ["train", "--help"], ["eval", "--help"],
                                  ["reproduce", "--help"], ["export", "--help"]])
def test_help(capsys, argv):
    with pytest.raises(SystemExit) as exit_info:
        cli.main(argv)
    assert exit_info.value.code == 0
    assert "usage: lwrl" in capsys.readouterr().out


def test_train_writes_config_and_episodes_and_eval_reads_the_agents(tmp_path, capsys):
    """A tiny training run: per-block means with standard errors, config.json and
    episodes.csv with one row per agent and episode, and a saved agent file that
    `lwrl eval` runs greedily."""
    out, saved = tmp_path / "run", tmp_path / "agents.npz"
    assert cli.main(["train", "mountain_car.cost_to_go", "--episodes", "4", "--agents", "3",
                     "--seed", "5", "--out", str(out), "--save", str(saved)]) == 0
    printed = capsys.readouterr().out
    assert "± " in printed and "seeds 5..7" in printed and "no agent diverged" in printed
    config = json.loads((out / "config.json").read_text())
    assert config["task"] == "mountain_car.cost_to_go" and config["settings"]["alpha"] == 3.9
    with open(out / "episodes.csv") as file:
        rows = list(csv.DictReader(file))
    assert len(rows) == 12
    assert set(rows[0]) >= {"agent", "episode", "steps", "return", "uptime_s", "diverged"}
    assert all(int(row["steps"]) == -float(row["return"]) + 1 for row in rows if row["truncated"] == "0")
    assert cli.main(["eval", str(saved), "--episodes", "2"]) == 0
    assert "3 saved agents, greedy" in capsys.readouterr().out
    assert cli.main(["export", str(saved), "--c", str(tmp_path / "c"), "--agent", "2"]) == 0
    assert "768 bytes of weights" in capsys.readouterr().out  # 8 x 8 neurons x 3 actions x 4 B
    assert (tmp_path / "c" / "lwrl_policy.c").exists() and (tmp_path / "c" / "lwrl_policy.h").exists()


def test_files_written_before_the_settings_were_named_settings_still_read(tmp_path, capsys):
    """An agent file and a run directory that keep the learner's settings under `agent`
    (their name before 2026-12-07): `lwrl eval` runs them with their settings, as it runs
    today's file, and `lwrl export` names their alpha."""
    from lwrl.agent import io as agent_io

    saved, old = tmp_path / "agents.npz", tmp_path / "old.npz"
    assert cli.main(["train", "mountain_car.cost_to_go", "--episodes", "3", "--agents", "2",
                     "--alpha", "2.5", "--epsilon", "0.3", "--save", str(saved)]) == 0
    agents, metadata = agent_io.load(saved)
    config = metadata["config"]
    config["agent"] = config.pop("settings")
    agent_io.save(old, agents, metadata)
    capsys.readouterr()
    printed = []
    for path in (saved, old):
        assert cli.main(["eval", str(path), "--episodes", "2"]) == 0
        printed.append(capsys.readouterr().out.splitlines()[-3:])
    assert printed[0] == printed[1]
    assert cli.main(["export", str(old), "--c", str(tmp_path / "c")]) == 0
    assert "alpha 2.5" in (tmp_path / "c" / "lwrl_policy.c").read_text()


def test_train_reports_diverged_agents(capsys):
    assert cli.main(["train", "mountain_car.cost_to_go", "--trace", "accumulating", "--alpha", "40",
                     "--lambda", "0.99", "--episodes", "10", "--agents", "2"]) == 0
    assert "2 of 2 agents diverged and were frozen: agent 0 (seed 0, episode" in capsys.readouterr().out


def test_train_saves_a_rerun_recording(tmp_path, capsys):
    """`--rrd` writes a recording of the chosen episodes that Rerun can read back."""
    import rerun as rr

    path = tmp_path / "run.rrd"
    assert cli.main(["train", "pendulum.swingup", "--plant", "analytic", "--episodes", "3",
                     "--agents", "2", "--rrd", str(path), "--log-episodes", "1,3",
                     "--log-agents", "1"]) == 0
    printed = capsys.readouterr().out
    assert f"wrote the recording {path} (2 episodes of agent 1)" in printed
    entities = {chunk.entity_path for chunk in rr.chunk.RrdReader(str(path)).stream()}
    assert any(entity.startswith("/signals/reward/agent1_ep0002") for entity in entities)
    assert any(entity.startswith("/scene/pendulum") for entity in entities)


def test_a_single_agent_reads_without_nan(tmp_path, capsys):
    """One agent: "1 agent", its values without "± nan", a note saying why there is no
    standard error, and the run's one-line summary of what it wrote and how long it took."""
    saved = tmp_path / "agent.npz"
    assert cli.main(["train", "mountain_car.cost_to_go", "--episodes", "3", "--agents", "1",
                     "--save", str(saved)]) == 0
    printed = capsys.readouterr().out
    assert ": 1 agent, " in printed and ", 3 episodes" in printed
    assert "nan" not in printed and "±" not in printed.split("\n", 1)[1]
    assert "one agent (seed 0): its own values, no standard error" in printed
    last = printed.strip().splitlines()[-1]
    assert re.fullmatch(rf"done in \d+\.\d s: wrote the agents to {re.escape(str(saved))}", last), last
    assert cli.main(["eval", str(saved), "--episodes", "1"]) == 0
    printed = capsys.readouterr().out
    assert "1 saved agent, greedy, 1 episode each" in printed and "nan" not in printed
    assert re.fullmatch(r"done in \d+\.\d s; nothing written", printed.strip().splitlines()[-1])


def test_undefined_values_are_dashes_with_a_reason(capsys):
    """An interrupted run: the episodes not run are "—" with a note saying why, a block only
    one agent ran has "± —" with its note, never "nan"; the columns align on their "±"."""
    from lwrl.cli import output
    from lwrl.runners.episodes import EpisodeResults

    results = EpisodeResults.empty(3, 10)
    results.steps[:, :4] = [[100, 90, 80, 70], [1200, 110, 95, 85], [130, 100, 90, 60]]
    results.steps[0, 4] = 50
    results.returns[:] = -results.steps
    results.uptime[:] = results.steps * 0.02
    results.interrupted = True
    output.print_results(results, [0, 1, 2], "", with_uptime=True)
    printed = capsys.readouterr().out
    assert "nan" not in printed.lower()
    assert "—: episodes not run (the run was interrupted)" in printed
    assert "± —: one agent ran these episodes, so no standard error" in printed
    table = printed.splitlines()[:11]
    assert table[0].split() == ["episodes", "steps", "return", "up-time", "(s)"]
    assert table[5].split()[:4] == ["5", "50.00", "±", "—"] and set(table[6].split()[1:]) == {"—"}
    marks = {tuple(i for i, char in enumerate(line) if char == "±") for line in table[1:5]}
    assert len(marks) == 1 and len(next(iter(marks))) == 3, table


def test_rollout_leaves_out_up_time_where_a_task_has_none(capsys):
    assert cli.main(["rollout", "mountain_car.cost_to_go", "--steps", "20"]) == 0
    out = capsys.readouterr().out
    assert "up-time" not in out and "nan" not in out
    assert cli.main(["rollout", "cartpole.balance", "--steps", "30"]) == 0
    assert "up-time (s)" in capsys.readouterr().out
