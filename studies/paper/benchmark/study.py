"""The second benchmark's runs, in order, through the sweep runner (resumable, claimed in
batches, Ray), into one directory `OUT`:

1. the reference rows' greedy episodes (`references/<task>.csv.gz`: seconds);
2. the search (`search.runs`): every configuration's training, its agents kept, then its
   greedy evaluation; each configuration is scored by its agents' mean final normalised
   score, and the row takes the best;
3. the rows: the chosen configuration trained by `protocol.AGENTS` agents for each fraction of
   the budget (`protocol.FRACTIONS`), each evaluated greedily (a deep row's fractions
   computed as one run, the longest, `runners.sweep.families`).

Every run's per-episode table is `OUT/runs/<key>.csv.gz`; the kept agents
(`<key>.agents.npz`) are needed only until a run's evaluation is written: a training whose
evaluation is finished is not run again, so the committed tables alone resume the study on
a fresh clone.
"""

import dataclasses
import os

import numpy as np
import pandas as pd

from lwrl import outputs
from lwrl.analysis import verdicts
from lwrl.runners.store import RunStore
from lwrl.runners.sweep import run_sweep
from lwrl.studies.paper.benchmark import evaluation, protocol, search

REFERENCES = "references"


@dataclasses.dataclass
class TaskRuns:
    """What the study ran on one task: the reference rows' per-agent measures, every search
    configuration's score, the chosen configurations, and the rows' per-agent normalised
    scores at each fraction of the budget, with the runs' tables."""

    task: str
    references: dict
    """`{"random" | "classical": (agents,) measures}`."""
    search_scores: dict
    """`{(label, i): (search agents,) normalised scores}` of every configuration."""
    chosen: dict
    """`{label: i}`: the configuration each row took."""
    scores: dict
    """`{(label, fraction): (agents,) normalised scores}` of the rows, an agent that diverged
    in training at the task's worst outcome (`evaluation.worst`)."""
    trainings: dict
    """`{(label, fraction): RunConfig}` of the rows' trainings."""
    tables: pd.DataFrame
    """Every training and evaluation table the study read, the rows' and the search's."""
    diverged: dict = dataclasses.field(default_factory=dict)
    """`{(label, fraction): count}`: how many of each row's agents diverged in training."""
    outside: dict = dataclasses.field(default_factory=dict)
    """`{(name, fraction): (agents,) normalised scores}` of the outside rows (`outside`):
    apart from `scores`, so that no outside row takes a row's place or enters a verdict."""


def references(task: str, out_dir: str, plant: str = "analytic") -> dict:
    """The reference rows' per-agent measures on `task`, from `OUT/references/<task>.csv.gz`
    where an earlier call wrote it, else run (`evaluation.run_references`: `protocol.AGENTS`
    agents, `evaluation.EPISODES` episodes each) and written."""
    path = references_path(task, out_dir, plant)
    if not os.path.exists(path):
        tables = evaluation.run_references(task, protocol.AGENTS, plant, evaluation.EPISODES)
        table = pd.concat([t.assign(row=row) for row, t in tables.items()], ignore_index=True)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        outputs.write_table(table, path)
    table = outputs.read_table(path)
    return {row: evaluation.measure(part, task) for row, part in table.groupby("row")}


def references_path(task: str, out_dir: str, plant: str) -> str:
    """Where `out_dir` keeps the reference rows' greedy episodes of `task` on `plant`: its
    being there makes `task` one of the directory's (`held`)."""
    return os.path.join(out_dir, REFERENCES, f"{task}-{plant}.csv.gz")


def held(out_dir: str, plant: str) -> list:
    """The benchmark's tasks on `plant` that `out_dir` has begun (their reference rows
    written), in the protocol's order."""
    return [task for task in protocol.tasks_on(plant)
            if os.path.exists(references_path(task, out_dir, plant))]


def normalised(task: str, values, reference: dict) -> np.ndarray:
    """`values` (the task's measure, per agent) as normalised scores: the random row 0, the
    classical row 1 (`analysis.verdicts.normalised_score`)."""
    return verdicts.normalised_score(values, reference["random"], reference["classical"],
                                     evaluation.task_measure(task).higher_is_better)


def train_and_evaluate(trainings: dict, out_dir: str, sweep: dict, description: str,
                       evaluate=evaluation.evaluation) -> tuple:
    """Run the trainings `{name: RunConfig}` (agents kept) whose greedy evaluation
    (`evaluate(training)`, the benchmark's by default) is not written yet, then every
    evaluation; return `({name: evaluation table}, every table)`."""
    evaluations = {name: evaluate(config) for name, config in trainings.items()}
    store = RunStore(out_dir)
    pending = [config for name, config in trainings.items() if not store.finished(evaluations[name])]
    if pending:
        run_sweep(pending, out_dir, **sweep, description=f"{description}: training",
                  keep_agents=True)
    table, _ = run_sweep(list(evaluations.values()), out_dir, **sweep,
                         description=f"{description}: evaluation")
    return _evaluated(trainings, evaluations, table, store)


