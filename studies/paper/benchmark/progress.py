"""How far the second benchmark has got in a directory, read from its files alone (nothing is
run, claimed or written): per task the reference rows, per row its search's trainings and
greedy evaluations, once they are all written the configuration it chose with its search
score (the mean normalised score of its search agents, by which it was chosen), then its
rows' (`study`'s steps 1 to 3; `lwrl bench run` starts the rows after every row's search),
and what the ledger counts.
Where the ledger has what a row's search runs cost, a row's line also says what CPU its
trainings left will take, each at the CPU per agent-step of its configuration's search run
(a row's at its chosen one's; before the choice, the span over its configurations; a run
under way at its own so far, from the state it keeps): an estimate, as a population of 20
agents may cost less per agent than one of 3.
A study that takes several working sessions is resumed by the same `lwrl bench run`; this
says what that command has left to do. `lwrl bench status`."""

import os

import numpy as np

from lwrl.runners.resume import kept
from lwrl.runners.store import RunStore, compute_spent, ledger_lines
from lwrl.runners.sweep import families, given_on_the_way, longest
from lwrl.studies.paper.benchmark import evaluation, protocol, search, study


def _counts(store: RunStore, configs) -> tuple:
    """`(trained, evaluated)`: how many of the trainings `configs` have their table and
    their greedy evaluation's."""
    configs = list(configs)
    return (sum(store.path(config).exists() for config in configs),
            sum(store.finished(evaluation.evaluation(config)) for config in configs))


def _chosen(task: str, out_dir: str, plant: str, runs: dict, store: RunStore):
    """`({label: i}, {(label, i): search agents' scores})`: the chosen configuration
    (`study.choose`) of each row whose search is evaluated whole, and those configurations'
    normalised scores; nothing while the reference rows are missing."""
    path = study.references_path(task, out_dir, plant)
    evaluations = {name: evaluation.evaluation(config) for name, config in runs.items()}
    unfinished = {label for (label, _), run in evaluations.items() if not store.finished(run)}
    whole = {name: run for name, run in evaluations.items() if name[0] not in unfinished}
    if not os.path.exists(path) or not whole:
        return {}, {}
    reference = study.references(task, out_dir, plant)  # written: read, not run
    scores = study.scored(task, {name: store.read([run]) for name, run in whole.items()}, reference)
    return study.choose(scores), scores


def cpu_per_agent_step(out_dir: str, configs) -> dict:
    """`{key: CPU seconds per agent-step}` of the runs of `configs` that lines of the ledger
    computed alone, as the longest of its family (`runners.sweep.families`) or together with
    runs of the same budget as one population (`runners.sweep.populations`): their CPU (a
    stopped run's earlier processes' line too, `runners.resume`) over the agents of the runs
    the line computed times their budget."""
    by_key = {config.key: config for config in configs}
    rates = {}
    for line in ledger_lines(out_dir, set(by_key)):
        mine = [by_key[key] for key in line["runs"]]
        given = given_on_the_way(mine)
        computed = [config for config in mine if config.key not in given]
        budgets = {config.budget for config in computed}
        if len(budgets) == 1 and None not in budgets:
            steps = sum(config.agents * config.budget for config in computed)
            for run in computed:
                rates[run.key] = rates.get(run.key, 0.0) + line["cpu_s"] / steps
    return rates


def cpu_left(pending, rate: float, out_dir=None) -> float:
    """CPU seconds the `pending` trainings would take at `rate` per agent-step: a family's
    (`runners.sweep.families`) its longest run's steps; for a run under way (its state kept
    in `out_dir`, `runners.resume`) the steps it has left, at its own rate so far."""
    total = 0.0
    for run, state in _under_way(pending, out_dir):
        taken = state.get("steps") or 0
        own = state["cpu_s"] / (run.agents * taken) if taken else rate
        total += own * run.agents * (run.budget - taken)
    return total


