"""Smoke test of the speed benchmark (it measures; it asserts no speed)."""

from benchmarks import agent_speed


def test_agent_speed_quick_prints_its_table(capsys):
    agent_speed.main(["--quick"])
    out = capsys.readouterr().out
    assert "| mountain_car.cost_to_go |" in out and "| cartpole.balance |" in out
    assert out.count("(x") == 4 and "Runs measured:" in out


def test_logging_overhead_is_never_negative():
    """A difference of medians within the repeats' spread, or below zero, is noise."""
    from benchmarks.rerun_logging import overhead

    assert overhead(10.0, 10.5, 0.1) == "5.0 %"
    assert overhead(10.0, 10.05, 0.1) == "within noise (spread 1.0 %)"
    assert overhead(10.0, 8.65, 0.3) == "within noise (spread 3.0 %)"