def read_evaluated(trainings: dict, out_dir: str, description: str,
                   evaluate=evaluation.evaluation) -> tuple:
    """`train_and_evaluate`'s answer from the tables `out_dir` holds, computing nothing: an
    `Unfinished` error where an evaluation is not written."""
    evaluations = {name: evaluate(config) for name, config in trainings.items()}
    store = RunStore(out_dir)
    missing = sum(not store.finished(run) for run in evaluations.values())
    if missing:
        raise Unfinished(f"{description}: {missing} of {len(evaluations)} greedy evaluations "
                         "not written")
    return _evaluated(trainings, evaluations, store.read(list(evaluations.values())), store)


class Unfinished(ValueError):
    """A task whose runs are not all written (`read_task`)."""


def _evaluated(trainings: dict, evaluations: dict, table: pd.DataFrame, store: RunStore) -> tuple:
    """`({name: evaluation table}, every table)`: the evaluations' `table` split by run, and
    with it the trainings' tables that are written (a family's shorter runs are not)."""
    by_run = dict(iter(table.groupby("run")))
    trained = [config for config in trainings.values() if store.path(config).exists()]
    tables = pd.concat([table, store.read(trained)], ignore_index=True) if trained else table
    return {name: by_run[config.key] for name, config in evaluations.items()}, tables


def study_task(task: str, out_dir: str, plant: str = "analytic", sweep=None) -> TaskRuns:
    """The search and the rows of `task` (see the module), resuming what `out_dir` holds."""
    sweep = sweep or {}
    return _task_runs(task, out_dir, plant, references(task, out_dir, plant),
                      lambda trainings, what: train_and_evaluate(trainings, out_dir, sweep, what))


def read_task(task: str, out_dir: str, plant: str = "analytic") -> TaskRuns:
    """`study_task`'s answer from what `out_dir` holds, computing and writing nothing: an
    `Unfinished` error naming the task where a run is not written."""
    if not os.path.exists(references_path(task, out_dir, plant)):
        raise Unfinished(f"{task}: the reference rows are not written")
    return _task_runs(task, out_dir, plant, references(task, out_dir, plant),
                      lambda trainings, what: read_evaluated(trainings, out_dir, what))


def _task_runs(task: str, out_dir: str, plant: str, reference: dict, evaluate) -> TaskRuns:
    """The search and the rows of `task`, their evaluations from `evaluate(trainings,
    description)` (`train_and_evaluate` or `read_evaluated`)."""
    evaluated, search_tables = evaluate(search.runs(task, plant), f"{task}: search")
    search_scores = scored(task, evaluated, reference)
    chosen = choose(search_scores)
    trainings = {(row.label, fraction): config for row in protocol.rows(task)
                 for fraction, config in row_trainings(task, row, chosen[row.label], plant).items()}
    evaluated, row_tables = evaluate(trainings, f"{task}: rows")
    diverged = {name: int(np.isnan(evaluation.measure(table, task)).sum())
                for name, table in evaluated.items()}
    return TaskRuns(task, reference, search_scores, chosen,
                    scored(task, evaluated, reference, diverged_as_worst=True), trainings,
                    pd.concat([search_tables, row_tables], ignore_index=True), diverged)


def scored(task: str, evaluated: dict, reference: dict, diverged_as_worst: bool = False) -> dict:
    """`{name: (agents,) normalised scores}` of the evaluation tables `{name: table}`: an
    agent that diverged in training NaN (the search's: `choose` ranks its configuration
    last), or with `diverged_as_worst` (the rows') the task's worst outcome
    (`evaluation.measure`)."""
    return {name: normalised(task, evaluation.measure(table, task, diverged_as_worst), reference)
            for name, table in evaluated.items()}


def row_trainings(task: str, row: protocol.Row, chosen: int, plant: str = "analytic") -> dict:
    """`{fraction: RunConfig}`: the row's chosen configuration (`chosen`, its position in
    the search) trained by `protocol.AGENTS` agents for each fraction of the budget."""
    settings = search.configurations(task, row)[chosen]
    return {fraction: protocol.training(task, row, settings, 0, protocol.AGENTS, fraction, plant)
            for fraction in protocol.FRACTIONS}


def choose(search_scores: dict) -> dict:
    """`{label: i}`: each row's configuration with the best mean normalised score over its
    agents (NaN, a diverged agent's, counting as the worst), the first (the row's own
    settings) on a tie."""
    best = {}
    for (label, i), values in search_scores.items():
        mean = float(np.mean(np.nan_to_num(values, nan=-np.inf)))
        if label not in best or mean > best[label][1]:
            best[label] = (i, mean)
    return {label: i for label, (i, _) in best.items()}
