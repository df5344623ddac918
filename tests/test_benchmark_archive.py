"""The first benchmark is an archive (docs/benchmark): its commands are gone from `lwrl bench`
and refused in one line, its report names the commit that computed it, and what other parts
took from its code keeps their committed runs' keys: the second benchmark's rows
(`protocol.linear_rows` and the deep rows: every configuration of every row's search is a
committed run, on both plants) and the episodes with which the implementations study trains
DQN and PPO (`studies/paper/episode_budgets.py`)."""

import pathlib
import re
import subprocess

import pytest
from conftest import run_cli

from lwrl.studies.implementations import plan as implementations_plan
from lwrl.studies.implementations import study as implementations_study
from lwrl.studies.paper.benchmark import protocol, search
from lwrl.studies.paper.episode_budgets import episode_budgets

DOCS = pathlib.Path(__file__).resolve().parents[1] / "docs"
ARCHIVE = {"analytic": DOCS / "benchmark", "mujoco": DOCS / "benchmark" / "mujoco"}
SECOND = {"analytic": DOCS / "benchmark2", "mujoco": DOCS / "benchmark2" / "mujoco"}


def committed_runs(directory: pathlib.Path) -> set:
    """The keys of the runs whose tables `directory/runs` holds."""
    return {path.name.removesuffix(".csv.gz") for path in (directory / "runs").glob("*.csv.gz")}


@pytest.mark.parametrize("argv", [["bench", "mountain_car.cost_to_go"], ["bench", "first", "all"]])
def test_the_first_benchmarks_commands_are_refused_in_one_line(argv, capsys):
    status, _, err = run_cli(argv, capsys)
    assert status == 2 and len(err) == 1 and "invalid choice" in err[0]
    allowed = err[0].split("choose from")[1]
    assert "'run'" in allowed and "first" not in allowed


@pytest.mark.parametrize("plant", ["analytic", "mujoco"])
def test_the_archived_report_names_the_commit_that_computed_it(plant):
    report = (ARCHIVE[plant] / "README.md").read_text()
    note = report.split("\n")[2]
    assert note.startswith("> **An archive.**") and "never committed" in note
    commit = re.search(r"last computed: by commit ([0-9a-f]{7,40})", note).group(1)
    history = subprocess.run(["git", "rev-parse", "--verify", "--quiet", f"{commit}^{{commit}}"],
                             cwd=DOCS, capture_output=True, text=True)
    shallow = subprocess.run(["git", "rev-parse", "--is-shallow-repository"], cwd=DOCS,
                             capture_output=True, text=True).stdout.strip()
    if history.returncode != 0 and shallow != "false":
        pytest.skip("the repository's history is not here (a shallow clone, or no git)")
    assert history.returncode == 0, f"{commit} is no commit of lwrl's history"


@pytest.mark.parametrize("plant", ["analytic", "mujoco"])
def test_every_search_run_of_the_second_benchmark_is_committed(plant):
    """Each row's settings, `linear_rows`' among them, make the keys of the committed runs:
    a changed row would be a new run, computed again."""
    committed = committed_runs(SECOND[plant])
    for task in protocol.tasks_on(plant):
        runs = search.runs(task, plant)
        assert {row.label for row in protocol.rows(task)} == {label for label, _ in runs}
        missing = [label for (label, _), config in runs.items() if config.key not in committed]
        assert not missing, f"{task}: {missing[:3]} not committed"


def test_the_implementations_study_trains_on_its_committed_runs():
    """`lwrl implementations`' committed command, with the episodes the CLI passes on."""
    cells = implementations_plan.cells(["mountain_car.cost_to_go", "pendulum.swingup"], 10,
                                       episode_budgets())
    keys = {config.key for config in implementations_study.all_configs(cells)}
    assert len(keys) == 80 and keys <= committed_runs(DOCS / "implementations")
