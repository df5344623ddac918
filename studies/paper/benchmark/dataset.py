"""A benchmark's runs as one Parquet dataset with its data card (`lwrl bench export DIR
--parquet OUT`; docs/FINDINGS.md, the third benchmark's rule, "Provenance and schemas").

Every run table of `DIR/runs/` (runners/schemas/run_table.json, which a test holds the
committed tables to) becomes rows of `OUT/runs.parquet`, one column per field of that schema
in its order, typed by it (string, 64-bit integer, 64-bit float, boolean; a run without a
column, such as another learner's setting, has nulls there), written a row group per
`GROUP` tables so that a thousand tables never sit in memory at once. Where the runs have
records of their costs (`DIR/runs/records/`, runners/schemas/records.json: the third
benchmark's CPU seconds and counted arithmetic per agent at every evaluation, and each run's
provenance), they become `OUT/records.parquet` the same way. `OUT/README.md` is the data
card: what the rows are, how to load them (`pandas.read_parquet(OUT/runs.parquet)`), each
field with its type and description (units in it), the source, the licence and how to cite.
"""

import datetime
import glob
import os
import pathlib

import pandas as pd

from lwrl import outputs
from lwrl.runners import records, table_schema

DATA = "runs.parquet"
RECORDS = "records.parquet"
CARD = "README.md"
GROUP = 100
"""Run tables per Parquet row group."""
ARROW_TYPES = {"string": "string", "integer": "int64", "number": "float64", "boolean": "bool"}
"""Arrow's type of each Table Schema type of a run table's fields (pyarrow: the paper extra)."""
LICENCE = ("Apache License 2.0, lwrl's licence (`license` in lwrl's pyproject.toml): the runs "
           "are the output of lwrl's code, and may be used, changed and shared under its terms.")
CITATION = """@inproceedings{framling2008lightweight,
  author    = {Kary Fr{\\"a}mling},
  title     = {Light-weight reinforcement learning with function approximation for
               real-life control tasks},
  booktitle = {Proceedings of the Fifth International Conference on Informatics in
               Control, Automation and Robotics (ICINCO 2008)},
  year      = {2008}
}"""
"""The method's paper, which lwrl's README asks to cite beside lwrl itself (`software`)."""


def tables(directory, folder: str) -> list:
    """The tables (`*.csv.gz`) in `folder` of the benchmark directory `directory`, sorted."""
    return sorted(glob.glob(os.path.join(glob.escape(str(directory)), folder, "*.csv.gz")))


def run_tables(directory) -> list:
    """The run tables of the benchmark directory `directory`, or a one-line ValueError."""
    paths = tables(directory, "runs")
    if not paths:
        raise ValueError(f"{directory} holds no run tables (runs/*.csv.gz): give a benchmark "
                         "directory, as `lwrl bench run TASK... --out DIR` writes it")
    return paths


def arrow_schema(schema: dict):
    """The Parquet file's schema: each field of the run table's, typed by `ARROW_TYPES`."""
    import pyarrow as pa
    return pa.schema([(field["name"], getattr(pa, {"bool": "bool_"}.get(kind, kind))())
                      for field in schema["fields"]
                      for kind in [ARROW_TYPES[field["type"]]]])


def typed_table(path: str, schema: dict, name: str = "run_table.json") -> pd.DataFrame:
    """One table with every field of `schema` (runners/schemas/`name`), typed by it (a
    missing column all null), or a one-line ValueError naming the table and the column that
    is not of its type."""
    table = outputs.read_table(path, keep_default_na=False,
                               na_values=schema.get("missingValues", [""]))
    pandas_types = {"string": "string", "integer": "Int64", "number": "float64", "boolean": "boolean"}
    columns = {}
    for field in schema["fields"]:
        column, kind = field["name"], pandas_types[field["type"]]
        if column not in table.columns:
            columns[column] = pd.Series(None, index=table.index, dtype=kind)
            continue
        try:
            columns[column] = table[column].astype(kind)
        except (TypeError, ValueError):
            raise ValueError(f"{path}: column {column!r} is no {field['type']} "
                             f"(runners/schemas/{name})") from None
    unknown = [column for column in table.columns if column not in columns]
    if unknown:
        raise ValueError(f"{path}: column {unknown[0]!r} is no field of runners/schemas/{name}")
    return pd.DataFrame(columns)


def write_parquet(paths: list, name: str, data: str, summary: dict) -> tuple:
    """Write the tables at `paths` as the Parquet file `data`, typed by the schema
    runners/schemas/`name`, adding each column of `summary` its values; the schema and the
    rows written."""
    import pyarrow as pa
    import pyarrow.parquet as pq
    schema = table_schema.load(table_schema.SCHEMAS / name)
    target, rows = arrow_schema(schema), 0
    with outputs.atomic_write(data, mode="wb") as file, pq.ParquetWriter(
            file, target, compression="zstd") as writer:
        for start in range(0, len(paths), GROUP):
            group = pd.concat([typed_table(path, schema, name)
                               for path in paths[start:start + GROUP]], ignore_index=True)
            writer.write_table(pa.Table.from_pandas(group, schema=target, preserve_index=False))
            rows += len(group)
            for column, seen in summary.items():
                seen.update(group[column].dropna().unique())
    return schema, rows


