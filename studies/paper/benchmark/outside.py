"""Results of a learner that is not in lwrl's registry, scored by the second benchmark's rule
(`lwrl bench score RESULTS...`): any library's agents, trained on a task of the suite (for
example through `lwrl.gym`) with the task's budget of steps and evaluated greedily as the
protocol evaluates every row, placed beside the rows.

A results file is a CSV (gzip-compressed or not), one row per greedy evaluation episode, as
`lwrl bench evaluate` (`harness`) writes it:

| column | meaning |
|---|---|
| `learner` | the learner's name, one per file: letters, digits, `_`, `.` and `-`, and no built-in row's (`BUILT_IN`) |
| `task` | DOMAIN.TASK, one of the benchmark's (`protocol.BUDGETS`) |
| `budget` | the environment steps its agents trained for: the task's budget |
| `fraction` | after which fraction of the budget the agent was evaluated (`protocol.FRACTIONS`) |
| `seed` | the agent's seed, an integer 0 to `protocol.AGENTS` - 1 (its evaluation episodes start from the suite's starts of seed + `evaluation.EVALUATION_SEED`, e.g. `env.reset(seed=seed + 10000)` of `lwrl.gym`) |
| `episode` | the evaluation episode, an integer 1 to `evaluation.EPISODES` |
| `steps` | the episode's steps, an integer 1 to the cap (`evaluation.step_cap`: `evaluation.STEP_CAP` on the tasks measured in steps, else the episode's length) |
| `uptime_s` | its seconds up, on the tasks measured in up-time (the pendulum, the cart-pole): 0 to the episode's length in seconds (`evaluation.episode_seconds`) |
| `protocol` | the protocol's version it followed (`protocol.VERSION`) |
| `starts` | the digest of the evaluation starts it ran from (`evaluation.starts_digest`), the protocol's (`evaluation.protocol_digest`) |

Every agent of seeds 0 to 19 at every fraction with every episode must be there: a file that
is not so is refused in one line naming what is wrong and what is allowed.

An outside row lives apart from the rows (`study.TaskRuns.outside`): the report lists it in
its leaderboard, marked, and no verdict, table or aggregate of the rows reads it.
"""

import re
import zlib

import numpy as np
import pandas as pd

from lwrl import outputs
from lwrl.studies.paper.benchmark import evaluation, protocol, study

COLUMNS = ("learner", "task", "budget", "fraction", "seed", "episode", "steps", "protocol",
           "starts")
TEXT = ("learner", "task", "protocol", "starts")
"""The columns read as text, as written: a digest of digits alone is no number, and a name
such as `NA` or `null` no empty cell."""
NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")
"""An outside learner's name (it names its file in the benchmark's directory)."""
BUILT_IN = ("random", "classical", *dict.fromkeys(
    row.label for task in protocol.BUDGETS for row in protocol.rows(task)))
"""The benchmark's own rows, the reference rows among them: names no outside row takes."""


def read(path: str, plant: str = "analytic") -> pd.DataFrame:
    """The results file at `path`, checked (see the module) against the protocol on `plant`;
    a one-line ValueError for a file that cannot be read or does not follow the protocol."""
    try:
        table = outputs.read_table(path)
        cells = outputs.read_table(path, header=None, dtype=str, keep_default_na=False)
    except (OSError, EOFError, zlib.error, ValueError, UnicodeDecodeError) as error:
        damaged = isinstance(error, (EOFError, zlib.error))  # a gzip file cut short or changed
        why = "damaged compressed data" if damaged else type(error).__name__
        raise ValueError(f"{path}: not a readable CSV file ({why})") from None
    names = cells.iloc[0].tolist()
    twice = [name for name in dict.fromkeys(names) if names.count(name) > 1]
    if twice:
        raise ValueError(f"{path}: the column {twice[0]!r} is there twice; each column once")
    for column in TEXT:  # as written: a learner "NA" is no empty cell
        if column in names:
            table[column] = cells.iloc[1:, names.index(column)].to_numpy()
    check(table, path, plant)
    return table


