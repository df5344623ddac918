"""lwrl's tables held to their schemas: Frictionless Table Schemas
(https://specs.frictionlessdata.io/table-schema/, v2's `fieldsMatch` included), one JSON file
per kind of table beside the code that writes it (`runners/schemas/`: a run's table, its
records, configs.jsonl, compute.jsonl; `studies/paper/benchmark/schemas/`: the reference rows).

`violations` checks a table against a schema with pandas, a column at a time (each distinct
cell typed once), because the committed tables hold millions of rows, which frictionless's own
validator reads one at a time (minutes); `table_violations` parses many small files of one
header at once (`read_csvs`). It checks the part of the specification those schemas use, and
says so of any other: the fields' names against `fieldsMatch`; each field's `type` (string,
integer, number, boolean, object, array, datetime with a strptime `format`); the constraints
`required`, `unique`, `minimum`, `maximum` and `enum`; `primaryKey` (unique, none missing);
`missingValues` and the booleans' default true and false values. A CSV table is read as text
(`read_csv`), so that a cell is judged as written; a JSON lines file as its values
(`read_jsonl`). tests/test_table_schemas.py holds the committed tables to the schemas, and
checks with frictionless itself, where it is installed, that they are Table Schemas and that
it agrees on a sample of tables.
"""

import gzip
import io
import json
import pathlib
import re

import numpy as np
import pandas as pd

from lwrl import outputs

SCHEMAS = pathlib.Path(__file__).resolve().parent / "schemas"
"""The schemas of the tables `runners` writes."""
TYPES = ("string", "integer", "number", "boolean", "object", "array", "datetime")
"""The field types `violations` checks."""
CONSTRAINTS = ("required", "unique", "minimum", "maximum", "enum")
"""The constraints `violations` checks."""
TRUE_VALUES = ("true", "True", "TRUE", "1")
"""Table Schema's default `trueValues`: the cells a boolean field reads as true."""
FALSE_VALUES = ("false", "False", "FALSE", "0")
"""Table Schema's default `falseValues`: the cells a boolean field reads as false."""
NUMBER_WORDS = ("NaN", "INF", "-INF")
"""Table Schema's spellings of the numbers that are no finite ones."""
MATCHES = ("exact", "equal", "subset", "superset", "partial")
"""`fieldsMatch`'s values: the table's columns against the schema's fields."""


def load(path) -> dict:
    """The schema at `path`, or a one-line ValueError naming a type, constraint or
    `fieldsMatch` that `violations` does not check."""
    schema = json.loads(pathlib.Path(path).read_text())
    for field in schema["fields"]:
        if field.get("type", "any") not in TYPES:
            raise ValueError(f"{path}: field {field['name']!r} has type {field.get('type')!r}; "
                             f"allowed: {', '.join(TYPES)}")
        unknown = set(field.get("constraints", {})) - set(CONSTRAINTS)
        if unknown:
            raise ValueError(f"{path}: field {field['name']!r} has constraint {sorted(unknown)[0]!r}; "
                             f"allowed: {', '.join(CONSTRAINTS)}")
    if schema.get("fieldsMatch", "exact") not in MATCHES:
        raise ValueError(f"{path}: fieldsMatch {schema['fieldsMatch']!r}; allowed: {', '.join(MATCHES)}")
    return schema


def read_csv(path, schema: dict) -> pd.DataFrame:
    """A CSV table as text, a cell of `missingValues` (default: the empty string) missing,
    marked as read from CSV (`attrs["csv"]`) for `violations`."""
    table = outputs.read_table(path, dtype=str, keep_default_na=False,
                               na_values=schema.get("missingValues", [""]))
    table.attrs["csv"] = True
    return table


def read_jsonl(path) -> pd.DataFrame:
    """A JSON lines file as a table, a row per line, each value as JSON gave it (a key absent
    from a line is None in its row)."""
    lines = [json.loads(line) for line in pathlib.Path(path).read_text().splitlines() if line]
    columns = list(dict.fromkeys(name for line in lines for name in line))
    return pd.DataFrame({name: pd.Series([line.get(name) for line in lines], dtype=object)
                         for name in columns})


def violations(table: pd.DataFrame, schema: dict, name: str = "table", within=None) -> list:
    """What in `table` (`read_csv`'s text or `read_jsonl`'s values, None for a missing value)
    breaks `schema`, a line each, naming the table, the field and the first row at fault
    (counted from 1); empty where nothing does. `within`: an array of the rows' tables,
    where `table` is several, each of which has its own primary keys."""
    fields = {field["name"]: field for field in schema["fields"]}
    text = bool(table.attrs.get("csv"))
    problems = [f"{name}: {line}" for line in field_match(list(table.columns), list(fields),
                                                          schema.get("fieldsMatch", "exact"))]
    for column in table.columns:
        if column in fields:
            problems += [f"{name}: field {column!r}: {line}"
                         for line in field_violations(table[column], fields[column], text)]
    key = schema.get("primaryKey")
    if key and set(key) <= set(table.columns):
        keys = table[key]
        if keys.isna().any(axis=None):
            problems.append(f"{name}: primary key {key} has a missing value")
        repeated = (keys if within is None else keys.assign(within=within)).astype(str).duplicated()
        if repeated.any():
            problems.append(f"{name}: primary key {key} repeats at row {first(repeated)}")
    return problems


