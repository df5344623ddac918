"""Stalled starts read from run tables (studies/paper/benchmark/stalled_starts.py): episodes at
the time limit before the first goal are counted, the budget's cut is not, a seed's longer
training speaks for it, and names that hold two configurations are refused in one line."""

import pandas as pd
import pytest

from lwrl import outputs
from lwrl.studies.paper.benchmark import stalled_starts

PREFIX = "acrobot.swingup-analytic-dqn_jax-64x64-lr0.001-t100"


def table(run, budget, episodes, rate=0.001, learn=True, trained=""):
    """A run table of `episodes`: per agent (seed, [(steps, truncated), ...])."""
    rows = [{"run": run, "task": "acrobot.swingup", "learning_rate": rate,
             "episodes": 10, "agents": len(episodes), "budget": budget, "learn": learn,
             "greedy": not learn, "trained": trained, "agent": agent, "seed": seed,
             "episode": i + 1, "steps": steps, "return": -steps, "uptime_s": float("nan"),
             "truncated": cut, "diverged": False}
            for agent, (seed, runs) in enumerate(episodes) for i, (steps, cut) in enumerate(runs)]
    return pd.DataFrame(rows)


def write(directory, name, frame):
    (directory / "runs").mkdir(exist_ok=True)
    outputs.write_table(frame, directory / "runs" / f"{name}.csv.gz")


@pytest.fixture
def benchmark(tmp_path, monkeypatch):
    """A directory of one configuration's runs: a training of the task's whole budget (100
    steps here), a shorter one of the same seeds, and the whole one's greedy evaluation."""
    monkeypatch.setitem(stalled_starts.protocol.BUDGETS, "acrobot.swingup", 100)
    train = f"{PREFIX}-s0-aaaa"
    write(tmp_path, train, table(train, 100, [(0, [(40, True), (30, False), (30, True)]),
                                              (1, [(20, False), (80, True)]),
                                              (2, [(40, True), (40, True), (20, True)])]))
    short = f"{PREFIX}-s0-bbbb"
    write(tmp_path, short, table(short, 40, [(0, [(40, True)]), (1, [(20, False), (20, True)]),
                                             (2, [(40, True)])]))
    greedy = f"{PREFIX}-s10000-cccc"
    write(tmp_path, greedy, table(greedy, 0, [(10000, [(5, False)]), (10001, [(40, True)]),
                                              (10002, [(40, True)])], learn=False, trained=train))
    return tmp_path


def test_time_limits_before_the_goal_are_counted_and_the_budgets_cut_is_not(benchmark):
    agents = stalled_starts.agents(str(benchmark), PREFIX)
    assert agents["seed"].tolist() == [0, 1, 2]
    assert agents["stalled"].tolist() == [1, 0, 2]
    assert agents["stalled_steps"].tolist() == [40, 0, 80]
    assert agents["reached"].tolist() == [True, False, False]


def test_a_block_of_seeds_gets_the_binomial_chances_of_as_many_stalled_and_as_few(benchmark):
    agents = stalled_starts.agents(str(benchmark), PREFIX)
    blocks = stalled_starts.blocks(agents, 0.5)
    assert blocks[["first", "last", "agents", "stalled"]].values.tolist() == [[0, 2, 3, 2]]
    assert blocks["p_as_many"].iloc[0] == pytest.approx(0.5)
    assert blocks["p_as_few"].iloc[0] == pytest.approx(0.875)


def test_names_that_hold_two_configurations_are_refused_in_one_line(benchmark, capsys):
    other = f"{PREFIX}-s0-dddd"
    write(benchmark, other, table(other, 100, [(0, [(100, True)])], rate=0.01))
    assert stalled_starts.main([str(benchmark), "--runs", PREFIX]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "2 configurations" in error