def check(table: pd.DataFrame, source: str, plant: str = "analytic") -> None:
    """A one-line ValueError naming the first way `table` departs from the protocol on
    `plant`."""
    missing = [c for c in COLUMNS if c not in table.columns]
    if missing:
        raise ValueError(f"{source}: missing column {missing[0]!r}; the columns are "
                         f"{', '.join(COLUMNS)} and, on the tasks measured in up-time, uptime_s")
    if table.empty:
        raise ValueError(f"{source}: no rows")
    for column in ("learner", "task"):
        if table[column].nunique(dropna=False) != 1:
            raise ValueError(f"{source}: one {column} per file; got {sorted(map(str, table[column].unique()))}")
    check_name(str(table["learner"].iloc[0]), source)
    task = str(table["task"].iloc[0])
    if task not in protocol.BUDGETS:
        raise ValueError(f"{source}: unknown task {task!r}; allowed: {', '.join(protocol.BUDGETS)}")
    column = evaluation.task_measure(task).column
    if column not in table.columns:
        raise ValueError(f"{source}: {task} is measured in {column}, a column the file lacks")
    budgets = set(table["budget"].tolist())
    if budgets != {protocol.BUDGETS[task]}:
        raise ValueError(f"{source}: the budget of {task} is {protocol.BUDGETS[task]} steps; "
                         f"got {sorted(budgets, key=str)}")
    numbers = pd.DataFrame({name: pd.to_numeric(table[name], errors="coerce")
                            for name in ("fraction", "seed", "episode", "steps")})
    for name, values in numbers.items():
        counted = name != "fraction"
        if not (np.isfinite(values) & ((values % 1 == 0) | (not counted))).all():
            raise ValueError(f"{source}: every {name} must be a "
                             f"{'whole' if counted else 'finite'} number")
    _check_values(numbers, "fraction", protocol.FRACTIONS, source)
    _check_values(numbers, "seed", range(protocol.AGENTS), source)
    _check_values(numbers, "episode", range(1, evaluation.EPISODES + 1), source)
    if numbers.duplicated(["fraction", "seed", "episode"]).any():
        raise ValueError(f"{source}: an episode is there twice (the same fraction, seed and episode)")
    if len(table) != len(protocol.FRACTIONS) * protocol.AGENTS * evaluation.EPISODES:
        raise ValueError(f"{source}: every seed needs every episode at every fraction; "
                         f"{len(table)} rows of {len(protocol.FRACTIONS) * protocol.AGENTS * evaluation.EPISODES}")
    _check_recorded(table, task, source, plant)  # a whole file's starts: every seed's
    values = pd.to_numeric(table[column], errors="coerce")
    if not np.isfinite(values).all():
        raise ValueError(f"{source}: every {column} must be a finite number")
    _check_range(numbers["steps"], "steps", 1, evaluation.step_cap(task), source, task)
    if column == "uptime_s":
        _check_range(values, column, 0.0, evaluation.episode_seconds(task), source, task)


def check_name(name: str, source: str) -> None:
    """A one-line ValueError unless `name` can name an outside row (`NAME`, not `BUILT_IN`)."""
    if not NAME.fullmatch(name):
        raise ValueError(f"{source}: learner {name!r} is no name: letters, digits, _, . and - "
                         "(a letter or digit first)")
    if name in BUILT_IN:
        raise ValueError(f"{source}: learner {name!r} is the name of a row of the benchmark "
                         f"({', '.join(BUILT_IN)}); an outside row needs a name of its own")


def _check_recorded(table: pd.DataFrame, task: str, source: str, plant: str) -> None:
    """The protocol's version and the digest of its evaluation starts on `plant`, one each,
    as the file records them."""
    wanted = {"protocol": protocol.VERSION, "starts": evaluation.protocol_digest(task, plant)}
    what = {"protocol": "the protocol's version", "starts": f"the digest of the evaluation "
            f"starts of {task} on the {plant} plant"}
    for column, value in wanted.items():
        given = sorted(set(map(str, table[column])))
        if given != [value]:
            raise ValueError(f"{source}: {column} must be {what[column]}, {value}; got "
                             f"{', '.join(map(repr, given))} (`lwrl bench evaluate` writes it)")


def _check_range(values, column: str, low, high, source: str, task: str) -> None:
    """Every value of `column` in [`low`, `high`]."""
    outside = values[(values < low) | (values > high)]
    if len(outside):
        raise ValueError(f"{source}: every {column} of {task} must be in [{low:g}, {high:g}]; "
                         f"got {outside.iloc[0]:g}")


def _check_values(table: pd.DataFrame, column: str, allowed, source: str) -> None:
    """Every value of `allowed` in `column`, and nothing else."""
    allowed = list(allowed)
    given = sorted(set(table[column].tolist()))
    if given != sorted(allowed):
        raise ValueError(f"{source}: {column} must take each of {allowed[0]}..{allowed[-1]} "
                         f"({len(allowed)} values) and no other; got {len(given)} values from "
                         f"{given[0]:g} to {given[-1]:g}")


def scores(table: pd.DataFrame, reference: dict) -> dict:
    """`{(learner, fraction): (agents,) normalised scores}` of a checked table, with the task's
    reference rows' measures `reference` (`study.references`)."""
    task, learner = str(table["task"].iloc[0]), str(table["learner"].iloc[0])
    return {(learner, float(fraction)): study.normalised(task, evaluation.measure(part, task), reference)
            for fraction, part in table.groupby("fraction")}
