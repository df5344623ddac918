"""How far the second benchmark has got in a directory, read from its files alone (nothing is
run, claimed or written): per task the reference rows, per row its search's trainings and
greedy evaluations, then its rows' (`study`'s steps 1 to 3), and what the ledger counts.
A study that takes several working sessions is resumed by the same `lwrl bench run`; this
says what that command has left to do. `lwrl bench status`."""

import os

from lwrl.runners.store import RunStore, compute_spent
from lwrl.studies.paper.benchmark import evaluation, protocol, search, study


def _counts(store: RunStore, configs) -> tuple:
    """`(trained, evaluated)`: how many of the trainings `configs` have their table and
    their greedy evaluation's."""
    configs = list(configs)
    return (sum(store.path(config).exists() for config in configs),
            sum(store.finished(evaluation.evaluation(config)) for config in configs))


def _chosen(task: str, out_dir: str, plant: str, runs: dict, store: RunStore):
    """Each row's chosen configuration (`study.choose`), or None while a search evaluation
    or the reference rows are missing."""
    path = os.path.join(out_dir, study.REFERENCES, f"{task}-{plant}.csv.gz")
    evaluations = {name: evaluation.evaluation(config) for name, config in runs.items()}
    if not os.path.exists(path) or not all(map(store.finished, evaluations.values())):
        return None
    reference = study.references(task, out_dir, plant)  # written: read, not run
    tables = {name: store.read([config]) for name, config in evaluations.items()}
    return study.choose(study.scored(task, tables, reference))


def task_lines(task: str, out_dir: str, plant: str = "analytic") -> list:
    """The lines of one task (see the module)."""
    store = RunStore(out_dir, make=False)
    written = os.path.exists(os.path.join(out_dir, study.REFERENCES, f"{task}-{plant}.csv.gz"))
    lines = [f"{task} ({plant} plant): reference rows {'written' if written else 'not run yet'}"]
    runs = search.runs(task, plant)
    chosen = _chosen(task, out_dir, plant, runs, store)
    for row in protocol.rows(task):
        mine = [config for (label, _), config in runs.items() if label == row.label]
        trained, evaluated = _counts(store, mine)
        text = (f"  {row.label:<20} search {trained}/{len(mine)} trained, "
                f"{evaluated}/{len(mine)} evaluated; ")
        if chosen is None:
            text += "its rows wait for every row's search"
        else:
            trainings = list(study.row_trainings(task, row, chosen[row.label], plant).values())
            trained, evaluated = _counts(store, trainings)
            text += (f"configuration {chosen[row.label]} chosen; rows ({protocol.AGENTS} agents "
                     f"at {len(trainings)} fractions) {trained}/{len(trainings)} trained, "
                     f"{evaluated}/{len(trainings)} evaluated")
        lines.append(text)
    return lines


def lines(tasks, out_dir: str, plant: str = "analytic") -> list:
    """Every task's lines, then the ledger's count (`runners.store.compute_spent`)."""
    result = [line for task in tasks for line in task_lines(task, out_dir, plant)]
    spent = compute_spent(out_dir)
    result.append(f"ledger ({os.path.join(out_dir, 'compute.jsonl')}): {spent['runs']} runs, "
                  f"{spent['wall_s'] / 3600:.2f} h of wall time, {spent['cpu_s'] / 3600:.2f} h "
                  "of CPU")
    return result
