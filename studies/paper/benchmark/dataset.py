"""A benchmark's runs as one Parquet dataset with its data card (`lwrl bench export DIR
--parquet OUT`; docs/FINDINGS.md, the third benchmark's rule, "Provenance and schemas").

Every run table of `DIR/runs/` (runners/schemas/run_table.json, which a test holds the
committed tables to) becomes rows of `OUT/runs.parquet`, one column per field of that schema
in its order, typed by it (string, 64-bit integer, 64-bit float, boolean; a run without a
column, such as another learner's setting, has nulls there), written a row group per
`GROUP` tables so that a thousand tables never sit in memory at once. `OUT/README.md` is the
data card: what the rows are, how to load them (`pandas.read_parquet(OUT/runs.parquet)`),
each field with its type and description (units in it), the source, the licence and how
to cite.
"""

import datetime
import glob
import os
import pathlib

import pandas as pd

from lwrl import outputs
from lwrl.runners import records, table_schema

DATA = "runs.parquet"
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


def run_tables(directory) -> list:
    """The run tables of the benchmark directory `directory`, or a one-line ValueError."""
    paths = sorted(glob.glob(os.path.join(glob.escape(str(directory)), "runs", "*.csv.gz")))
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


def typed_table(path: str, schema: dict) -> pd.DataFrame:
    """One run table with every field of `schema`, typed by it (a missing column all null),
    or a one-line ValueError naming the table and the column that is not of its type."""
    table = outputs.read_table(path, keep_default_na=False,
                               na_values=schema.get("missingValues", [""]))
    pandas_types = {"string": "string", "integer": "Int64", "number": "float64", "boolean": "boolean"}
    columns = {}
    for field in schema["fields"]:
        name, kind = field["name"], pandas_types[field["type"]]
        if name not in table.columns:
            columns[name] = pd.Series(None, index=table.index, dtype=kind)
            continue
        try:
            columns[name] = table[name].astype(kind)
        except (TypeError, ValueError):
            raise ValueError(f"{path}: column {name!r} is no {field['type']} "
                             "(runners/schemas/run_table.json)") from None
    unknown = [name for name in table.columns if name not in columns]
    if unknown:
        raise ValueError(f"{path}: column {unknown[0]!r} is no field of runners/schemas/run_table.json")
    return pd.DataFrame(columns)


def export(directory, out, command: str) -> list:
    """Write `out/runs.parquet` and its data card `out/README.md` from the run tables of the
    benchmark directory `directory`; the paths written."""
    import pyarrow as pa
    import pyarrow.parquet as pq
    schema = table_schema.load(table_schema.SCHEMAS / "run_table.json")
    paths = run_tables(directory)
    os.makedirs(out, exist_ok=True)
    data, target = os.path.join(out, DATA), arrow_schema(schema)
    rows, summary = 0, {"task": set(), "plant": set(), "learner": set()}
    with outputs.atomic_write(data, mode="wb") as file, pq.ParquetWriter(
            file, target, compression="zstd") as writer:
        for start in range(0, len(paths), GROUP):
            group = pd.concat([typed_table(path, schema) for path in paths[start:start + GROUP]],
                              ignore_index=True)
            writer.write_table(pa.Table.from_pandas(group, schema=target, preserve_index=False))
            rows += len(group)
            for name, seen in summary.items():
                seen.update(group[name].dropna().unique())
    card = os.path.join(out, CARD)
    with outputs.atomic_write(card, encoding="utf-8") as file:
        file.write(data_card(schema, directory, command, len(paths), rows, summary,
                             os.path.getsize(data)))
    return [data, card]


def data_card(schema: dict, directory, command: str, tables: int, rows: int, summary: dict,
              size: int) -> str:
    """The data card (see the module)."""
    from lwrl import __version__
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    fields = [f"| `{field['name']}` | {field['type']} | "
              f"{'yes' if field.get('constraints', {}).get('required') else ''} | "
              f"{field['description'].replace('|', '/')} |" for field in schema["fields"]]
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
        "| field | type | required | description |", "|---|---|---|---|", *fields, "",
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