def export(directory, out, command: str) -> list:
    """Write `out/runs.parquet`, `out/records.parquet` where the runs have records, and the
    data card `out/README.md` from the benchmark directory `directory`; the paths written."""
    paths, recorded = run_tables(directory), tables(directory, "runs/records")
    os.makedirs(out, exist_ok=True)
    data, summary = os.path.join(out, DATA), {"task": set(), "plant": set(), "learner": set()}
    schema, rows = write_parquet(paths, "run_table.json", data, summary)
    written, costs, kept = [data], None, os.path.join(out, RECORDS)
    if recorded:
        hosts = {"host_cpu": set(), "lwrl_commit": set()}
        records_schema, records_rows = write_parquet(recorded, "records.json", kept, hosts)
        written.append(kept)
        costs = records_schema, len(recorded), records_rows, hosts, os.path.getsize(kept)
    elif os.path.exists(kept):
        os.remove(kept)  # an earlier export's, replaced by none
    card = os.path.join(out, CARD)
    with outputs.atomic_write(card, encoding="utf-8") as file:
        file.write(data_card(schema, directory, command, len(paths), rows, summary,
                             os.path.getsize(data), costs))
    return [*written, card]


def field_rows(schema: dict) -> list:
    """The data card's table of the fields of `schema`: name, type, required, description."""
    return ["| field | type | required | description |", "|---|---|---|---|",
            *(f"| `{field['name']}` | {field['type']} | "
              f"{'yes' if field.get('constraints', {}).get('required') else ''} | "
              f"{field['description'].replace('|', '/')} |" for field in schema["fields"])]


def records_section(costs) -> list:
    """The data card's section on `records.parquet` (`costs`: its schema, tables, rows, the
    hosts and commits seen, its size), or nothing where the runs have no records."""
    if costs is None:
        return []
    schema, tables, rows, seen, size = costs
    return [
        "## The costs measured in the runs", "",
        f"`{RECORDS}` ({size / 1e6:.1f} MB, {rows} rows, from the {tables} tables of "
        f"`runs/records/`): a row per agent of a run, the run and the agent's seed as in "
        f"`{DATA}` (join the two on `run` and `seed`). `cpu_s` is the agent's share of the "
        "CPU seconds of the process that trained its batch (the batch's CPU divided by "
        "`cpu_shared_by`); `multiply_adds` and `transcendentals` are its counted arithmetic "
        "over its `steps`, which no host's speed moves. A family of budgets computed as one "
        "run records at each checkpoint what it cost to get there; a greedy evaluation's "
        "record is its own, never its training's. The last columns are the run's provenance: "
        "lwrl's version and commit, the host's CPU, Python's and the libraries' versions.", "",
        f"- hosts: {', '.join(f'`{value}`' for value in sorted(seen['host_cpu']))}",
        f"- commits: {len(seen['lwrl_commit'])}", "",
        "```python", "import pandas as pd", "",
        f'records = pd.read_parquet("{RECORDS}")', "```", "",
        "In the order of the file (the Frictionless Table Schema `runners/schemas/records.json` "
        "of lwrl's source):", "", *field_rows(schema), ""]


def data_card(schema: dict, directory, command: str, tables: int, rows: int, summary: dict,
              size: int, costs=None) -> str:
    """The data card (see the module)."""
    from lwrl import __version__
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    listed = {name: ", ".join(f"`{value}`" for value in sorted(values))
              for name, values in summary.items()}
    return "\n".join([
        "# Data card: the benchmark's runs", "",
        f"Written by `{command}` on {stamp}, by lwrl {__version__} at commit "
        f"{records.commit()}, from the {tables} run tables of `{directory}/runs/`.", "",
        "## What it is", "",
        f"`{DATA}` ({size / 1e6:.1f} MB, {rows} rows): every training and greedy evaluation "
        "run of the benchmark, a row per agent and episode, the run's configuration repeated "
        "on every row. A training run's rows are its agents' learning episodes as far as its "
        "budget of environment steps; an evaluation's (`trained` names the training whose "
        "agents it evaluates, `greedy` true, `learn` false) are the agents' greedy episodes. "
        "The benchmark's report, its rule and the reference rows that normalise its scores "
        "are beside the runs in the benchmark's directory. A run on a variant of a task (the "
        "third benchmark's `TASK+VARIANT`) names the task in `task` and carries its variant "
        "in its own columns: its observation noise in `observation_noise.NAME`, its physics "
        "drawn each episode in the parameter's column (`thrust`, `force`, ...), null in the "
        "nominal task's rows.", "",
        f"- tasks: {listed['task']}", f"- plants: {listed['plant']}",
        f"- learners: {listed['learner']}", "",
        "## Loading it", "",
        "```python", "import pandas as pd", "",
        f'runs = pd.read_parquet("{DATA}")  # pyarrow installed', "```", "",
        "## Fields", "",
        "In the order of the file; *required*: never null. A setting that one learner has "
        "and another has not is null in the other's rows. Units: `steps` and `budget` count "
        "control steps (each task's control time step is in its definition, `lwrl tasks`), "
        "`uptime_s` is seconds, `return` the task's reward summed over the episode; other "
        "settings are in the units their descriptions give. The same fields, with their "
        "constraints, are the Frictionless Table Schema `runners/schemas/run_table.json` of "
        "lwrl's source.", "",
        *field_rows(schema), "", *records_section(costs),
        "## Licence", "", LICENCE, "",
        "## How to cite", "",
        "The method is Främling's; cite the paper, and lwrl (version "
        f"{__version__}, commit above) for the benchmark and its runs:", "",
        "```bibtex", CITATION, "",
        "@software{lwrl,",
        "  title   = {lwrl: light-weight reinforcement learning, as a living benchmark},",
        f"  version = {{{__version__}}},",
        f"  year    = {{{stamp[:4]}}},",
        "  note    = {Reproduction of Fr{\\\"a}mling (2008) on MuJoCo and analytic control tasks}",
        "}", "```", ""])

