"""The third benchmark's compute plan (studies/paper/benchmark/compute_plan.py): the search's
ledger's rates (SAC's row's hours, the deep rows' cost beside the paper's agent's), the search's
agent-budgets by successive halving counted by hand, a learner the ledger does not count
borrowing its stand-in's rate, and one row's hours recomputed from the ledger's rates and
the design's counts."""

import pathlib

import numpy as np
import pandas as pd
import pytest

from lwrl.studies.paper.benchmark import compute_plan, evaluation, study

BENCHMARK2 = pathlib.Path(__file__).resolve().parents[1] / "docs" / "benchmark2"


def test_ledger_rates():
    rates = compute_plan.ledger_rates(BENCHMARK2).set_index(["task", "learner", "run"])
    sac = rates.loc["pendulum.swingup-continuous", "sac_jax", "training"]
    # SAC's row alone took 4.3 h of the ledger's CPU; its search's configurations the rest
    assert 4.3 * 3600 < sac.cpu_s < 8 * 3600
    # the deep rows' learning costs hundreds of times the paper's agent's per agent-step
    paper = rates.loc["acrobot.swingup", "sarsa", "training"].cpu_s_per_agent_step
    assert rates.loc["acrobot.swingup", "dqn_jax", "training"].cpu_s_per_agent_step > 100 * paper
    assert np.all(rates.cpu_s_per_agent_step > 0)


def test_search_budgets_by_hand(monkeypatch):
    # 32 x 2 at 1/8; 8 configurations: 2 seeds go on from 1/8 to 1/2, 2 new ones run 1/2;
    # 2 configurations: 4 seeds go on from 1/2 to 1, 6 new ones run 1
    monkeypatch.setattr(compute_plan, "SEARCH_RUNGS", ((32, 2, 0.125), (8, 4, 0.5), (2, 10, 1.0)))
    assert compute_plan.search_budgets() == pytest.approx(8 + (6 + 8) + (4 + 12))
    assert compute_plan.search_evaluations() == 64 + 32 + 20


def test_stand_ins_and_unknown_learners():
    rates = pd.DataFrame({"task": ["t"] * 2, "learner": ["ppo_jax"] * 2,
                          "run": ["training", "evaluation"], "cpu_s": [10.0, 1.0],
                          "agent_steps": [1000, 100]})
    assert compute_plan.rate(rates, "stream_q", "training") == (0.01, "ppo_jax")
    assert compute_plan.rate(rates, "ppo_jax", "evaluation") == (0.01, "ppo_jax")
    with pytest.raises(ValueError, match="counts no training of 'mystery'"):
        compute_plan.rate(rates, "mystery", "training")


def test_one_row_recomputed():
    rates = compute_plan.ledger_rates(BENCHMARK2)
    runs = study.study_task("acrobot.swingup", str(BENCHMARK2))
    planned = compute_plan.plan({"acrobot.swingup": runs}, rates, variants=())
    dqn = planned.set_index("row").loc["dqn"]
    dqn_rates = rates[rates.learner == "dqn_jax"].set_index("run")
    train = dqn_rates.cpu_s["training"] / dqn_rates.agent_steps["training"]
    greedy = dqn_rates.cpu_s["evaluation"] / dqn_rates.agent_steps["evaluation"]
    episode = compute_plan.episode_steps(runs)["dqn"]
    episodes = ((compute_plan.EVALUATIONS - compute_plan.VERDICTS) * compute_plan.FINE_EPISODES
                + compute_plan.VERDICTS * evaluation.EPISODES)
    training = 100_000 * (compute_plan.RIVAL_AGENTS + compute_plan.search_budgets())
    greedy_steps = episode * (compute_plan.RIVAL_AGENTS * episodes
                              + compute_plan.search_evaluations() * evaluation.EPISODES)
    assert dqn.agents == compute_plan.RIVAL_AGENTS
    assert dqn.cpu_h == pytest.approx((training * train + greedy_steps * greedy) / 3600)
    # the linear rows take more agents and far fewer hours; the new rivals are planned
    rows = planned.set_index("row")
    assert rows.loc["paper"].agents == compute_plan.LIGHT_AGENTS
    assert rows.loc["paper"].cpu_h < dqn.cpu_h / 20
    assert {"ars", "stream_q", "stream_ac"} <= set(rows.index)
