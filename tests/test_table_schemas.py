"""The committed tables of the second benchmark (docs/benchmark2, both plants) against their
Table Schemas (runners/schemas/, studies/paper/benchmark/schemas/): the run tables, the
configurations, the compute ledger and the reference rows; the checker finds what breaks a
schema; and frictionless itself, where installed, reads the schemas as Table Schemas and
agrees on a sample of tables."""

import glob
import importlib.util
import json
import pathlib

import pandas as pd
import pytest

from lwrl.runners import table_schema
from lwrl.studies.paper.benchmark.third import rule

ROOT = pathlib.Path(__file__).resolve().parents[1]
BENCHMARKS = [ROOT / "docs" / "benchmark2", ROOT / "docs" / "benchmark2" / "mujoco"]
REFERENCES = ROOT / "studies" / "paper" / "benchmark" / "schemas" / "references.json"
SCHEMAS = {"run_table": table_schema.SCHEMAS / "run_table.json",
           "configs": table_schema.SCHEMAS / "configs.json",
           "compute": table_schema.SCHEMAS / "compute.json", "references": REFERENCES,
           "records": table_schema.SCHEMAS / "records.json"}
THIRD = ROOT / "docs" / "benchmark3"
THIRD_TASKS = rule.STAGE_1
"""The third benchmark's tasks: its variants' and continuous rows' runs are on them too."""
FRICTIONLESS = pytest.mark.skipif(importlib.util.find_spec("frictionless") is None,
                                  reason="frictionless is not installed (pip install -e '.[dev]')")


def run_tables(directory: pathlib.Path) -> list:
    """The run tables of a benchmark directory, in name order."""
    return sorted(glob.glob(str(directory / "runs" / "*.csv.gz")))


def run_records(directory: pathlib.Path) -> list:
    """The runs' records of a benchmark directory, in name order."""
    return sorted(glob.glob(str(directory / "runs" / "records" / "*.csv.gz")))


@pytest.mark.parametrize("directory", BENCHMARKS, ids=["analytic", "mujoco"])
def test_the_ledger_configurations_and_reference_rows_keep_their_schemas(directory):
    for name in ("configs", "compute"):
        schema = table_schema.load(SCHEMAS[name])
        table = table_schema.read_jsonl(directory / f"{name}.jsonl")
        assert len(table) > 0 and table_schema.violations(table, schema, name) == []
    schema = table_schema.load(REFERENCES)
    paths = sorted(glob.glob(str(directory / "references" / "*.csv.gz")))
    assert len(paths) >= 4 and table_schema.table_violations(paths, schema) == []


@pytest.mark.parametrize("directory", BENCHMARKS, ids=["analytic", "mujoco"])
def test_every_run_table_keeps_its_schema(directory):
    paths = run_tables(directory)
    assert len(paths) >= 700
    assert table_schema.table_violations(paths, table_schema.load(SCHEMAS["run_table"])) == []


def third_benchmark_files(task: str) -> tuple:
    """`(run tables, records)` of docs/benchmark3 whose runs are on `task`, in name order."""
    chosen = lambda found: [path for path in found
                            if pathlib.Path(path).name.startswith(f"{task}-")]
    return chosen(run_tables(THIRD)), chosen(run_records(THIRD))


@pytest.mark.parametrize("task", THIRD_TASKS)
def test_the_third_benchmarks_run_tables_and_records_keep_their_schemas(task):
    """docs/benchmark3's run tables and every run's records (those of the 100-agent rows'
    training runs too, whose tables are not committed), a test per task so that the suite's
    workers share them."""
    paths, records = third_benchmark_files(task)
    names = lambda found: {pathlib.Path(path).name for path in found}
    assert len(paths) >= 100 and names(paths) < names(records)
    assert table_schema.table_violations(paths, table_schema.load(SCHEMAS["run_table"])) == []
    assert table_schema.table_violations(records, table_schema.load(SCHEMAS["records"])) == []


def test_the_third_benchmarks_ledger_and_reference_rows_keep_their_schemas():
    """docs/benchmark3's compute ledger and reference rows; and every run table and record
    is of one of `THIRD_TASKS`, checked above."""
    found = [third_benchmark_files(task) for task in THIRD_TASKS]
    assert sum(len(paths) + len(records) for paths, records in found) == (
        len(run_tables(THIRD)) + len(run_records(THIRD)))
    ledger = table_schema.read_jsonl(THIRD / "compute.jsonl")
    assert table_schema.violations(ledger, table_schema.load(SCHEMAS["compute"]), "compute") == []
    references = sorted(glob.glob(str(THIRD / "references" / "*.csv.gz")))
    assert references and table_schema.table_violations(references, table_schema.load(REFERENCES)) == []


