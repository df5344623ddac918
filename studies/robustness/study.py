"""`lwrl robustness`: train, evaluate over the cells, measure, report.

Both phases go through the sweep runner into one directory, `OUT/runs/` (resumable: a
second call computes only what the first did not finish): the training keeps its agents
(`run_sweep(keep_agents=True)`), the evaluations go on with them greedily. Each cell's
measure is the task's own (`measures`), per agent the mean over its evaluation episodes,
with the 95 % bootstrap interval over agents (`analysis.statistics`).
"""

import dataclasses
import json
import os
import time

import numpy as np
import pandas as pd

from lwrl import agent as learners
from lwrl import outputs
from lwrl import tasks
from lwrl.agent import io as agent_io
from lwrl.analysis.statistics import improvement_interval, mean_interval
from lwrl.runners.sweep import run_sweep
from lwrl.runners.store import RunStore
from lwrl.studies.robustness import controller, plan


def first_of_each_kind() -> tuple:
    """The registry's first learner of each kind of action (`Learner.actions`), in its
    order."""
    first: dict = {}
    for name, learner in learners.LEARNERS.items():
        first.setdefault(learner.actions, name)
    return tuple(first.values())


C_LEARNERS = first_of_each_kind()
"""The learners whose exported controllers run in C: the registry's first of each kind of
action, the paper's light-weight one and, for continuous actions, its actor-critic over the
same NRBF features (CACLA), whose agents export (`Agents.controller`)."""


@dataclasses.dataclass(frozen=True)
class Measure:
    """A column of the results that the study reads, per episode."""

    column: str
    label: str
    unit: str
    higher_is_better: bool
    digits: int


def measures(task: str) -> list:
    """The task's own measures, the first the one mapped: up-time where the task has it,
    else the success rate (the episodes that reach the task's terminal state, not its time
    limit) and the steps per episode (to the goal, or the time limit's)."""
    if tasks.definition(*tasks.split_name(task)).has_uptime:
        return [Measure("uptime_s", "up-time", "s", True, 1)]
    return [Measure("success", "success rate", "", True, 2),
            Measure("steps", "steps per episode", "", False, 0)]


@dataclasses.dataclass
class TaskResult:
    """What the study found on one task."""

    task: str
    plant: str
    axes: tuple
    cells: list
    trainings: dict
    """`{(learner, training): RunConfig}` of the trained runs."""
    per_agent: dict
    """`{(learner, training, cell, measure column): (agents,) values}`."""
    controllers: dict = dataclasses.field(default_factory=dict)
    """`{learner: run}` of the C controllers that ran (`C_LEARNERS`' in the study): `agent`
    (its index), `same` (cells whose episodes equal the Python agent's), `per_cell`
    `{cell: {measure column: value}}`."""
    evaluation_episodes: int = 0
    seconds: float = 0.0
    """This invocation's wall time on the task."""
    computed: int = 0
    runs: int = 0
    timing: dict = dataclasses.field(default_factory=dict)
    """`seconds` and `invocations`: the wall time of every invocation that computed some of
    the task's runs, summed (`add_time`); no invocation where none was recorded."""

    def estimate(self, learner, training, cell, measure):
        return mean_interval(self.per_agent[learner, training, cell, measure.column])

    def grid_cells(self) -> list:
        return [cell for cell in self.cells if cell.kind == "parameters"]

    def grid_scores(self, learner, training, measure) -> np.ndarray:
        """Per agent, its mean over every cell of the parameter grid."""
        return np.mean([self.per_agent[learner, training, cell, measure.column]
                        for cell in self.grid_cells()], axis=0)

    def comparison(self, first, second, measure):
        """The probability that an agent of `first` `(learner, training)` does better over
        the grid than one of `second`, with its interval."""
        return improvement_interval(self.grid_scores(*first, measure),
                                    self.grid_scores(*second, measure), measure.higher_is_better)


def per_episode(table: pd.DataFrame) -> pd.DataFrame:
    """The results with the study's derived column `success` (the episode reached a terminal
    state: not truncated, not cut by divergence)."""
    return table.assign(success=(~table["truncated"].astype(bool)
                                 & ~table["diverged"].astype(bool)).astype(float))


TIMINGS = "timings.json"
"""Per task, the wall time that its runs took, kept beside the runs."""


def add_time(out_dir: str, task: str, keys, seconds: float, resumed: bool = True) -> dict:
    """Add `seconds` of an invocation that computed some of the runs `keys` of `task` (none:
    0) to the task's entry of `out_dir/timings.json`, so that a study resumed in several
    invocations reports the time all of them took. An entry of runs that are all among
    `keys` is added to (the study grew: a learner joined it, and the runs it had are kept)
    where the invocation `resumed` (it found some of those runs finished); an entry of other
    runs (the same task studied otherwise in the same directory), or of runs of which none
    is left (a fresh checkout holds the entry but not the runs, which are computed again),
    is replaced. Return the entry."""
    path = os.path.join(out_dir, TIMINGS)
    timings = json.load(open(path)) if os.path.exists(path) else {}
    keys = sorted(keys)
    entry = timings.get(task)
    if entry is None or not resumed or not set(entry.get("keys", [None])) <= set(keys):
        entry = {"seconds": 0.0, "invocations": 0}
    timings[task] = entry = {**entry, "keys": keys}
    if seconds:
        entry["seconds"] += seconds
        entry["invocations"] += 1
        with outputs.atomic_write(path) as file:
            json.dump(timings, file, indent=2)
    return entry


