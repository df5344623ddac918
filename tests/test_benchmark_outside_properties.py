"""The outside-results checker (studies/paper/benchmark/outside.py, `lwrl bench score`) over
arbitrary tables (Hypothesis): every file the harness could write with values in the
protocol's ranges is read as written; a file changed in any way that breaks the protocol (a
column gone, a cell of another type, NaN or infinite, out of range, a row gone or twice,
another version, digest or name) is refused in one line, and `lwrl bench score` leaves the
benchmark directory as it was."""

import math
import pathlib
import shutil

import numpy as np
import pandas as pd
import pytest
from conftest import run_cli
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from lwrl.studies.paper.benchmark import evaluation, harness, outside, protocol

COMMITTED = pathlib.Path(__file__).resolve().parents[1] / "docs" / "benchmark2"
ROWS = len(protocol.FRACTIONS) * protocol.AGENTS * evaluation.EPISODES
TASKS = tuple(protocol.BUDGETS)
EXAMPLES = settings(max_examples=60, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

MISSING = ("", "NA", "N/A", "nan", "NaN", "null", "None", "<NA>", "#N/A")
"""Cells a CSV reader may take for an empty one (pandas's defaults among them)."""
NAMES = st.one_of(st.sampled_from([n for n in MISSING if outside.NAME.fullmatch(n)]),
                  st.from_regex(outside.NAME, fullmatch=True)).filter(
    lambda n: n not in outside.BUILT_IN)
"""Names an outside row may take, those that read as empty cells among them."""
TEXT = st.one_of(st.sampled_from(["\n", "a\nb", "\r", ",", '"', " "]),
                 st.text(st.characters(codec="utf-8", exclude_categories=["Cs"]), max_size=12))
"""Any text a cell may hold, separators, quotes and line breaks among it."""
CELLS = st.one_of(st.none(), st.sampled_from(MISSING), TEXT, st.integers(-2 ** 70, 2 ** 70),
                  st.floats(allow_nan=True, allow_infinity=True), st.none())
"""Any cell: text, a whole number of any size, any double, an empty cell."""


def number(value) -> float | None:
    """`value` as the CSV reader takes a number, None where it is no number."""
    if value is None:
        return None
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError):
        return None


@st.composite
def conforming(draw, task=None):
    """`(task, table)`: the harness's table (`harness.results`) of `evaluations` at every
    fraction with any steps and up-times in the protocol's ranges, from the protocol's starts."""
    task = draw(st.sampled_from(TASKS)) if task is None else task
    cap, seconds = evaluation.step_cap(task), evaluation.episode_seconds(task)
    uptime = evaluation.task_measure(task).column == "uptime_s"
    starts = evaluation.starts(task)
    evaluations = []
    for fraction in protocol.FRACTIONS:
        index = pd.MultiIndex.from_product(
            [[fraction], range(protocol.AGENTS), range(1, evaluation.EPISODES + 1)],
            names=["fraction", "seed", "episode"]).to_frame(index=False)
        size = len(index)
        steps = draw(arrays(np.int64, size, elements=st.integers(1, cap)))
        seconds_up = (draw(arrays(np.float64, size, elements=st.floats(0.0, seconds)))
                      if uptime else np.full(size, np.nan))
        table = index.assign(steps=steps, uptime_s=seconds_up)
        evaluations.append(harness.Evaluation(task, "analytic", fraction, table,
                                              dict(enumerate(starts))))
    return task, harness.results(draw(st.permutations(evaluations)), draw(NAMES))


@st.composite
def broken(draw):
    """`(table, what)`: a conforming table changed in one way that breaks the protocol."""
    task, table = draw(conforming())
    table = table.astype(object)
    row = draw(st.integers(0, ROWS - 1))
    change = draw(st.sampled_from(["column", "column twice", "cell", "cells", "row gone",
                                   "row twice", "recorded", "name"]))
    measured = evaluation.task_measure(task).column
    if change in ("column", "column twice"):
        column = draw(st.sampled_from([*outside.COLUMNS, measured]))
        if change == "column":
            return table.drop(columns=column), f"no {column}"
        at = draw(st.integers(0, len(table.columns)))
        return pd.concat([table.iloc[:, :at], table[[column]], table.iloc[:, at:]], axis=1), (
            f"{column} twice")
    if change == "row gone":
        return table.drop(index=row), "a row gone"
    if change == "row twice":
        return pd.concat([table, table.iloc[[row]]], ignore_index=True), "a row twice"
    if change == "recorded":
        column = draw(st.sampled_from(["protocol", "starts"]))
        value = draw(TEXT.filter(lambda v: v != table.at[0, column]))
        rows = draw(st.sampled_from([[row], list(range(ROWS))]))
        table.loc[rows, column] = value
        return table, f"{column} {value!r}"
    if change == "name":
        value = draw(st.one_of(st.sampled_from(outside.BUILT_IN), TEXT.filter(
            lambda v: not outside.NAME.fullmatch(v))))
        table["learner"] = value
        return table, f"learner {value!r}"
    column = draw(st.sampled_from(["learner", "task", "budget", "fraction", "seed", "episode",
                                   "steps", measured]))
    if change == "cells":  # some cells of one column, none of them a number
        rows = draw(st.lists(st.integers(0, ROWS - 1), min_size=1, max_size=4, unique=True))
        values = draw(st.lists(CELLS.filter(lambda v: number(v) is None), min_size=len(rows),
                               max_size=len(rows)))
        if column in ("learner", "task"):
            assume(any(v is None or str(v) != table.at[0, column] for v in values))
        for at, value in zip(rows, values):
            table.at[at, column] = value
        return table, f"{column} {values!r} in rows {rows}"
    value = draw(CELLS)
    given_ = table.at[row, column]
    if column in ("learner", "task"):
        assume(value is None or str(value) != given_)
    elif column in ("budget", "fraction", "seed", "episode"):
        # another value of a whole table's key breaks it: a value it lacks, or one twice
        assume(number(value) != float(given_))
    else:  # the measures: anything but a whole number of steps, or seconds, in range
        value_ = number(value)
        high = evaluation.step_cap(task) if column == "steps" else evaluation.episode_seconds(task)
        low = 1 if column == "steps" else 0
        assume(value_ is None or not math.isfinite(value_) or not low <= value_ <= high
               or (column == "steps" and value_ % 1 != 0))
    table.at[row, column] = value
    return table, f"{column} {value!r} in row {row}"


