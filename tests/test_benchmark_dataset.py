"""`lwrl bench export DIR --parquet OUT` (studies/paper/benchmark/dataset.py): a benchmark's
run tables as one Parquet file that pandas loads in one line, every value as the tables
hold it, the columns the run tables' schema's fields, typed by it; its data card names the
fields, the licence and how to cite; bad input is one line."""

import json
import pathlib
import shutil

import numpy as np
import pandas as pd
import pytest
from conftest import run_cli

from lwrl import outputs
from lwrl.runners import table_schema

pytest.importorskip("pyarrow")

COMMITTED = pathlib.Path(__file__).resolve().parents[1] / "docs" / "benchmark2"
SCHEMA = json.loads((table_schema.SCHEMAS / "run_table.json").read_text())


def assert_holds(exported: pd.DataFrame, table: pd.DataFrame) -> None:
    """`exported` holds every column of `table` with its values: numbers equal, text alike."""
    for column in table.columns:
        if table[column].dtype.kind in "fiub":
            np.testing.assert_array_equal(exported[column].to_numpy(dtype=float),
                                          table[column].to_numpy(dtype=float), err_msg=column)
        else:
            assert exported[column].astype(str).tolist() == table[column].astype(str).tolist()


@pytest.fixture
def benchmark(tmp_path) -> pathlib.Path:
    """A benchmark directory of three committed run tables: a linear row's training, a deep
    row's and an evaluation, so that columns differ between them."""
    names = sorted(path.name for path in (COMMITTED / "runs").glob("*.csv.gz"))
    chosen = [next(name for name in names if "-nrbf-" in name),
              next(name for name in names if "-dqn_jax-" in name),
              next(name for name in names if "-ppo_jax-" in name)]
    (tmp_path / "bench" / "runs").mkdir(parents=True)
    for name in chosen:
        shutil.copy(COMMITTED / "runs" / name, tmp_path / "bench" / "runs" / name)
    return tmp_path / "bench"


def test_the_runs_load_in_one_line_as_the_tables_hold_them(benchmark, tmp_path, capsys):
    out = tmp_path / "dataset"
    status, printed, _ = run_cli(["bench", "export", str(benchmark), "--parquet", str(out)], capsys)
    assert status == 0 and "runs.parquet" in printed
    runs = pd.read_parquet(out / "runs.parquet")
    assert list(runs.columns) == [field["name"] for field in SCHEMA["fields"]]
    tables = [outputs.read_table(path) for path in sorted((benchmark / "runs").glob("*.csv.gz"))]
    assert len(runs) == sum(map(len, tables))
    for table in tables:
        mine = runs[runs["run"] == table["run"].iloc[0]].reset_index(drop=True)
        assert_holds(mine, table)
        absent = [name for name in runs.columns if name not in table.columns]
        assert absent and mine[absent].isna().all(axis=None)  # another learner's settings
    card = (out / "README.md").read_text()
    for words in ("| `uptime_s` | number | ", "Apache License 2.0", "@software{lwrl",
                  'pd.read_parquet("runs.parquet")', f"{len(runs)} rows"):
        assert words in card, words


@pytest.fixture
def recorded(tmp_path) -> pathlib.Path:
    """A benchmark directory of two of the third benchmark's committed runs with their
    records: a linear row's training and a deep row's."""
    third = COMMITTED.parent / "benchmark3" / "runs"
    names = sorted(path.name for path in (third / "records").glob("*.csv.gz"))
    chosen = [next(name for name in names if "-nrbf-" in name),
              next(name for name in names if "-ppo_jax-" in name)]
    (tmp_path / "bench" / "runs" / "records").mkdir(parents=True)
    for name in chosen:
        for folder in ("", "records"):
            shutil.copy(third / folder / name, tmp_path / "bench" / "runs" / folder / name)
    return tmp_path / "bench"