def finished(out_dir: str, trained: dict, evaluations: dict) -> int:
    """How many of the study's runs are finished in `out_dir` (a training with its kept
    agents)."""
    return (sum(map(RunStore(out_dir, keep_agents=True).finished, trained.values()))
            + sum(map(RunStore(out_dir).finished, evaluations.values())))


def study_task(task: str, out_dir: str, plant: str = "analytic", quick: bool = False,
               agents=None, episodes=None, evaluation_episodes=None, sweep=None,
               stepped=None, learners=None) -> TaskResult:
    """Train, evaluate and measure `task`; the runs in `out_dir/runs`, their batches run by
    `runners.sweep.run_sweep` with the options `sweep` (`backend`, `workers`, `address`);
    `stepped`: the stepped loop's learners' training protocols (`plan.stepped_protocol`);
    `learners`: the learners trained (None: every one that fits, `plan.chosen_learners`)."""
    started = time.perf_counter()
    trained = plan.trainings(task, plant, agents, episodes, quick, stepped, learners)
    count = evaluation_episodes or plan.evaluation_episodes(task, quick)
    cells = plan.cells(task, quick)
    evaluations = {(learner, training, cell): plan.evaluation(task, config, cell, count, quick)
                   for (learner, training), config in trained.items() for cell in cells}
    keys = [config.key for config in [*trained.values(), *evaluations.values()]]
    finished_before = finished(out_dir, trained, evaluations)
    resumed = finished_before > 0
    try:
        _, computed = run_sweep(list(trained.values()), out_dir, **(sweep or {}),
                                description=f"{task}: training", keep_agents=True)
        table, more = run_sweep(list(evaluations.values()), out_dir, **(sweep or {}),
                                description=f"{task}: evaluation")
    except KeyboardInterrupt:  # its finished runs are kept, and so is the time they took
        if finished(out_dir, trained, evaluations) > finished_before:
            add_time(out_dir, task, keys, time.perf_counter() - started, resumed)
        raise
    timing = add_time(out_dir, task, keys, time.perf_counter() - started if computed + more else 0.0,
                      resumed)
    table = per_episode(table)
    per_agent = {}
    for (learner, training, cell), config in evaluations.items():
        rows = table[table["run"] == config.key]
        for measure in measures(task):
            per_agent[learner, training, cell, measure.column] = (
                rows.groupby("agent")[measure.column].mean().to_numpy())
    result = TaskResult(task, plant, tuple(p.name for p in plan.axes(task)), cells, trained,
                        per_agent, evaluation_episodes=count, computed=computed + more,
                        runs=len(trained) + len(evaluations), timing=timing)
    for learner in C_LEARNERS:
        if (learner, "nominal") in trained:
            ran = controlled(task, out_dir, learner, trained[learner, "nominal"], evaluations,
                             table)
            if ran:
                result.controllers[learner] = ran
    result.seconds = time.perf_counter() - started
    return result


CONTINUOUS_RETURNS = 1e-12
"""The relative distance within which a continuous C controller's episode returns count as
the Python agent's (measured: 2.4e-16, one cell of the pendulum's quick study)."""


def returns_tolerance(actions: str) -> float:
    """The relative distance within which a C controller's returns count as the Python
    agent's, for a learner of `actions`: none for discrete actions, `CONTINUOUS_RETURNS`
    for continuous ones."""
    return CONTINUOUS_RETURNS if actions == "continuous" else 0.0


def controlled(task: str, out_dir: str, learner: str, trained, evaluations: dict,
               table: pd.DataFrame) -> dict:
    """The exported C controller of the first agent of `trained` (a run of `learner`) that
    did not diverge, in every cell of the study: its measures, and the cells whose episodes
    (steps and returns, episode by episode) equal that Python agent's; empty where every
    agent diverged. A discrete controller's returns must be the same numbers; a continuous
    one's within `CONTINUOUS_RETURNS` of their size, its action (a double sum in C's order)
    being the Python agent's to an ulp or so, which the plant carries into the return."""
    kept = RunStore.agents_file(out_dir, trained.key)
    runs = {cell: config for (name, training, cell), config in evaluations.items()
            if name == learner and training == "nominal"}
    agent, _ = agent_io.load(kept)
    alive = np.flatnonzero(~agent.diverged)
    if len(alive) == 0:
        return {}
    b = int(alive[0])
    directory = os.path.join(out_dir, "controller", task, learner)
    library = controller.build(kept, directory, b)
    configs = [dataclasses.replace(config, agents=1, seed=config.seed + b) for config in runs.values()]
    results = controller.run_controller(library, configs, [config.seed for config in configs])
    c_table = per_episode(pd.DataFrame(results.columns([config.seed for config in configs])))
    same, per_cell = 0, {}
    for index, (cell, config) in enumerate(runs.items()):
        ours = c_table[c_table["agent"] == index]
        python = table[(table["run"] == config.key) & (table["agent"] == b)]
        same += bool(np.array_equal(ours["steps"].to_numpy(), python["steps"].to_numpy())
                     and np.allclose(ours["return"].to_numpy(), python["return"].to_numpy(),
                                     rtol=returns_tolerance(agent.learner.actions), atol=0.0))
        per_cell[cell] = {measure.column: float(ours[measure.column].mean())
                          for measure in measures(task)}
    return {"agent": b, "same": same, "cells": len(runs), "per_cell": per_cell,
            "source": os.path.join(directory, "lwrl_policy.c")}


def total_runs(task_names, plant: str, quick: bool) -> int:
    """How many runs the study of `task_names` has (trainings and evaluations)."""
    return sum(len(plan.trainings(task, plant, quick=quick)) * (1 + len(plan.cells(task, quick)))
               for task in task_names)