def write(table: pd.DataFrame, path: pathlib.Path, gzipped: bool) -> pathlib.Path:
    path = path.with_suffix(".csv.gz" if gzipped else ".csv")
    table.to_csv(path, index=False, compression="gzip" if gzipped else None)
    return path


def contents(directory: pathlib.Path) -> dict:
    return {str(path.relative_to(directory)): path.read_bytes()
            for path in sorted(directory.rglob("*")) if path.is_file()}


def refused(path: pathlib.Path) -> str:
    """The one line `outside.read` refuses the file with (failing the test otherwise)."""
    with pytest.raises(ValueError) as error:
        outside.read(str(path))
    message = str(error.value)
    assert message and "\n" not in message and "\r" not in message, message
    return message


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> pathlib.Path:
    return tmp_path_factory.mktemp("outside")


@pytest.fixture(scope="module")
def benchmark_dir(tmp_path_factory) -> pathlib.Path:
    """A benchmark directory of every task's reference rows (all that scoring reads)."""
    directory = tmp_path_factory.mktemp("benchmark")
    shutil.copy(COMMITTED / "configs.jsonl", directory)
    shutil.copytree(COMMITTED / "references", directory / "references")
    return directory


@EXAMPLES
@given(conforming(), st.booleans())
def test_every_table_on_the_protocol_is_read_as_written(folder, example, gzipped):
    task, table = example
    path = write(table, folder / "good", gzipped)
    read = outside.read(str(path))
    pd.testing.assert_frame_equal(read, table, check_dtype=False)


@settings(EXAMPLES, max_examples=150)
@given(broken(), st.booleans())
def test_a_table_that_breaks_the_protocol_is_refused_in_one_line(folder, example, gzipped):
    table, what = example
    refused(write(table, folder / "bad", gzipped))


@EXAMPLES
@given(st.binary(max_size=400), st.sampled_from([".csv", ".csv.gz"]))
def test_any_bytes_are_refused_in_one_line(folder, data, suffix):
    path = folder / f"bytes{suffix}"
    path.write_bytes(data)
    refused(path)


@EXAMPLES
@given(conforming(TASKS[0]), st.data())
def test_a_damaged_gzip_file_is_refused_in_one_line_or_read_whole(folder, example, data):
    """A compressed file cut short or with bytes changed: refused, or (a change the format
    does not check, e.g. in its header's time) the table as written."""
    task, table = example
    whole = write(table, folder / "whole", True).read_bytes()
    end = data.draw(st.integers(0, len(whole)), label="end")
    damaged = bytearray(whole[:end])
    for _ in range(data.draw(st.integers(0, 3), label="changes") if damaged else 0):
        at = data.draw(st.integers(0, len(damaged) - 1), label="at")
        damaged[at] ^= data.draw(st.integers(1, 255), label="bits")
    path = folder / "damaged.csv.gz"
    path.write_bytes(bytes(damaged))
    try:
        read = outside.read(str(path))
    except ValueError:
        refused(path)
    else:
        pd.testing.assert_frame_equal(read, table, check_dtype=False)


@settings(max_examples=15, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                 HealthCheck.function_scoped_fixture])
@given(broken())
def test_lwrl_bench_score_refuses_them_and_changes_nothing(folder, benchmark_dir, capsys, example):
    table, what = example
    path = write(table, folder / "score", False)
    before = contents(benchmark_dir)
    status, printed, err = run_cli(["bench", "score", str(path), "--out", str(benchmark_dir)],
                                   capsys)
    assert status == 2 and len(err) == 1 and not printed, (what, err)
    assert contents(benchmark_dir) == before
