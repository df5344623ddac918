"""How far the third benchmark has got in a directory, read from its files alone (nothing is
run, claimed or written), `lwrl bench status`: per task its reference rows, per row its
search's rungs (configurations evaluated of each), the configuration it chose, its runs on
the clock and, on the rule's first stage's tasks, past the budget where it still rises
(`study.longer`; its runs counted once the row's on the clock are written), and an
estimate of the CPU of the trainings it has left.

The estimate: the agent-steps of the trainings not yet written (a population learner's runs
on the clock are one run, `runners.sweep.families`; a linear learner's each its own; the
rungs not yet begun by `compute_plan.SEARCH_RUNGS`), at the CPU per agent-step that the
records of the row's longest training so far with the pending ones' network give
(`recorded_rate`; a search's 64 x 64 runs say little of a 256 x 256 row's cost), else that
the ledger counts for the row's trainings so far (`benchmark.progress.cpu_per_agent_step`),
else for its learner's on the directory's other rows, else the second benchmark's committed
ledger's (`compute_plan.rate`, with its stand-ins). Greedy evaluations are not counted; a small
search run costs more per agent-step than a row of many agents, so the estimate errs high
for the linear rows.
"""

import os
import pathlib

import numpy as np

import lwrl
from lwrl.runners import records
from lwrl.runners.store import RunStore
from lwrl.runners.sweep import families, longest
from lwrl.studies.paper.benchmark import compute_plan, progress, protocol
from lwrl.studies.paper.benchmark import study as second
from lwrl.studies.paper.benchmark.third import clock, halving, rule, study


SECOND = "docs/benchmark2"
"""The second benchmark's committed runs in lwrl's checkout, whose ledger's rates stand in
for a learner this directory's ledger does not count yet."""


def steps(trainings) -> int:
    """The agent-steps computing `trainings` takes: one run per family, its longest."""
    return sum(run.agents * run.budget for run in map(longest, families(list(trainings))))


def _done(store: RunStore, training, evaluate) -> bool:
    """Whether `training` needs no computing: its table is written, or its evaluation."""
    return store.path(training).exists() or store.finished(evaluate(training))


class RowProgress:
    """One row's state: what it has done (`text`), the trainings it has left that are known
    (`pending`), every training known (`known`) and the agent-steps of those not yet known
    (`later`)."""

    def __init__(self, out_dir: str, reference, learner: str):
        self.out_dir, self.reference, self.learner = out_dir, reference, learner
        self.store = RunStore(out_dir, make=False)
        self.text, self.pending, self.known, self.later, self.stages = [], [], [], 0, 0

    def evaluate(self, trainings: dict, what: str, evaluate) -> tuple:
        """`study`'s evaluation of one stage's `trainings` read from the directory, its count
        kept; an `Unfinished` error where its evaluations are not all written (or the
        reference rows, which score them)."""
        runs = list(trainings.values())
        self.stages += 1
        self.known += runs
        self.pending += [run for run in runs if not _done(self.store, run, evaluate)]
        evaluated = sum(self.store.finished(evaluate(run)) for run in runs)
        self.text.append(f"{what.rsplit(': ', 1)[-1]} {evaluated}/{len(runs)} evaluated")
        if evaluated < len(runs) or self.reference is None:
            raise study.Unfinished(what)
        return second.read_evaluated(trainings, self.out_dir, what, evaluate)


def search_steps(task: str, row: protocol.Row, stages: int, plant: str) -> int:
    """The agent-steps of a row's search after its first `stages` stages (a rung but the
    last, or one configuration of the last on the clock)."""
    budget = protocol.BUDGETS[rule.split(task)[0]]
    last = len(compute_plan.SEARCH_RUNGS) - 1
    finalists = compute_plan.SEARCH_RUNGS[last][0]
    finalist = steps(clock.trainings(halving.rung_training(
        task, row, halving.configurations(task, row)[0], last, plant)).values())
    early = [count * seeds * fraction * budget
             for count, seeds, fraction in compute_plan.SEARCH_RUNGS[:last]]
    return int(sum(early[stages:]) + finalist * (finalists - max(0, stages - last)))


