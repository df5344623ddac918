"""The third benchmark's runs, in order, through the sweep runner (resumable, claimed in
batches, Ray), into one directory `OUT` that records the rule's edition (`rule.EDITION_FILE`):

1. the reference rows' greedy episodes (`references/<task>-<plant>.csv.gz`), on the starts
   of the rows' evaluations (seeds `rule.SEED` up, `compute_plan.LIGHT_AGENTS` of them, the
   clock's verdict episodes and starts);
2. row by row, in the protocol's order: its search by successive halving (`halving`; on a
   variant, none: the configuration chosen on its task), then the chosen configuration
   trained by the row's agents (`rule.agents`) on seeds `rule.SEED` up and evaluated at
   every point of the clock (`clock`);
3. once every task of the rule's first stage and the variants have run, the rule's third
   stage (`longer`): on each of the first stage's tasks the rows still rising at the budget
   continued to 4 times it (`clock.longer_trainings`), the others carried; on the other
   tasks, which the plan does not continue, a row not rising is carried and a rising one is
   not run there (`carried`).

Every run's per-episode table is `OUT/runs/<key>.csv.gz`, written whole by the sweep runner
(`runners.store`); a training whose evaluation is written is not run again, so the tables
alone resume the study, and a killed run computes again only what it had not written.
"""

import dataclasses
import os

import numpy as np
import pandas as pd

from lwrl import outputs
from lwrl.studies.paper.benchmark import compute_plan, evaluation, protocol
from lwrl.studies.paper.benchmark import study as second
from lwrl.studies.paper.benchmark.third import clock, halving, rule

Unfinished = second.Unfinished


@dataclasses.dataclass
class RowRuns:
    """One row of a task: its search's rungs, the configuration it chose, and its agents'
    normalised scores at every point of the clock."""

    row: protocol.Row
    rungs: list
    """Per rung, `{i: (agents,) normalised scores}` of its configurations (the last rung's
    at the whole budget); empty on a variant (no search of its own)."""
    chosen: int
    """The configuration the row runs (its position in `halving.configurations`)."""
    scores: dict
    """`{j: (agents,) normalised scores}` at each point of the clock, an agent that diverged
    in training at the task's worst outcome."""
    trainings: dict
    """`{j: RunConfig}` of the row's runs."""
    own: list
    """The keys of the row's runs, its trainings' and their evaluations'."""
    searched: list
    """The keys of its search's runs, trainings and evaluations (none on a variant)."""
    longer: dict | None = None
    """`{j: (agents,) normalised scores}` past the budget (`clock.LONGER`) of a row still
    rising at 1 (`clock.rising`), continued; `{}` for a row that is not, whose score at 4
    times the budget is its score at 1, carried; None where the stage has not run."""
    continued: list = dataclasses.field(default_factory=list)
    """The keys of the runs that continued it (`longer`), which `own` holds too."""


@dataclasses.dataclass
class TaskRuns:
    """What the study ran on one task: the reference rows' measures and its rows."""

    task: str
    references: dict
    rows: dict
    """`{label: RowRuns}`, in the protocol's order."""
    unfinished: dict = dataclasses.field(default_factory=dict)
    """`{label: what is not written}` of the rows a partial reading left out (`read_task`)."""


def references_path(task: str, out_dir: str, plant: str) -> str:
    """Where `out_dir` keeps the reference rows' greedy episodes of `task` on `plant`."""
    return second.references_path(task, out_dir, plant)


def references(task: str, out_dir: str, plant: str = "analytic") -> dict:
    """The reference rows' per-agent measures on `task` (see the module), from their table
    where written, else run and written."""
    path = references_path(task, out_dir, plant)
    base = rule.split(task)[0]
    if not os.path.exists(path):
        spread = clock.START_SPREAD.get(protocol.variant(base)[0])
        tables = evaluation.run_references(
            base, compute_plan.LIGHT_AGENTS, plant, clock.VERDICT_EPISODES,
            rule.environment(task), rule.SEED, {"start_spread": spread} if spread else None)
        table = pd.concat([t.assign(row=row) for row, t in tables.items()], ignore_index=True)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        outputs.write_table(table, path)
    table = outputs.read_table(path)
    return {row: evaluation.measure(part, base) for row, part in table.groupby("row")}