def test_the_run_tables_schema_has_a_field_for_every_learners_column():
    """A run's table repeats each scalar setting of its learner (`RunConfig.columns`): every
    one of the registry is a field of the schema, typed as its setting is."""
    import dataclasses

    from lwrl import agent
    from lwrl.settings import SCALARS, base_type
    fields = {field["name"]: field["type"] for field in
              table_schema.load(SCHEMAS["run_table"])["fields"]}
    types = {bool: "boolean", int: "integer", float: "number", str: "string"}
    for learner in agent.LEARNERS.values():
        for setting in dataclasses.fields(learner.settings):
            kind = base_type(setting.type)
            if kind in SCALARS:
                assert fields.get(setting.name) == types[kind], (learner.name, setting.name)


def test_the_run_tables_schema_has_a_field_for_every_physical_parameter_and_sensor():
    """A run's table has a column per physical parameter it sets (`params.NAME`), per
    observation noise (`observation_noise.NAME`) and per parameter drawn each episode
    (`randomise`: `NAME`): every domain's parameters and every task's state variables are
    numeric fields of the schema."""
    from lwrl import tasks
    fields = {field["name"]: field["type"] for field in
              table_schema.load(SCHEMAS["run_table"])["fields"]}
    for domain in tasks.DOMAINS:
        for name in tasks.domain(domain).parameters.names:
            assert fields.get(name) == fields.get(f"params.{name}") == "number", (domain, name)
    for domain, task in tasks.ALL_TASKS:
        for name in tasks.definition(domain, task).state_names:
            assert fields.get(f"observation_noise.{name}") == "number", (domain, task, name)


def test_the_records_schema_names_the_columns_a_run_records():
    from lwrl.runners import records
    schema = table_schema.load(SCHEMAS["records"])
    assert tuple(field["name"] for field in schema["fields"]) == records.COLUMNS


def test_the_checker_finds_what_breaks_a_schema(tmp_path):
    """A reference table with each fault in turn: a column the schema lacks, a required cell
    empty, a value of another type, one below its minimum, one outside its enum, a repeated
    key; each named with its field and row, and the file."""
    schema = table_schema.load(REFERENCES)
    good = pd.DataFrame({"agent": [0, 0], "seed": [10000, 10000], "episode": [1, 2],
                         "steps": [5.0, 7.0], "return": [-5.0, -7.0], "uptime_s": [None, None],
                         "truncated": [False, True], "diverged": [False, False],
                         "row": ["random", "random"]})
    faults = {"are not the schema's fields": good.assign(extra=1),
              "field 'return': a required value is missing at row 2": good.assign(**{"return": [-5.0, None]}),
              "field 'episode': '1.5' at row 1 is no integer": good.assign(episode=["1.5", "2"]),
              "field 'truncated': 'yes' at row 2 is no boolean": good.assign(truncated=["False", "yes"]),
              "field 'steps': '0.0' at row 1 is beyond the minimum 1": good.assign(steps=[0.0, 7.0]),
              "field 'row': 'greedy' at row 2 is not one of": good.assign(row=["random", "greedy"]),
              "primary key ['row', 'agent', 'episode'] repeats at row 2": good.assign(episode=[1, 1])}
    path = tmp_path / "good.csv.gz"
    good.to_csv(path, index=False)
    assert table_schema.table_violations([str(path)], schema) == []
    for fault, table in faults.items():
        path = tmp_path / "table.csv.gz"
        table.to_csv(path, index=False)
        found = table_schema.table_violations([str(tmp_path / "good.csv.gz"), str(path)], schema)
        assert len(found) == 1 and fault in found[0] and str(path) in found[0], (fault, found)