def row_progress(task: str, row: protocol.Row, out_dir: str, plant: str, reference,
                 chosen_on_task) -> RowProgress:
    """The state of `row` of `task` (`reference`: the task's reference rows, or None while
    they are not written; `chosen_on_task`: a variant's configurations, None on a task)."""
    state = RowProgress(out_dir, reference, row.learner)
    chosen = None
    if chosen_on_task is None:
        try:
            _, chosen, _ = study.search_row(task, row, plant, reference, state.evaluate)
        except study.Unfinished:
            state.later += search_steps(task, row, state.stages, plant)
    else:
        chosen = chosen_on_task.get(row.label)
    settings = halving.configurations(task, row)[0 if chosen is None else chosen]
    runs = clock.trainings(rule.training(task, row, settings, rule.SEED, rule.agents(task, row),
                                         1.0, plant))
    if chosen is None:
        state.later += steps(runs.values())
        state.text.append("its runs wait for its search" if chosen_on_task is None
                          else "its runs wait for its task's search")
        return state
    state.text.append(f"configuration {chosen} chosen")
    try:
        scores, _, _ = study.clock_row(task, runs, reference, state.evaluate,
                                       f"its {rule.agents(task, row)} agents on the clock", True)
        if task in rule.STAGE_1 and not clock.rising(scores):
            state.text.append("not rising at the budget: carried to 4 times it")
        elif task in rule.STAGE_1:
            state.evaluate(clock.longer_trainings(runs[clock.POINTS[-1]]),
                           "rising at the budget: continued to 4 times it", clock.evaluation_at)
    except study.Unfinished:
        pass
    return state


def task_lines(task: str, out_dir: str, plant: str = "analytic") -> list:
    """The lines of one task (see the module)."""
    written = os.path.exists(study.references_path(task, out_dir, plant))
    lines = [f"{task} ({plant} plant): reference rows {'written' if written else 'not run yet'}"]
    reference = study.references(task, out_dir, plant) if written else None
    base = rule.split(task)[0]
    chosen_on_task = None
    if base != task:
        try:
            chosen_on_task = {label: runs.chosen for label, runs
                              in study.read_task(base, out_dir, plant).rows.items()}
        except study.Unfinished:
            chosen_on_task = {}
    states = {row.label: row_progress(task, row, out_dir, plant, reference, chosen_on_task)
              for row in rule.rows(task)}
    planned, total = planned_rates(), 0.0
    for label, state in states.items():
        seconds, text = left(state, out_dir, states, planned)
        total += seconds
        lines.append(f"  {label:<20} {'; '.join(state.text)}{text}")
    if total:
        lines.append(f"  about {progress.duration(total)} of CPU of trainings left on {task} "
                     "(greedy evaluations apart)")
    return lines


def left(state: RowProgress, out_dir: str, states: dict, planned) -> tuple:
    """`(CPU seconds, text)` of the trainings a row has left, at its rate (see the module):
    `; about ... of CPU of trainings left`, nothing where it has nothing left, the agent-steps
    alone where no rate is known. `planned`: the second benchmark's ledger rates
    (`compute_plan.ledger_rates`), for a learner this directory's ledger does not count yet."""
    agent_steps = steps(state.pending) + state.later
    if not agent_steps:
        return 0.0, ""
    shapes = {network(run) for run in state.pending}
    alike = [run for other in states.values() for run in other.known
             if run.learner == state.learner]
    rate, source = recorded_rate(out_dir, [run for run in state.known if network(run) in shapes])
    if rate is None:
        rates = (progress.cpu_per_agent_step(out_dir, state.known)
                 or progress.cpu_per_agent_step(out_dir, alike))
        rate, source = float(np.mean(list(rates.values()))) if rates else None, "its ledger's rate"
    if rate is None:
        try:
            rate, of = compute_plan.rate(planned, state.learner, "training")
        except ValueError:
            return 0.0, f"; {agent_steps / 1e6:.1f} M agent-steps of training left (no rate yet)"
        source = f"the second benchmark's rate of {of}"
    seconds = rate * agent_steps
    return seconds, (f"; about {progress.duration(seconds)} of CPU of trainings left "
                     f"({agent_steps / 1e6:.1f} M agent-steps at {source})")


def recorded_rate(out_dir: str, runs) -> tuple:
    """`(CPU seconds per agent-step, its source)` the records of the longest of `runs` that
    has them give (`runners.records`: every agent's share of its training's CPU over its
    steps), or `(None, None)`: the longest, since a short run's steps are more of its cheap
    first ones (before `learning_starts`, say)."""
    written = [run for run in runs if RunStore.records_file(out_dir, run.key).exists()]
    if not written:
        return None, None
    table = records.read(out_dir, [max(written, key=lambda run: run.budget)])
    return (float(table["cpu_s"].sum() / table["steps"].sum()),
            "the rate its longest recorded run of that network took")


def network(run) -> str | None:
    """The hidden layers of `run`'s networks (`net_arch`), None for a learner without: a
    search's runs of one learner differ in their CPU per agent-step by their network's size
    far more than by anything else."""
    return getattr(run.settings, "net_arch", None)


def planned_rates():
    """The second benchmark's ledger rates (`compute_plan.ledger_rates`) where lwrl runs from
    its checkout, which holds its committed runs (`SECOND`); else none."""
    return compute_plan.ledger_rates(pathlib.Path(lwrl.__file__).resolve().parent.parent / SECOND)


def lines(tasks, out_dir: str, plant: str = "analytic") -> list:
    """Every task's lines, then the ledger's count (`benchmark.progress.ledger`)."""
    return [line for task in tasks for line in task_lines(task, out_dir, plant)] + [
        progress.ledger(out_dir)]
