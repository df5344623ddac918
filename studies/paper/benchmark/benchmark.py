"""`lwrl bench run`, `lwrl bench report` and `lwrl bench score`: the second benchmark from its
runs to its report.

Layout of the output directory (every table a gzip CSV, resumable by the same command):

    runs/<key>.csv.gz            one run's per-episode table: its configuration's columns
                                 (`RunConfig.columns`: task, plant, learner and every setting,
                                 `budget` among them) and per agent and episode `seed`,
                                 `episode`, `steps`, `return`, `uptime_s` (s), `truncated`,
                                 `diverged`; a training's episodes as far as its budget, an
                                 evaluation's (`trained`, `greedy`) its greedy episodes
    runs/records/<key>.csv.gz    per agent, what its run cost and where it ran
                                 (`runners.records`): its share of its batch's CPU seconds,
                                 at each budget of a family the CPU up to it, its counted
                                 arithmetic, lwrl's version and commit, the CPU, Python's and
                                 the libraries' versions (the second benchmark's runs were
                                 written before runs recorded them: not recorded)
    runs/<key>.agents.npz        a training's agents until its evaluation is written (not kept
                                 in git: the tables alone resume the study)
    references/<task>-<plant>.csv.gz
                                 the random and classical rows' greedy episodes (`row`)
    outside/<learner>-<task>.csv.gz
                                 an outside learner's results (`lwrl bench score`,
                                 `outside`'s schema), in the report's leaderboard
    costs.json                   CPU per learning step of each row (`timed_costs`)
    compute.jsonl                what each computed batch of runs cost (wall and CPU seconds,
                                 host, CPU: `runners.store`), a line each, kept across
                                 interruptions: the report's cost line
    configs.jsonl                every run's full configuration, a line each (where it ran: its
                                 records)
    figures/                     the aggregates, the profiles, each task's curves and the
                                 pendulum's training curves with both kinds of action
    README.md                    the report, the command at its top

The report covers every task the directory holds (`study.held`), whichever tasks the call
ran: a task whose runs are not all written is named in it as such and not judged.
`lwrl bench report DIR` writes it from the directory alone, computing nothing.
A directory that holds `configs.jsonl` and a task's reference rows is a benchmark directory
(`check_benchmark`): what `lwrl bench run` writes.
"""

import glob
import json
import os
import time

from lwrl import outputs
from lwrl.analysis.statistics import mean_interval
from lwrl.runners.sweep import config_line
from lwrl.studies.paper.benchmark import outside, protocol, report, study, timed_costs

OUTSIDE = "outside"
FIGURES = "figures"
CONFIGS = "configs.jsonl"
COSTS = "costs.json"


def benchmark(tasks, out_dir: str, command: str, plant: str = "analytic", sweep=None,
              with_report: bool = True) -> str | None:
    """Run (or resume) the benchmark on `tasks`, measure their rows' costs, then, where
    `with_report`, write the report of every task `out_dir` holds (`write_report`); its
    path, or None where no report was asked for (`rebuild` writes it later)."""
    started = time.perf_counter()
    tasks = [protocol.check_task(task, plant) for task in tasks]
    computed = [study.study_task(task, out_dir, plant, sweep) for task in tasks]
    timed_costs.measure_all(cost_cells(computed), out_dir)
    return write_report(out_dir, command, plant, started, computed) if with_report else None


def rebuild(out_dir: str, command: str, plant: str = "analytic") -> str:
    """The report of what the benchmark directory `out_dir` holds, computing nothing
    (`lwrl bench report`); its path."""
    started = time.perf_counter()
    check_benchmark(out_dir, plant)
    return write_report(out_dir, command, plant, started)


def write_report(out_dir: str, command: str, plant: str, started: float, computed=()) -> str:
    """Write `configs.jsonl` and the report (README.md, its figures) of every task `out_dir`
    holds on `plant`: those of `computed` (`study.TaskRuns`) as they are, the others read
    (`study.read_task`), with the outside rows and the costs `costs.json` holds; a task whose
    runs are not all written is named as such. `started`: the call's `time.perf_counter()`,
    whose wall time the report states. A one-line ValueError where no task has all its
    runs."""
    task_runs, unfinished = held_runs(out_dir, plant, computed)
    if not task_runs:
        raise ValueError(f"{out_dir}: no task has all its runs on the {plant} plant "
                         f"({'; '.join(unfinished.values())}); `lwrl bench status all --out "
                         f"{out_dir}` says what is left")
    rows = outside_rows(out_dir, plant)
    for runs in task_runs:
        for table in rows.get(runs.task, ()):
            runs.outside.update(outside.scores(table, runs.references))
    write_held_configs(out_dir, task_runs, unfinished, plant)
    judged = report.judge(task_runs, measured_cpu(out_dir, cost_cells(task_runs)))
    path = os.path.join(out_dir, "README.md")
    with outputs.atomic_write(path) as file:
        file.write(report.document(judged, command, started, os.path.join(out_dir, FIGURES),
                                   out_dir, list(unfinished.values())))
    return path