CHUNK = 100
"""Tables read and checked together by `table_violations`: a hundred run tables are about
100 000 rows, the rest of the thousand waiting on disk rather than in memory."""


def table_violations(paths, schema: dict) -> list:
    """`violations` of many CSV tables of one schema: each file's columns by `fieldsMatch`,
    then their values `CHUNK` files at a time as one table (a column at a time over them:
    the committed run tables are a thousand small files), each line naming the file at
    fault; each file's primary keys are its own."""
    paths, problems = list(paths), []
    for start in range(0, len(paths), CHUNK):
        problems += chunk_violations(paths[start:start + CHUNK], schema)
    return problems


def chunk_violations(paths: list, schema: dict) -> list:
    """`table_violations` of a few files, those of one header parsed at once (`read_csvs`)."""
    fields = [field["name"] for field in schema["fields"]]
    match = schema.get("fieldsMatch", "exact")
    tables, order, problems = [], [], []
    for group, table in read_groups(paths, schema):
        problems += [f"{path}: {line}" for path in group
                     for line in field_match(list(table.columns), fields, match)]
        tables.append(table)
        order += group
    whole = pd.concat(tables, ignore_index=True)
    whole.attrs["csv"] = True
    lengths = [length for table in tables for length in table.attrs["lengths"]]
    ends = np.cumsum(lengths)
    row = re.compile(r"at row (\d+)")

    def located(line: str) -> str:
        found = row.search(line)
        if not found:
            return f"{len(paths)} tables: {line}"
        number = int(found.group(1))
        index = int(np.searchsorted(ends, number))
        within = number - (int(ends[index - 1]) if index else 0)
        return f"{order[index]}: {line[:found.start()]}at row {within}{line[found.end():]}"
    return problems + [located(line.removeprefix("table: ")) for line in
                       violations(whole, dict(schema, fieldsMatch="partial"),
                                  within=np.repeat(np.arange(len(lengths)), lengths))]


def read_groups(paths, schema: dict) -> list:
    """CSV files as text (`read_csv`), those of one header line parsed at once (`read_csvs`):
    `[(their paths, their table)]`, a pair per header, in the order each header first comes."""
    groups: dict = {}
    for path in paths:
        text = file_bytes(path)
        groups.setdefault(text.partition(b"\n")[0], []).append((path, text))
    return [([path for path, _ in group], read_csvs([text for _, text in group], schema))
            for group in groups.values()]


def file_bytes(path) -> bytes:
    """The bytes of the file at `path`, gunzipped for `.gz`."""
    data = pathlib.Path(path).read_bytes()
    return gzip.decompress(data) if str(path).endswith(".gz") else data


def read_csvs(texts: list, schema: dict) -> pd.DataFrame:
    """CSV files' `texts` (bytes) of one header line as one `read_csv` table, the rows each
    gave in `attrs["lengths"]`: their lines after the header are parsed at once, under the
    first header (a hundred small files in the time of a few). Without carriage returns a
    row ends at a line break, so as many rows as lines means that each line was a row, each
    file's its own; fewer (a quoted cell holding a line break, a blank line, which
    `read_csv` skips), and each file is read on its own."""
    lines = [text.rstrip(b"\n").split(b"\n")[1:] for text in texts]
    lengths = [len(part) for part in lines]
    table = None
    if not any(b"\r" in text for text in texts):
        table = read_csv(io.BytesIO(b"\n".join([texts[0].partition(b"\n")[0],
                                                *(line for part in lines for line in part)])),
                         schema)
    if table is None or len(table) != sum(lengths):
        tables = [read_csv(io.BytesIO(text), schema) for text in texts]
        table, lengths = pd.concat(tables, ignore_index=True), [len(part) for part in tables]
    table.attrs["lengths"] = lengths
    return table


def field_match(columns: list, fields: list, match: str) -> list:
    """The table's `columns` against the schema's `fields` by `fieldsMatch` (`MATCHES`)."""
    extra = [column for column in columns if column not in fields]
    absent = [field for field in fields if field not in columns]
    if match == "exact" and columns != fields:
        return [f"columns {columns} are not the schema's fields {fields} in order"]
    if match in ("equal", "superset") and extra:
        return [f"column {extra[0]!r} is no field of the schema"]
    if match in ("equal", "subset") and absent:
        return [f"field {absent[0]!r} of the schema is no column"]
    if match == "partial" and len(absent) == len(fields):
        return ["no column is a field of the schema"]
    return []