def test_the_records_load_beside_the_runs(recorded, tmp_path, capsys):
    """The runs' records of their costs and provenance become records.parquet, typed by
    their schema, every value as the tables hold it; the card names their fields and hosts."""
    out = tmp_path / "dataset"
    status, printed, _ = run_cli(["bench", "export", str(recorded), "--parquet", str(out)], capsys)
    assert status == 0 and "records.parquet" in printed
    schema = json.loads((table_schema.SCHEMAS / "records.json").read_text())
    costs = pd.read_parquet(out / "records.parquet")
    assert list(costs.columns) == [field["name"] for field in schema["fields"]]
    tables = [outputs.read_table(path) for path in sorted((recorded / "runs" / "records").glob("*.csv.gz"))]
    expected = pd.concat(tables, ignore_index=True)
    assert_holds(costs, expected)
    runs = pd.read_parquet(out / "runs.parquet")
    assert set(zip(costs["run"], costs["seed"])) <= set(zip(runs["run"], runs["seed"]))
    card = (out / "README.md").read_text()
    for words in ("## The costs measured in the runs", "| `cpu_s` | number | yes | ",
                  'pd.read_parquet("records.parquet")', f"{len(costs)} rows",
                  *(f"`{host}`" for host in expected["host_cpu"].unique())):
        assert words in card, words
    table = pd.read_csv(next((recorded / "runs" / "records").glob("*.csv.gz")))
    table.assign(stranger=1).to_csv(recorded / "runs" / "records" / "z.csv.gz", index=False)
    status, _, err = run_cli(["bench", "export", str(recorded), "--parquet", str(out), "--force"], capsys)
    assert status == 2 and len(err) == 1
    assert "column 'stranger' is no field of runners/schemas/records.json" in err[0]


def test_bad_input_is_one_line(benchmark, tmp_path, capsys):
    nothing = tmp_path / "empty"
    nothing.mkdir()
    status, _, err = run_cli(["bench", "export", str(nothing), "--parquet", str(tmp_path / "o")], capsys)
    assert status == 2 and len(err) == 1 and "holds no run tables (runs/*.csv.gz)" in err[0]
    out = tmp_path / "dataset"
    assert run_cli(["bench", "export", str(benchmark), "--parquet", str(out)], capsys)[0] == 0
    status, _, err = run_cli(["bench", "export", str(benchmark), "--parquet", str(out)], capsys)
    assert status == 2 and len(err) == 1 and "already holds runs.parquet" in err[0]
    assert run_cli(["bench", "export", str(benchmark), "--parquet", str(out), "--force"], capsys)[0] == 0
    table = pd.read_csv(next((benchmark / "runs").glob("*.csv.gz")))
    table.assign(stranger=1).to_csv(benchmark / "runs" / "z.csv.gz", index=False)
    status, _, err = run_cli(["bench", "export", str(benchmark), "--parquet", str(out), "--force"], capsys)
    assert status == 2 and len(err) == 1 and "column 'stranger' is no field" in err[0]


DATASETS = sorted(path.parent.parent for path in COMMITTED.parent.glob("benchmark*/**/dataset/runs.parquet"))
"""The benchmarks whose runs are committed as a dataset (`dataset/`, as `lwrl bench export`
wrote it)."""


def test_the_second_benchmark_is_committed_as_a_dataset():
    assert COMMITTED in DATASETS


@pytest.mark.parametrize("directory", DATASETS, ids=lambda path: path.name)
def test_the_committed_dataset_is_the_committed_runs(directory):
    """A committed dataset (benchmark2's among them): every run table's rows, and every
    record's where the runs have them, as many as they hold."""
    for table, folder in (("runs", "runs"), ("records", "runs/records")):
        tables = sorted((directory / folder).glob("*.csv.gz"))
        if not tables:
            assert not (directory / "dataset" / f"{table}.parquet").exists()
            continue
        exported = pd.read_parquet(directory / "dataset" / f"{table}.parquet", columns=["run"])
        counts = exported.groupby("run").size()
        assert set(counts.index) == {path.name.removesuffix(".csv.gz") for path in tables}
        for path in tables[::50]:
            assert counts[path.name.removesuffix(".csv.gz")] == len(pd.read_csv(path, usecols=["run"]))