def study_task(task: str, out_dir: str, plant: str = "analytic", sweep=None) -> TaskRuns:
    """The searches and rows of `task` (see the module), resuming what `out_dir` holds."""
    sweep = sweep or {}

    def evaluate(trainings, what, how):
        return second.train_and_evaluate(trainings, out_dir, sweep, what, how)

    return _task_runs(task, out_dir, plant, references(task, out_dir, plant), evaluate)


def read_task(task: str, out_dir: str, plant: str = "analytic", partial: bool = False) -> TaskRuns:
    """`study_task`'s answer from what `out_dir` holds, computing and writing nothing: an
    `Unfinished` error naming the task where a run is not written, or with `partial` the rows
    whose runs are all written, the others in `TaskRuns.unfinished`."""
    if not os.path.exists(references_path(task, out_dir, plant)):
        raise Unfinished(f"{task}: the reference rows are not written")

    def evaluate(trainings, what, how):
        return second.read_evaluated(trainings, out_dir, what, how)

    return _task_runs(task, out_dir, plant, references(task, out_dir, plant), evaluate, partial)


def _task_runs(task: str, out_dir: str, plant: str, reference: dict, evaluate,
               partial: bool = False) -> TaskRuns:
    """Every row of `task`, their evaluations from `evaluate(trainings, description,
    evaluation)` (`second.train_and_evaluate` or `second.read_evaluated`); with `partial`,
    a row whose runs are not all written left out (`TaskRuns.unfinished`)."""
    base = rule.split(task)[0]
    # a variant runs the configurations chosen on its task, whose rows must be written
    chosen_on_task = {} if base == task else {
        label: runs.chosen
        for label, runs in read_task(base, out_dir, plant, partial).rows.items()}
    rows, unfinished = {}, {}
    for row in rule.rows(task):
        try:
            rows[row.label] = _row_runs(task, row, plant, reference, evaluate, chosen_on_task)
        except Unfinished as missing:
            if not partial:
                raise
            unfinished[row.label] = str(missing)
    return TaskRuns(task, reference, rows, unfinished)


def _row_runs(task: str, row: protocol.Row, plant: str, reference: dict, evaluate,
              chosen_on_task: dict) -> RowRuns:
    """One row of `task` (`_task_runs`); on a variant, its configuration `chosen_on_task`."""
    if rule.split(task)[0] == task:
        rungs, chosen, keys = search_row(task, row, plant, reference, evaluate)
    elif row.label in chosen_on_task:
        rungs, chosen, keys = [], chosen_on_task[row.label], []
    else:
        raise Unfinished(f"{task}: {row.label}: its task's row is not written")
    settings = halving.configurations(task, row)[chosen]
    full = rule.training(task, row, settings, rule.SEED, rule.agents(task, row), 1.0, plant)
    scores, trainings, more = clock_row(task, clock.trainings(full), reference, evaluate,
                                        f"{task}: {row.label}", diverged_as_worst=True)
    return RowRuns(row, rungs, chosen, scores, trainings, more, keys)


def longer(runs: TaskRuns, evaluate) -> TaskRuns:
    """`runs` with each row's `longer` (the rule's third stage): a row still rising at the
    budget (`clock.rising`) continued to 4 times it, evaluated at the clock's points past it
    by `evaluate` (`study_task`'s or `read_task`'s); the others `{}`, carried."""
    for label, row in runs.rows.items():
        row.longer = {}
        if clock.rising(row.scores):
            row.longer, _, keys = clock_row(
                runs.task, clock.longer_trainings(row.trainings[clock.POINTS[-1]]),
                runs.references, evaluate, f"{runs.task}: {label}: to 4 times the budget", True)
            row.own += keys
            row.continued = keys
    return runs