def first(mask) -> int:
    """The first row (from 1) where `mask` is true."""
    return int(np.argmax(np.asarray(mask))) + 1


def field_violations(column: pd.Series, field: dict, text: bool) -> list:
    """What in one column breaks its field's type and constraints (`text`: CSV cells)."""
    constraints = field.get("constraints", {})
    missing = column.isna().to_numpy()
    problems = []
    if constraints.get("required") and missing.any():
        problems.append(f"a required value is missing at row {first(missing)}")
    present = column[~missing]
    values, wrong = typed(present, field, text)
    if wrong.any():
        problems.append(f"{present.iloc[int(np.argmax(wrong))]!r} at row "
                        f"{int(np.flatnonzero(~missing)[np.argmax(wrong)]) + 1} is no "
                        f"{field.get('type', 'any')}"
                        + (f" of format {field['format']}" if "format" in field else ""))
        return problems
    index = np.flatnonzero(~missing)
    for bound, outside in (("minimum", lambda v, b: v < b), ("maximum", lambda v, b: v > b)):
        if bound in constraints:
            out = outside(values, constraints[bound])
            if out.any():
                problems.append(f"{present.iloc[int(np.argmax(out))]!r} at row "
                                f"{int(index[np.argmax(out)]) + 1} is beyond the {bound} "
                                f"{constraints[bound]}")
    if "enum" in constraints:
        out = ~pd.Series(values).isin(constraints["enum"]).to_numpy()
        if out.any():
            problems.append(f"{present.iloc[int(np.argmax(out))]!r} at row "
                            f"{int(index[np.argmax(out)]) + 1} is not one of {constraints['enum']}")
    if constraints.get("unique") and present.astype(str).duplicated().any():
        problems.append(f"a value repeats at row "
                        f"{int(index[np.argmax(present.astype(str).duplicated())]) + 1}")
    return problems


def typed(values: pd.Series, field: dict, text: bool) -> tuple:
    """`(the values as their type's numbers or objects, a mask of those that are not of
    it)`: `text`, CSV cells as Table Schema reads them (`typed_text`, of each distinct cell
    once: a run's table repeats its settings on every row), else values as JSON typed
    them."""
    if text:
        codes, cells = pd.factorize(values.astype(str))
        read, wrong = typed_text(pd.Series(cells), field)
        return read[codes], wrong[codes]
    kind = field.get("type", "any")
    python = {"string": str, "integer": int, "number": (int, float), "boolean": bool,
              "object": dict, "array": list, "datetime": str}[kind]
    ok = values.map(lambda value: isinstance(value, python)
                    and (kind == "boolean" or not isinstance(value, bool))).to_numpy(dtype=bool)
    if kind == "datetime":
        return typed_text(values.where(ok, ""), field)[0], ~ok | typed_text(values.where(ok, ""), field)[1]
    if kind in ("integer", "number"):
        return pd.to_numeric(values.where(ok, 0)).to_numpy(dtype=float), ~ok
    return values.to_numpy(), ~ok


def typed_text(cells: pd.Series, field: dict) -> tuple:
    """`typed` of CSV cells (text), a column at a time."""
    kind = field.get("type", "any")
    if kind == "string":
        return cells.to_numpy(), np.zeros(len(cells), dtype=bool)
    if kind == "datetime":
        parsed = pd.to_datetime(cells, format=field.get("format"), errors="coerce", utc=True)
        return parsed.to_numpy(), parsed.isna().to_numpy()
    if kind == "boolean":
        return cells.isin(TRUE_VALUES).to_numpy(), ~cells.isin(TRUE_VALUES + FALSE_VALUES).to_numpy()
    if kind in ("object", "array"):
        python = dict if kind == "object" else list
        read = cells.map(json_value)
        return read.to_numpy(), ~read.map(lambda value: isinstance(value, python)).to_numpy(dtype=bool)
    if kind == "integer":
        ok = cells.str.fullmatch(r"[+-]?\d+").to_numpy(dtype=bool)
    else:  # number
        words = cells.isin(NUMBER_WORDS).to_numpy()
        ok = words | pd.to_numeric(cells.where(~words, "0"), errors="coerce").notna().to_numpy()
    spelt = cells.where(ok, "0").replace({"INF": "inf", "-INF": "-inf"})
    return pd.to_numeric(spelt).to_numpy(dtype=float), ~ok


def json_value(text: str):
    """The JSON value `text` spells (a CSV cell of an object or array field), else None."""
    try:
        return json.loads(text)
    except ValueError:
        return None
