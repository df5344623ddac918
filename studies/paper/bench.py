"""`lwrl bench`: every learner of the registry under one protocol (`bench_protocol`), the
baselines' search (`bench_search`), its costs (`bench_costs`) and the report
(`bench_report`), for the light-weight claim of docs/FINDINGS.md. The rows that are not
searched run first (seconds), then the search, then the searched rows with their chosen
settings.

Layout of the output directory:

    runs/<key>.csv.gz     one finished run (the sweep's store: resumable, claimed in batches)
    results.csv.gz        every run's tidy table, with a `label` column naming the learner row
    configs.jsonl         every run's full configuration (the rows', then the search's)
    costs.json            the cost measurements per (task, learner) (kept: not measured again)
    timings.json          the wall time of each call that finished
    controllers/          the exported C controllers and their instruction counts
    figures/              learning curves and Pareto figures per task
    README.md             the report
"""

import dataclasses
import json
import os
import time

from lwrl import outputs
from lwrl.runners import sweep
from lwrl.studies.paper import bench_protocol as protocol
from lwrl.studies.paper import bench_search as search


def ordered(cells) -> list:
    """The cells, lwrl's learners on every task before the baselines, task by task."""
    return sorted(cells, key=lambda cell: (cell[1] in search.SEARCHED, cell[1] in search.SEARCHED
                                           and list(protocol.TASKS).index(cell[0])))


def bench(tasks, labels, out_dir: str, plant: str = "analytic", agents: int = 5,
          quick: bool = False, backend: str = "local", workers=None, address=None,
          command: str = "") -> str:
    """Run (or resume) the benchmark's runs, measure the costs, write the report; return
    the report's path."""
    started = time.perf_counter()
    tasks = protocol.check_tasks(tasks)
    labels = protocol.check_learners(labels, tasks)
    cells = ordered(protocol.configs(tasks, labels, plant, agents, quick))
    os.makedirs(out_dir, exist_ok=True)
    options = dict(backend=backend, workers=workers, address=address)
    unsearched = [config for _, label, config in cells if label not in search.SEARCHED]
    _, computed = (sweep.run_sweep(unsearched, out_dir, description="bench", **options)
                   if unsearched else (None, 0))
    found = search.candidates(cells)
    tried = [config for configs in found.values() for config in configs]
    searched, more = (sweep.run_sweep(tried, out_dir, description="bench: search", **options)
                      if tried else (None, 0))
    chosen = search.choose(found, searched)
    cells = [(task, label, dataclasses.replace(chosen[task, label], agents=config.agents, seed=config.seed)
              if (task, label) in chosen else config) for task, label, config in cells]
    configs = [config for _, _, config in cells]
    sweep.write_configs(configs + tried, os.path.join(out_dir, "configs.jsonl"))
    results, rows = sweep.run_sweep(configs, out_dir, description="bench", **options)
    computed += more + rows
    label_of = {config.key: label for _, label, config in cells}
    results.insert(1, "label", results["run"].map(label_of))
    outputs.write_table(results, os.path.join(out_dir, "results.csv.gz"))
    from lwrl.studies.paper import bench_costs, bench_report
    costs = bench_costs.measure_all(cells, out_dir, quick=quick)
    seconds = time.perf_counter() - started
    return bench_report.write(cells, results, costs, out_dir, command=command, seconds=seconds,
                              total_seconds=timed_calls(out_dir, seconds), computed=computed,
                              search=(found, chosen, searched))


def timed_calls(out_dir: str, seconds: float) -> float:
    """The wall time of every call that got this far in `out_dir` (`timings.json`), this
    one's `seconds` added; an interrupted call's time is lost with it."""
    path = os.path.join(out_dir, "timings.json")
    calls = []
    if os.path.isfile(path):
        with open(path) as file:
            calls = json.load(file)
    calls.append(seconds)
    with outputs.atomic_write(path) as file:
        json.dump(calls, file)
    return sum(calls)