def carried(runs: TaskRuns) -> TaskRuns:
    """`runs` of a task whose rows the plan does not continue past the budget (the variants,
    the continuous pendulum: docs/FINDINGS.md, "Compute"), computing nothing: a row not rising
    at the budget carried to 4 times it (`longer` `{}`), a rising one not run there (None)."""
    for row in runs.rows.values():
        row.longer = None if clock.rising(row.scores) else {}
    return runs


def continue_task(task: str, out_dir: str, plant: str = "analytic", sweep=None) -> TaskRuns:
    """`study_task`, then its rows still rising at the budget continued (`longer`),
    resuming what `out_dir` holds."""
    sweep = sweep or {}

    def evaluate(trainings, what, how):
        return second.train_and_evaluate(trainings, out_dir, sweep, what, how)

    return longer(study_task(task, out_dir, plant, sweep), evaluate)


def read_longer(runs: TaskRuns, out_dir: str) -> TaskRuns:
    """`runs` (`read_task`'s) with the third stage's rows where all its runs are written
    (`longer`), else as they are (`RowRuns.longer` None), computing nothing."""

    def evaluate(trainings, what, how):
        return second.read_evaluated(trainings, out_dir, what, how)

    try:
        return longer(runs, evaluate)
    except Unfinished:
        for row in runs.rows.values():
            row.longer = None
        return runs


def clock_row(task: str, trainings: dict, reference: dict, evaluate, what: str,
              diverged_as_worst: bool) -> tuple:
    """`({j: (agents,) normalised scores}, trainings, keys of the runs)` of the runs
    `trainings` (`clock.trainings`) evaluated at every point of the clock."""
    evaluated, _ = evaluate(trainings, what, clock.evaluation_at)
    keys = [config.key for config in trainings.values()]
    keys += [clock.evaluation_at(config).key for config in trainings.values()]
    return (second.scored(rule.split(task)[0], evaluated, reference, diverged_as_worst),
            trainings, keys)


def search_row(task: str, row: protocol.Row, plant: str, reference: dict, evaluate) -> tuple:
    """`(rungs, chosen, keys of the runs)`: successive halving over the row's configurations
    (`halving`)."""
    configurations = halving.configurations(task, row)
    alive = list(range(len(configurations)))
    rungs, keys = [], []
    last = len(compute_plan.SEARCH_RUNGS) - 1
    for rung in range(last):
        trainings = {i: halving.rung_training(task, row, configurations[i], rung, plant)
                     for i in alive}
        evaluated, _ = evaluate(trainings, f"{task}: {row.label}: search rung {rung + 1}",
                                halving.evaluation)
        keys += [config.key for config in trainings.values()]
        keys += [halving.evaluation(config).key for config in trainings.values()]
        rungs.append(second.scored(task, evaluated, reference))
        alive = halving.best(rungs[-1], compute_plan.SEARCH_RUNGS[rung + 1][0])
    finals, curves = {}, {}
    for i in alive:
        full = halving.rung_training(task, row, configurations[i], last, plant)
        what = f"{task}: {row.label}: search rung {last + 1}, configuration {i}"
        scores, _, more = clock_row(task, clock.trainings(full), reference, evaluate, what, False)
        keys += more
        finals[i] = scores[clock.POINTS[-1]]
        curves[i] = clock.area([clock.fraction(j) for j in scores],
                               [np.mean(np.nan_to_num(s, nan=reference_worst(task, reference)))
                                for s in scores.values()])
    rungs.append(finals)
    return rungs, halving.choose({i: (finals[i], curves[i]) for i in alive}), keys


def reference_worst(task: str, reference: dict) -> float:
    """The normalised score of the task's worst outcome (`evaluation.worst`): a diverged
    agent's in the area of a search's curve."""
    return float(second.normalised(task, [evaluation.worst(task)], reference)[0])


def held(out_dir: str, plant: str) -> list:
    """The third benchmark's tasks that `out_dir` has begun (their reference rows written)."""
    return [task for task in rule.TASKS if os.path.exists(references_path(task, out_dir, plant))]
