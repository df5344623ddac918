"""Smoke test of the speed benchmark (it measures; it asserts no speed)."""

from benchmarks import agent_speed


def test_agent_speed_quick_prints_its_table(capsys):
    agent_speed.main(["--quick"])
    out = capsys.readouterr().out
    assert "| mountain_car.cost_to_go |" in out and "| cartpole.balance |" in out
    assert out.count("(x") == 4 and "Runs measured:" in out
