"""The third benchmark's plan (studies/paper/benchmark/planning.py) from the second
benchmark's committed tables, read as they are: the facts the rule quotes (the paper's agent's
scores at the classical level, DQN's cart-pole collapse, the pendulum's detectable
difference), and one line with exit status 2 for a bad flag."""

import pathlib

import pytest

from lwrl.analysis import power
from lwrl.studies.paper.benchmark import planning, protocol, study

BENCHMARK2 = pathlib.Path(__file__).resolve().parents[1] / "docs" / "benchmark2"
DISCRETE = ["mountain_car.cost_to_go", "pendulum.swingup", "cartpole.balance", "acrobot.swingup"]


@pytest.fixture(scope="module")
def plans():
    return {task: {plan.row: plan for plan in planning.plan_task(
                study.study_task(task, str(BENCHMARK2)), protocol.AGENTS)}
            for task in DISCRETE}


def test_saturation_facts(plans):
    # 52 of the paper's agent's 80 final scores (65 %) at the classical level
    assert sum(plans[task]["paper"].saturated[1.0] for task in DISCRETE) == 52
    # DQN's cart-pole: 15 of 20 balancing at half the budget, 7 at the end
    assert plans["cartpole.balance"]["dqn"].saturated[0.5] == 15
    assert plans["cartpole.balance"]["dqn"].saturated[1.0] == 7


def test_pendulum_detectable_difference(plans):
    paper, dqn = plans["pendulum.swingup"]["paper"], plans["pendulum.swingup"]["dqn"]
    assert (paper.sd, dqn.sd) == pytest.approx((0.555, 0.339), abs=0.001)
    # the second benchmark's design (two-sided at 0.05, no correction): about 0.41 by the
    # normal approximation, 0.42 by Welch's t
    assert power.detectable_difference(paper.sd, dqn.sd, 20, 20, 0.025) == pytest.approx(0.42, abs=0.005)
    # the third's one-sided test after Holm over its family: larger
    assert dqn.detectable > 0.55
    assert power.power(paper.sd, dqn.sd, 20, 20, 0.0, dqn.detectable, 0.05,
                       planning.FAMILY) == pytest.approx(power.POWER, abs=1e-6)
    # the agents a row needs for the margin make the detectable difference the margin
    needed = int(dqn.needed)
    assert power.detectable_difference(paper.sd, dqn.sd, needed, needed, 0.05,
                                       planning.FAMILY) <= planning.MARGIN
    assert power.detectable_difference(paper.sd, dqn.sd, needed - 1, needed - 1, 0.05,
                                       planning.FAMILY) > planning.MARGIN


@pytest.mark.parametrize("flags, words", [
    (["--margin", "-0.1"], "margin"),
    (["--family", "0"], "at least 1 test"),
    (["--light-agents", "1"], "--light-agents must be at least 2"),
    (["--variants", "cartpole.swing"], "unknown benchmark task"),
])
def test_bad_flag_is_one_line_and_status_2(capsys, flags, words):
    with pytest.raises(SystemExit) as exit_:
        planning.main([str(BENCHMARK2)] + flags)
    assert exit_.value.code == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("error: ") and words in error and "\n" not in error
