"""`lwrl bench run` and `lwrl bench score`: the second benchmark from its runs to its report.

Layout of the output directory (every table a gzip CSV, resumable by the same command):

    runs/<key>.csv.gz            one run's per-episode table: its configuration's columns
                                 (`RunConfig.columns`: task, plant, learner and every setting,
                                 `budget` among them) and per agent and episode `seed`,
                                 `episode`, `steps`, `return`, `uptime_s` (s), `truncated`,
                                 `diverged`; a training's episodes as far as its budget, an
                                 evaluation's (`trained`, `greedy`) its greedy episodes
    runs/<key>.agents.npz        a training's agents until its evaluation is written (not kept
                                 in git: the tables alone resume the study)
    references/<task>-<plant>.csv.gz
                                 the random and classical rows' greedy episodes (`row`)
    outside/<learner>-<task>.csv.gz
                                 an outside learner's results (`lwrl bench score`,
                                 `outside`'s schema), placed in the tables
    costs.json                   CPU per learning step of each row (studies/paper/bench_costs.py)
    timings.json                 the wall time of every call that finished
    compute.jsonl                what each computed batch of runs cost (wall and CPU seconds,
                                 host, CPU: `runners.store`), a line each, kept across
                                 interruptions: the report's cost line
    configs.jsonl                every run's full configuration (lwrl's version in `learner`'s
                                 settings, the host in timings)
    figures/                     the aggregates, the profiles, each task's curves and the
                                 pendulum's training curves with both kinds of action
    README.md                    the report, the command at its top
"""

import glob
import os
import time

from lwrl import outputs
from lwrl.analysis.statistics import mean_interval
from lwrl.runners.sweep import write_configs
from lwrl.studies.paper import bench_costs
from lwrl.studies.paper.bench import timed_calls
from lwrl.studies.paper.benchmark import outside, protocol, report, study

OUTSIDE = "outside"
FIGURES = "figures"


def benchmark(tasks, out_dir: str, command: str, plant: str = "analytic", sweep=None) -> str:
    """Run (or resume) the benchmark on `tasks`, measure the rows' costs, place the outside
    results of `out_dir/outside`, write the report; its path."""
    started = time.perf_counter()
    tasks = [protocol.check_task(task, plant) for task in tasks]
    task_runs = []
    for task in tasks:
        runs = study.study_task(task, out_dir, plant, sweep)
        for path in sorted(glob.glob(os.path.join(out_dir, OUTSIDE, f"*-{task}.csv.gz"))):
            runs.scores.update(outside.scores(outside.read(path), runs.references))
        task_runs.append(runs)
    configs = [config for runs in task_runs for config in runs.trainings.values()]
    write_configs(configs, os.path.join(out_dir, "configs.jsonl"))
    cells = [(runs.task, label, config) for runs in task_runs
             for (label, fraction), config in runs.trainings.items() if fraction == 1.0]
    costs = bench_costs.measure_all(cells, out_dir)
    cpu = {(costs[config.key]["task"], costs[config.key]["label"]):
           costs[config.key]["cpu_s_per_learning_step"] for _, _, config in cells}
    judged = report.judge(task_runs, cpu)
    figure_dir = os.path.join(out_dir, FIGURES)
    seconds = timed_calls(out_dir, time.perf_counter() - started)
    path = os.path.join(out_dir, "README.md")
    with outputs.atomic_write(path) as file:
        file.write(report.document(judged, command, seconds, figure_dir, out_dir))
    return path


def score(paths, out_dir: str, plant: str = "analytic") -> list:
    """Check each outside results file (`outside`), keep it in `out_dir/outside` for the
    report, and return one line per file and fraction: its normalised scores between the
    task's reference rows (run once into `out_dir/references`)."""
    tables = [(path, outside.read(path)) for path in paths]  # every file checked first
    lines = []
    for path, table in tables:
        task, learner = str(table["task"].iloc[0]), str(table["learner"].iloc[0])
        target = os.path.join(out_dir, OUTSIDE, f"{learner}-{task}.csv.gz")
        os.makedirs(os.path.dirname(target), exist_ok=True)
        outputs.write_table(table, target)
        for (name, fraction), values in outside.scores(table, study.references(task, out_dir, plant)).items():
            lines.append(f"{name} on {task} after {fraction:g} of the budget: normalised score "
                         f"{mean_interval(values).text(2)}")
    return lines
