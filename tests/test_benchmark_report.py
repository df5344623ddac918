"""The second benchmark's report from the committed benchmark (docs/benchmark2): `lwrl
bench run` on one task keeps every other task's lines and sections; an outside row,
evaluated by the harness (`lwrl.bench`) and scored, enters the leaderboard and moves no
number of the rows; a task whose runs are not all written is named, and nothing is
computed (shown on a copy holding the acrobot and the cart-pole alone, whose report takes
less time to write than the whole one)."""

import difflib
import json
import pathlib
import shutil

import numpy as np
import pytest
from conftest import run_cli

from lwrl import bench

COMMITTED = pathlib.Path(__file__).resolve().parents[1] / "docs" / "benchmark2"
TASK = "mountain_car.cost_to_go"


def pump(observations):
    """Push along the velocity (Mountain-Car's actions: 0 left, 2 right)."""
    return np.where(observations[:, 1] >= 0, 2, 0)


@pytest.fixture
def copy(tmp_path) -> pathlib.Path:
    """The committed analytic benchmark, as a fresh clone has it."""
    return pathlib.Path(shutil.copytree(COMMITTED, tmp_path / "benchmark2",
                                        ignore=shutil.ignore_patterns("mujoco")))


@pytest.fixture
def two_tasks(tmp_path) -> pathlib.Path:
    """The committed analytic benchmark with the acrobot's and the cart-pole's runs, reference
    rows and `configs.jsonl` lines alone, as `lwrl bench run` on those two tasks writes them."""
    kept = ("acrobot.swingup", "cartpole.balance")
    out = pathlib.Path(shutil.copytree(COMMITTED, tmp_path / "two_tasks", ignore=lambda _, names: [
        name for name in names if name in ("mujoco", "figures")
        or name.endswith(".csv.gz") and not name.startswith(kept)]))
    lines = (COMMITTED / "configs.jsonl").read_text().splitlines(keepends=True)
    (out / "configs.jsonl").write_text("".join(line for line in lines
                                               if json.loads(line)["task"] in kept))
    return out


def changed(old: str, new: str) -> tuple:
    """`(lines only in old, lines only in new)`."""
    diff = list(difflib.ndiff(old.splitlines(), new.splitlines()))
    return ([line[2:] for line in diff if line.startswith("- ")],
            [line[2:] for line in diff if line.startswith("+ ")])


def leaderboard(text: str) -> dict:
    """`{(task, row): score}` of the report's leaderboard (its rank left out)."""
    rows = {}
    for line in text.split("## Leaderboard", 1)[1].split("\n## ", 1)[0].splitlines():
        cells = [cell.strip() for cell in line.strip("|").split("|")]
        if len(cells) == 4 and cells[1].isdigit():
            rows[cells[0], cells[2]] = cells[3]
    return rows


def runs(directory: pathlib.Path) -> list:
    return sorted(path.name for path in (directory / "runs").iterdir())


def test_the_report_keeps_every_row_and_takes_an_outside_one_apart(copy, two_tasks, tmp_path,
                                                                    capsys):
    committed = (COMMITTED / "README.md").read_text()
    held = runs(copy)
    evaluations = [bench.evaluate(pump, TASK, None, f) for f in bench.FRACTIONS]
    bench.results(evaluations, "pump").to_csv(tmp_path / "pump.csv.gz", index=False)
    status, _, err = run_cli(["bench", "score", str(tmp_path / "pump.csv.gz"), "--out", str(copy)],
                             capsys)
    assert status == 0, err
    status, _, err = run_cli(["bench", "run", TASK, "--out", str(copy)], capsys)
    assert status == 0, err
    assert runs(copy) == held  # nothing computed
    assert (copy / "configs.jsonl").read_bytes() == (COMMITTED / "configs.jsonl").read_bytes()
    text = (copy / "README.md").read_text()
    board, before = leaderboard(text), leaderboard(committed)
    assert {key: value for key, value in board.items() if key != (TASK, "pump *outside*")} == before
    assert (TASK, "pump *outside*") in board
    outside_lines = {f"| {TASK} | {rank} | pump *outside* |" for rank in range(1, 9)}
    gone, added = changed(committed, text)
    for line in gone + added:  # the header, and the leaderboard's Mountain-Car rows re-ranked
        assert line.startswith("Written by") or line.startswith(f"| {TASK} | "), line
    header = next(line for line in added if line.startswith("Written by"))
    assert header.startswith(f"Written by `lwrl bench run {TASK} --out {copy}` in ")
    assert "129.4 min" not in header  # its own time, not the sum over past calls
    assert sum(any(line.startswith(start) for start in outside_lines) for line in added) == 1

    held, configs = runs(two_tasks), (two_tasks / "configs.jsonl").read_bytes()
    evaluation = next(name for name in held  # a row's greedy evaluation (seed 0 + 10 000)
                      if name.startswith("acrobot.swingup-analytic-") and "-s10000-" in name)
    (two_tasks / "runs" / evaluation).unlink()
    status, _, err = run_cli(["bench", "report", str(two_tasks)], capsys)
    assert status == 0, err
    text = (two_tasks / "README.md").read_text()
    assert ("Not reported, their runs not all written (`lwrl bench status` says what is left, "
            "`lwrl bench run` computes it): acrobot.swingup: rows: 1 of ") in text
    assert "## acrobot.swingup" not in text and "## cartpole.balance" in text
    assert runs(two_tasks) == [name for name in held if name != evaluation]
    assert (two_tasks / "configs.jsonl").read_bytes() == configs


def test_a_directory_that_is_no_benchmark_is_refused(tmp_path, capsys):
    status, _, err = run_cli(["bench", "report", str(tmp_path)], capsys)
    assert status == 2 and len(err) == 1 and "is no benchmark directory" in err[0]
    assert not list(tmp_path.iterdir())