def held_runs(out_dir: str, plant: str, computed=()) -> tuple:
    """`([TaskRuns of each task out_dir holds with all its runs], {task: why not} of the
    others)`, in the protocol's order: `computed`'s as they are, the others read."""
    given = {runs.task: runs for runs in computed}
    task_runs, unfinished = [], {}
    for task in study.held(out_dir, plant):
        try:
            task_runs.append(given[task] if task in given else study.read_task(task, out_dir, plant))
        except study.Unfinished as missing:
            unfinished[task] = str(missing)
    return task_runs, unfinished


def write_held_configs(out_dir: str, task_runs, unfinished, plant: str) -> None:
    """`configs.jsonl`: the rows' trainings of each task of `task_runs`, and the lines it held
    of the tasks `unfinished`, kept as they were, in the protocol's order."""
    path = os.path.join(out_dir, CONFIGS)
    kept = {}
    if os.path.isfile(path):
        with open(path) as file:
            for line in file:
                kept.setdefault(line_task(json.loads(line)), []).append(line)
    lines = {runs.task: [config_line(config) for config in runs.trainings.values()]
             for runs in task_runs}
    lines.update({task: kept.get(task, []) for task in unfinished})
    with outputs.atomic_write(path) as file:
        file.writelines(line for task in protocol.tasks_on(plant) for line in lines.get(task, ()))


def line_task(line: dict) -> str:
    """The benchmark task of a line of `configs.jsonl`: its task, made with its kind of action
    (`protocol.variant`)."""
    return line["task"] + (protocol.CONTINUOUS if line.get("actions") == "continuous" else "")


def cost_cells(task_runs) -> list:
    """`(task, label, RunConfig)` of each row's full-budget training: the runs whose costs
    `timed_costs` measures."""
    return [(runs.task, label, config) for runs in task_runs
            for (label, fraction), config in runs.trainings.items() if fraction == 1.0]


def measured_cpu(out_dir: str, cells) -> dict:
    """`{(task, label): CPU seconds per learning step}` of the `cells` (`cost_cells`) whose
    costs `out_dir/costs.json` holds."""
    path = os.path.join(out_dir, COSTS)
    costs = {}
    if os.path.isfile(path):
        with open(path) as file:
            costs = json.load(file)
    return {(task, label): costs[config.key]["cpu_s_per_learning_step"]
            for task, label, config in cells if config.key in costs}


def check_benchmark(out_dir: str, plant: str) -> None:
    """A one-line ValueError unless `out_dir` is a benchmark directory on `plant` (see the
    module)."""
    if not (os.path.isfile(os.path.join(out_dir, CONFIGS)) and study.held(out_dir, plant)):
        raise ValueError(f"{out_dir} is no benchmark directory on the {plant} plant: one holds "
                         f"{CONFIGS} and a task's reference rows "
                         f"({study.REFERENCES}/TASK-{plant}.csv.gz), as `lwrl bench run "
                         f"TASK... --out DIR` writes them")


def outside_path(out_dir: str, learner: str, task: str) -> str:
    """Where `out_dir` keeps the outside learner `learner`'s results on `task`."""
    return os.path.join(out_dir, OUTSIDE, f"{learner}-{task}.csv.gz")


def outside_rows(out_dir: str, plant: str) -> dict:
    """`{task: [checked results table, ...]}` of the outside rows `out_dir` keeps."""
    rows = {}
    for path in sorted(glob.glob(os.path.join(out_dir, OUTSIDE, "*.csv.gz"))):
        table = outside.read(path, plant)
        rows.setdefault(str(table["task"].iloc[0]), []).append(table)
    return rows


def score(paths, out_dir: str, plant: str = "analytic", replace: bool = False) -> list:
    """Check each outside results file (`outside`) against the protocol on `plant`, keep it in
    the benchmark directory `out_dir` for its report, and return one line per file and
    fraction: its normalised scores between the task's reference rows. Every file is checked
    before any is kept: a one-line ValueError, and nothing written, where one is refused
    (`check_benchmark`, `outside.check`, a task the benchmark does not hold, a learner
    already scored on its task without `replace`, two files of one learner and task)."""
    check_benchmark(out_dir, plant)
    held = study.held(out_dir, plant)
    targets = {}
    for path in paths:
        table = outside.read(path, plant)
        task, learner = str(table["task"].iloc[0]), str(table["learner"].iloc[0])
        if task not in held:
            raise ValueError(f"{path}: the benchmark in {out_dir} holds no runs of {task} on the "
                             f"{plant} plant; it holds {', '.join(held)}")
        target = outside_path(out_dir, learner, task)
        if target in targets:
            raise ValueError(f"{path}: {learner} on {task} is in another of the files too; "
                             "one file per learner and task")
        if os.path.exists(target) and not replace:
            raise ValueError(f"{path}: {learner} is already scored on {task} ({target}); "
                             "--replace replaces it, or name the learner otherwise")
        references = study.references(task, out_dir, plant)  # held: read, not run
        targets[target] = (table, [
            f"{name} on {task} after {fraction:g} of the budget: normalised score "
            f"{mean_interval(values).text(2)}"
            for (name, fraction), values in outside.scores(table, references).items()])
    for target, (table, _) in targets.items():
        os.makedirs(os.path.dirname(target), exist_ok=True)
        outputs.write_table(table, target)
    return [line for _, lines in targets.values() for line in lines]
