"""`lwrl implementations`: the runs, through the sweep runner into `OUT/runs/` (resumable:
a second call computes only what the first did not finish), then the report.

Each agent is a run of its own (`plan.Cell.configs`), so an interrupted call loses at most
the agents being computed, and a call with more agents keeps the fewer's. The order:

1. the costs (`costs`, kept in `costs.json`), minutes;
2. one call of the sweep per seed (`rounds`), its batches the longest first (by the costs),
   so that a backend that runs batches in parallel (Ray) keeps its workers busy: the first
   call holds every population (a population learner's runs of one task differ in their
   seeds only, so the sweep joins them into one population, trained as one program) and
   the reference learners' agents of seed 0, each a batch of its own; each later call the
   reference learners' agents of its seed. The reference learners' agents take most of
   the study's time.
"""

import json
import os
import sys
import time

import numpy as np

from lwrl import outputs
from lwrl import tasks
from lwrl.runners import sweep
from lwrl.runners.store import RunStore
from lwrl.studies.implementations import costs as costs_module
from lwrl.studies.implementations import plan, report


def log(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def load_timings(out_dir: str) -> dict:
    path = os.path.join(out_dir, "timings.json")
    timings = {}
    if os.path.isfile(path):
        try:
            with open(path) as file:
                timings = json.load(file)
        except (OSError, ValueError):
            timings = {}
    timings.setdefault("calls", [])
    timings.setdefault("rounds", [])
    return timings


def save_timings(out_dir: str, timings: dict) -> None:
    with outputs.atomic_write(os.path.join(out_dir, "timings.json")) as file:
        json.dump(timings, file, indent=1)


def all_configs(cells) -> list:
    return [config for cell in cells for name in cell.pair.names for config in cell.configs(name)]


def expected_steps(cell, name: str, store: RunStore) -> float:
    """The agent-steps one agent of `name` is expected to take on `cell`: the mean of its
    finished agents, else the protocol's most (every episode to its time limit)."""
    finished = [config for config in cell.configs(name) if store.finished(config)]
    if finished:
        return float(np.mean([np.nansum(store.read([config])["steps"]) for config in finished]))
    definition = tasks.definition(*tasks.split_name(cell.task), **cell.task_options)
    limit = definition.step_limit if np.isfinite(definition.step_limit) else 10_000
    return float(cell.episodes * limit)


def expected_seconds(cell, name: str, store: RunStore, costs: dict, agents: int = 1) -> float:
    """CPU seconds a batch of `agents` agents of `name` on `cell` is expected to take."""
    cost = costs.get(cell.key, {}).get(name, {})
    return (cost.get("cpu_us_per_agent_step") or 1.0) * expected_steps(cell, name, store) * agents


def rounds(cells, store: RunStore, costs: dict) -> list:
    """The calls of the sweep, each a list of runs, the longest batch first: the first
    holds every population (each task and pair one batch: its runs differ in their seeds
    only) and the reference learners' runs of the first seed; then one call per seed."""
    result = []
    for seed in range(cells[0].agents):
        batches = []
        if seed == 0:
            for cell in cells:
                configs = [c for c in cell.configs(cell.pair.twin) if not store.finished(c)]
                if configs:
                    batches.append((expected_seconds(cell, cell.pair.twin, store, costs,
                                                     cell.agents), configs))
        for cell in cells:
            config = cell.config(cell.pair.reference, seed)
            if not store.finished(config):
                batches.append((expected_seconds(cell, cell.pair.reference, store, costs), [config]))
        if batches:
            batches.sort(key=lambda batch: -batch[0])
            result.append((seed, [config for _, configs in batches for config in configs]))
    return result


def run_all(cells, out_dir: str, options: dict, costs: dict, timings: dict) -> int:
    """Run what is missing (see the module); return how many runs this call computed."""
    store = RunStore(out_dir)
    computed, total = 0, len(all_configs(cells))
    for seed, configs in rounds(cells, store, costs):
        names = dict.fromkeys(f"{config.learner} on {config.task}" for config in configs)
        log(f"seed {seed}: {len(configs)} runs: {', '.join(names)}")
        wall = time.perf_counter()
        _, count = sweep.run_sweep(configs, out_dir, description=f"seed {seed}", **options)
        wall = time.perf_counter() - wall
        computed += count
        timings["rounds"].append({"seed": seed, "runs": count, "wall_s": wall,
                                  "backend": options["backend"],
                                  "finished": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())})
        save_timings(out_dir, timings)
        done = sum(map(store.finished, all_configs(cells)))
        log(f"seed {seed}: {count} runs computed in {wall / 60:.1f} min; {done} of {total} "
            "runs finished")
    return computed


def finished_results(cells, out_dir: str):
    """The results of every finished run of the cells, and how many there are."""
    store = RunStore(out_dir)
    finished = [config for config in all_configs(cells) if store.finished(config)]
    if not finished:
        raise ValueError(f"no finished run in {out_dir}")
    return store.read(finished), len(finished)


def notes(out_dir: str) -> str:
    path = os.path.join(out_dir, "notes.md")
    if not os.path.isfile(path):
        return ""
    with open(path, encoding="utf-8") as file:
        text = file.read()
    # the notes' own title gives way to the report's section heading
    lines = text.strip().splitlines()
    return "\n".join(lines[1:] if lines and lines[0].startswith("# ") else lines)


def write_report(cells, out_dir: str, command: str, seconds: float, total_seconds: float,
                 computed: int, costs: dict | None = None, timings: dict | None = None) -> str:
    """The report from the runs finished so far (all, after `implementations`)."""
    results, finished = finished_results(cells, out_dir)
    costs = costs_module.load(out_dir) if costs is None else costs
    timings = load_timings(out_dir) if timings is None else timings
    initialisations = {cell.key: plan.initialisation(cell) for cell in cells}
    return report.write(cells, results, costs, timings, initialisations, out_dir, command=command,
                        seconds=seconds, total_seconds=total_seconds, computed=computed,
                        runs=len(all_configs(cells)), finished=finished, notes=notes(out_dir))


def implementations(task_names, out_dir: str, agents: int = 10, budgets=None, episodes=None,
                    timesteps=None, time_limit=None, backend: str = "local", workers=None,
                    address=None, command: str = "", actions: str = "discrete") -> str:
    """Run (or resume) the study and write its report; return the report's path.

    `budgets`: `{task: (episodes, task options)}`, each task's protocol by default (the
    task's own episodes where it has none); `episodes`, `timesteps` and `time_limit`
    replace every task's episodes, both learners' horizon and the episodes' time limit
    (smoke tests); `actions`: the pairs' kind of action (`plan.pairs`), the tasks made with
    it."""
    started = time.perf_counter()
    cells = plan.cells(task_names, agents, budgets, episodes, timesteps, time_limit,
                       actions=actions)
    if backend not in sweep.BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; allowed: {', '.join(sweep.BACKENDS)}")
    os.makedirs(out_dir, exist_ok=True)
    sweep.write_configs(all_configs(cells), os.path.join(out_dir, "configs.jsonl"))
    costs = costs_module.measure_all(cells, out_dir, log)
    timings = load_timings(out_dir)
    computed = run_all(cells, out_dir, dict(backend=backend, workers=workers, address=address),
                       costs, timings)
    seconds = time.perf_counter() - started
    timings["calls"].append(seconds)
    save_timings(out_dir, timings)
    return write_report(cells, out_dir, command, seconds, sum(timings["calls"]), computed,
                        costs, timings)
