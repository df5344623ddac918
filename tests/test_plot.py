"""`lwrl plot RUN_DIR...`: the learning curves of runs `lwrl train --out` wrote, with 95 %
intervals over agents; bad input in one line, exit status 2."""

import re

import numpy as np
import pytest
from conftest import run_cli

pytest.importorskip("matplotlib", reason="lwrl plot needs the paper extra")
from lwrl.cli import plot  # noqa: E402


def test_the_runs_curves_are_drawn_on_one_figure(tmp_path, capsys):
    for name, alpha in (("a", "3.9"), ("b", "1.0")):
        status, _, _ = run_cli(["train", "mountain_car.cost_to_go", "--agents", "3",
                                "--episodes", "4", "--alpha", alpha,
                                "--out", str(tmp_path / name)], capsys)
        assert status == 0
    status, out, _ = run_cli(["plot", str(tmp_path / "a"), str(tmp_path / "b"),
                              "--out", str(tmp_path / "curves.png"), "--log"], capsys)
    assert status == 0
    for extension in ("png", "svg"):
        path = tmp_path / f"curves.{extension}"
        assert path.stat().st_size > 1000 and f"wrote {path}" in out
    svg = (tmp_path / "curves.svg").read_text()
    assert "a: sarsa on mountain_car.cost_to_go" in svg and "b: sarsa" in svg
    assert "steps per episode" in svg


def test_the_default_measure_is_the_up_time_where_every_task_keeps_one():
    assert plot.default_measure(["pendulum.swingup", "cartpole.balance"]) == "uptime_s"
    assert plot.default_measure(["pendulum.swingup", "mountain_car.cost_to_go"]) == "steps"


@pytest.mark.parametrize("argv, message", [
    (["plot", "NO_SUCH_DIR"], "NO_SUCH_DIR: not a run directory (lwrl train --out DIR writes "
                              "config.json and episodes.csv there)"),
    (["plot", "RUN", "--out", "curves.svg"], "--out must name a .png file; got 'curves.svg'"),
    (["plot", "RUN", "--measure", "reward"], "invalid choice: 'reward'"),
])
def test_bad_input_is_one_line_and_status_2(argv, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    status, _, err = run_cli(argv, capsys)
    assert status == 2 and message in err[-1], err  # argparse's usage line may come before


def test_a_curve_by_steps_takes_each_agents_last_finished_episode():
    import pandas as pd

    from lwrl.analysis.plots import curve_by_steps
    table = pd.DataFrame({"seed": [0, 0, 0, 1, 1], "episode": [1, 2, 3, 1, 2],
                          "steps": [10, 10, 10, 15, 30], "return": [1.0, 2.0, 3.0, 5.0, 6.0]})
    steps, grid = curve_by_steps(table, "return", points=4)
    # agent 0 finishes at 10, 20, 30; agent 1 at 15, 45: from 15 (both have one) to 30
    np.testing.assert_allclose(steps, [15.0, 20.0, 25.0, 30.0])
    np.testing.assert_array_equal(grid, [[1.0, 2.0, 2.0, 3.0], [5.0, 5.0, 5.0, 5.0]])


def test_a_curve_by_steps_leaves_out_the_episodes_not_run():
    import pandas as pd

    from lwrl.analysis.plots import curve_by_steps
    table = pd.DataFrame({"seed": [0, 0, 1, 1], "episode": [1, 2, 1, 2],
                          "steps": [10, np.nan, 10, 20], "return": [1.0, np.nan, 2.0, 3.0]})
    steps, grid = curve_by_steps(table, "return", points=2)
    np.testing.assert_allclose(steps, [10.0, 10.0])
    np.testing.assert_array_equal(grid, [[1.0, 1.0], [2.0, 2.0]])


def test_the_last_point_of_a_curve_is_printed_with_its_interval(tmp_path, capsys):
    status, _, _ = run_cli(["train", "mountain_car.cost_to_go", "--agents", "3", "--episodes",
                            "50", "--budget", "600", "--out", str(tmp_path / "run")], capsys)
    assert status == 0
    for flags, where in (([], r"at episode \d+,"), (["--by-steps"], r"at [\d,]+ steps,")):
        status, out, _ = run_cli(["plot", str(tmp_path / "run"), "--out",
                                  str(tmp_path / "c.png"), *flags], capsys)
        assert status == 0 and re.search(f"steps per episode {where} mean over agents", out), out


def test_the_episode_a_budget_cut_is_left_out():
    import pandas as pd

    from lwrl.analysis.plots import without_cut_episodes
    table = pd.DataFrame({"seed": [0, 0, 0, 1, 1, 1], "episode": [1, 2, 3, 1, 2, 3],
                          "steps": [10, 10, 3, 15, 20, np.nan], "truncated": [0, 0, 1, 0, 1, 0]})
    kept = without_cut_episodes(table, step_limit=20)
    # agent 0's last (3 steps, truncated) was cut; agent 1's last ran to the step limit
    assert list(zip(kept["seed"], kept["episode"])) == [(0, 1), (0, 2), (1, 1), (1, 2)]