def under_way(out_dir: str, pending) -> str:
    """What the pending trainings' kept states say (`runners.resume`): the steps each one's
    longest run has taken, or nothing."""
    said = [f"{state['steps']:,} of {run.budget:,} steps"
            for run, state in _under_way(pending, out_dir) if "steps" in state]
    return f" (its run under way kept at {', '.join(said)})" if said else ""


def _under_way(pending, out_dir) -> list:
    """`[(longest run, what its kept state says)]`, one per family of `pending`
    (`runners.sweep.families`); nothing kept without `out_dir`."""
    return [(run, kept(RunStore.resume_file(out_dir, run.key)) if out_dir else {})
            for run in map(longest, families(pending))]


def task_lines(task: str, out_dir: str, plant: str = "analytic") -> list:
    """The lines of one task (see the module)."""
    store = RunStore(out_dir, make=False)
    written = os.path.exists(study.references_path(task, out_dir, plant))
    lines = [f"{task} ({plant} plant): reference rows {'written' if written else 'not run yet'}"]
    runs = search.runs(task, plant)
    chosen, scores = _chosen(task, out_dir, plant, runs, store)
    rates = cpu_per_agent_step(out_dir, runs.values())
    for row in protocol.rows(task):
        mine = [config for (label, _), config in runs.items() if label == row.label]
        trained, evaluated = _counts(store, mine)
        text = (f"  {row.label:<20} search {trained}/{len(mine)} trained, "
                f"{evaluated}/{len(mine)} evaluated; ")
        if row.label not in chosen:
            measured = [rates[config.key] for config in mine if config.key in rates]
            pending = [config for config in mine if not _done(store, config)]
            left = cpu_left(pending, float(np.mean(measured))) if measured else None
            text += "its rows wait for every row's search"
            costs = [cpu_left(study.row_trainings(task, row, i, plant).values(), rates[config.key])
                     for (label, i), config in runs.items()
                     if label == row.label and config.key in rates]
            if costs:
                span = dict.fromkeys((duration(min(costs)), duration(max(costs))))
                text += f" (they will take {' to '.join(span)} of CPU, by the configuration chosen)"
        else:
            trainings = list(study.row_trainings(task, row, chosen[row.label], plant).values())
            trained, evaluated = _counts(store, trainings)
            mean = np.mean(scores[row.label, chosen[row.label]])
            text += (f"configuration {chosen[row.label]} chosen, search score {mean:.2f}; "
                     f"rows ({protocol.AGENTS} agents "
                     f"at {len(trainings)} fractions) {trained}/{len(trainings)} trained, "
                     f"{evaluated}/{len(trainings)} evaluated")
            rate = rates.get(runs[row.label, chosen[row.label]].key)
            pending = [config for config in trainings if not _done(store, config)]
            text += under_way(out_dir, pending)
            left = cpu_left(pending, rate, out_dir) if rate is not None else None
        if left:
            text += (f"; about {duration(left)} of CPU of trainings left"
                     + (" (its search's)" if row.label not in chosen else ""))
        lines.append(text)
    return lines


def duration(seconds: float) -> str:
    """`seconds` in hours from an hour on, else in whole minutes (at least one)."""
    return f"{seconds / 3600:.1f} h" if seconds >= 3600 else f"{max(1, round(seconds / 60))} min"


def _done(store: RunStore, training) -> bool:
    """Whether `training` needs no computing: its table is written, or its evaluation."""
    return store.path(training).exists() or store.finished(evaluation.evaluation(training))


def lines(tasks, out_dir: str, plant: str = "analytic") -> list:
    """Every task's lines, then the ledger's count (`runners.store.compute_spent`)."""
    return [line for task in tasks for line in task_lines(task, out_dir, plant)] + [ledger(out_dir)]


def ledger(out_dir: str) -> str:
    """The line of what the ledger of `out_dir` counts (`runners.store.compute_spent`)."""
    spent = compute_spent(out_dir)
    return (f"ledger ({os.path.join(out_dir, 'compute.jsonl')}): {spent['runs']} runs, "
            f"{spent['wall_s'] / 3600:.2f} h of wall time, {spent['cpu_s'] / 3600:.2f} h of CPU")
