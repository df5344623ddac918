"""`lwrl bench run --no-report` killed (SIGKILL: no handler runs) once some of its tables
are written, while it writes another, then the same command again: every table the same,
byte for byte, as an uninterrupted run's, and nothing of the killed process left behind in
the benchmark's directory."""

import os
import pathlib
import shutil
import signal
import subprocess
import sys
import time

import pandas as pd

from lwrl.runners.store import RunStore
from lwrl.studies.paper.benchmark import evaluation, protocol, study

TASK = "mountain_car.cost_to_go"
COMMITTED = pathlib.Path(__file__).resolve().parents[1] / "docs" / "benchmark2"
ROW = "true_online_sarsa"
"""True online Sarsa's row: its runs take seconds."""
FRACTIONS = (0.1, 0.25)
"""The fractions whose runs are taken away (the shortest trainings)."""


def missing_runs() -> list:
    """The runs taken away: the row's trainings at `FRACTIONS` and their evaluations, as the
    committed benchmark chose them."""
    chosen = study.read_task(TASK, str(COMMITTED)).chosen
    row = next(row for row in protocol.rows(TASK) if row.label == ROW)
    trainings = study.row_trainings(TASK, row, chosen[ROW])
    return [run for fraction in FRACTIONS
            for run in (trainings[fraction], evaluation.evaluation(trainings[fraction]))]


def copy(destination: pathlib.Path, runs) -> pathlib.Path:
    """The committed benchmark on the analytic plant without the tables of `runs`."""
    shutil.copytree(COMMITTED, destination, ignore=shutil.ignore_patterns("mujoco", "figures"))
    for run in runs:
        RunStore(destination, make=False).path(run).unlink()
    return destination


def command(out: pathlib.Path) -> list:
    """The tables' command: `--no-report`, the report's figures and intervals being what
    takes its time and no table's content."""
    return [sys.executable, "-m", "lwrl.cli", "bench", "run", TASK, "--out", str(out),
            "--no-report"]


def files(out: pathlib.Path) -> list:
    """Every file below `out`, by its path relative to it."""
    return [str(path.relative_to(out)) for path in out.rglob("*") if path.is_file()]


def tables(out: pathlib.Path) -> dict:
    return {path.name: path.read_bytes() for path in sorted((out / "runs").glob("*.csv.gz"))}


ATTEMPTS = 3
"""Kills tried before the test gives up: the process may finish every table between two
looks (the host busy), and then there is nothing to kill; a new copy is tried."""


def kill_after_a_table(killed: pathlib.Path, paths: list) -> list:
    """Start the command on `killed`, SIGKILL it once one of `paths` is written and a file
    is being written after it; the names of `paths` written by then."""
    process = subprocess.Popen(command(killed), stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    try:
        while process.poll() is None and not (any(path.exists() for path in paths) and any(
                name.endswith(".partial") for name in os.listdir(killed / "runs"))):
            time.sleep(0.001)  # until it writes a file after one of the tables
        process.send_signal(signal.SIGKILL)
    finally:
        process.wait()
    assert process.returncode in (-signal.SIGKILL, 0), process.returncode
    return [path.name for path in paths if path.exists()] if process.returncode else []


def test_a_killed_run_resumed_writes_the_same_tables_byte_for_byte(tmp_path):
    runs = missing_runs()
    for attempt in range(ATTEMPTS):
        killed = copy(tmp_path / f"killed{attempt}", runs)
        paths = [RunStore(killed, make=False).path(run) for run in runs]
        written = kill_after_a_table(killed, paths)
        if 0 < len(written) < len(paths):
            break
        shutil.rmtree(killed)
    assert 0 < len(written) < len(paths), f"no kill between two tables in {ATTEMPTS} attempts"
    whole = copy(tmp_path / "whole", runs)
    for out in (killed, whole):
        finished = subprocess.run(command(out), capture_output=True, text=True, timeout=600)
        assert finished.returncode == 0, finished.stderr
    assert tables(killed) == tables(whole)
    left = sorted(set(files(killed)) - set(files(whole)))
    assert not left, left  # no claim, no half-written file
    assert sorted(os.listdir(tmp_path)) == [killed.name, "whole"]  # nor the claim on --out
    # the committed tables were written before a column (`actions`) was: as read, the same
    for run in runs:
        pd.testing.assert_frame_equal(RunStore(killed).read([run]), RunStore(COMMITTED).read([run]),
                                      check_like=True)