def test_tables_read_together_are_the_tables_read_one_by_one():
    """`read_csvs` parses files of one header at once: where a quoted cell holds a line
    break, a line is blank or lines end in carriage returns, it gives each file's rows as
    reading them one by one does; a quote a file leaves open is an error, not a cell that
    takes in the next file's lines."""
    import io
    schema = table_schema.load(REFERENCES)
    header = b"a,b\n"
    cases = {"plain": [header + b"1,x\n2,y\n", header + b"3,z", header],
             "quoted comma": [header + b'1,"x,y"\n', header + b'2,"say ""hi"""\n'],
             "quoted line break": [header + b'1,"x\ny"\n2,z\n', header + b"3,w\n"],
             "blank line": [header + b"1,x\n\n2,y\n", header + b"3,z\n\n"],
             "carriage returns": [header + b"1,x\r\n2,y\r\n", header + b"3,z\r4,w\n"]}
    for case, texts in cases.items():
        together = table_schema.read_csvs(texts, schema)
        alone = [table_schema.read_csv(io.BytesIO(text), schema) for text in texts]
        pd.testing.assert_frame_equal(together, pd.concat(alone, ignore_index=True), obj=case)
        assert together.attrs["lengths"] == [len(table) for table in alone], case
    with pytest.raises(pd.errors.ParserError, match="EOF inside string"):
        table_schema.read_csvs([header + b'1,"x\n', header + b'2,y"\n3,z\n'], schema)


def test_a_fault_is_named_by_its_file_and_row_where_other_headers_come_between(tmp_path):
    schema = table_schema.load(REFERENCES)
    good = pd.DataFrame({"agent": [0, 0], "seed": [10000, 10000], "episode": [1, 2],
                         "steps": [5.0, 7.0], "return": [-5.0, -7.0], "uptime_s": [None, None],
                         "truncated": [False, True], "diverged": [False, False],
                         "row": ["random", "random"]})
    paths = [tmp_path / name for name in ("a.csv.gz", "b.csv.gz", "c.csv.gz")]
    good.to_csv(paths[0], index=False)
    good[list(reversed(good.columns))].to_csv(paths[1], index=False)
    good.assign(episode=["1", "2.5"]).to_csv(paths[2], index=False)
    found = table_schema.table_violations([str(path) for path in paths], schema)
    assert len(found) == 2 and str(paths[1]) in found[0] and "are not the schema's fields" in found[0]
    assert found[1].startswith(f"{paths[2]}: field 'episode': '2.5' at row 2 is no integer"), found


def test_a_json_lines_value_of_another_type_is_found(tmp_path):
    path = tmp_path / "compute.jsonl"
    path.write_text('{"runs": ["a"], "wall_s": 1.0, "cpu_s": 2, "host": "h", '
                    '"finished": "2026-12-04T14:33:01+0000"}\n'
                    '{"runs": "b", "wall_s": true, "cpu_s": -1, "host": "h", '
                    '"finished": "yesterday"}\n')
    found = table_schema.violations(table_schema.read_jsonl(path),
                                    table_schema.load(SCHEMAS["compute"]), "compute")
    assert [line.split(":")[1].strip() for line in found] == [
        "field 'runs'", "field 'wall_s'", "field 'cpu_s'", "field 'finished'"], found


def test_a_schema_with_what_the_checker_does_not_check_is_refused(tmp_path):
    path = tmp_path / "schema.json"
    path.write_text('{"fields": [{"name": "x", "type": "integer", "constraints": {"pattern": "1"}}]}')
    with pytest.raises(ValueError, match="constraint 'pattern'; allowed: required"):
        table_schema.load(path)


@FRICTIONLESS
@pytest.mark.parametrize("name", list(SCHEMAS))
def test_frictionless_reads_each_schema_as_a_table_schema(name):
    from frictionless import Schema
    report = Schema.validate_descriptor(str(SCHEMAS[name]))
    assert report.valid, report.flatten(["message"])


@FRICTIONLESS
def test_frictionless_agrees_on_a_sample_of_tables():
    from frictionless import Resource, Schema
    directory = BENCHMARKS[0]
    cases = [(path, "run_table", None) for path in run_tables(directory)[::250]]
    cases += [(path, "references", None) for path in glob.glob(str(directory / "references" / "*"))[:1]]
    cases += [(str(directory / f"{name}.jsonl"), name, "jsonl") for name in ("configs", "compute")]
    cases += [(path, "records", None) for path in run_records(THIRD)[:1]]
    for path, name, form in cases:
        report = Resource(path=str(pathlib.Path(path).relative_to(ROOT)), basepath=str(ROOT),
                          format=form, schema=Schema.from_descriptor(json.loads(SCHEMAS[name].read_text()))).validate()
        assert report.valid, (path, report.flatten(["message"])[:3])
