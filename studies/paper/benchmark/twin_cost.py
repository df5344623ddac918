"""What the second benchmark's deep rows would have cost on their Stable-Baselines3 twins
alone (the issue's "and what it would cost with SB3 alone"): each deep row's configuration's
CPU per agent-step on its twin, measured by `benchmarks/sb3_cost.py` into `SB3_COST`, times
the steps of that configuration's runs, against what the ledger counts of them."""

import dataclasses
import json
import os

import numpy as np

from lwrl.runners.store import RunStore, ledger_lines, ledger_runs
from lwrl.runners.sweep import given_on_the_way
from lwrl.studies.paper.benchmark import evaluation, protocol, search

SB3_COST = "sb3_cost.json"
"""Beside the runs: each deep row's configuration's CPU per agent-step on its
Stable-Baselines3 twin (`benchmarks/sb3_cost.py`), by the configuration's `key`."""


@dataclasses.dataclass(frozen=True)
class DeepConfiguration:
    """One configuration of a deep row (the search's `index`-th of the row `label` of
    `task`) and the runs of it that `runs/` holds: its trainings (the search's, and the
    row's at each fraction where the row chose it) and their greedy evaluations."""

    task: str
    label: str
    index: int
    key: str
    """The key of the search's training, which names the configuration (task, plant,
    learner, and a digest of every setting)."""
    trainings: tuple
    evaluations: tuple


def deep_configurations(out_dir: str, plant: str = "analytic", tasks=None) -> list:
    """Every configuration of a deep row (`protocol.deep`) of every benchmark task on `plant`
    (`protocol.tasks_on`; the benchmark's plant, whose deep rows may train on another,
    `protocol.row_plant`), or of those of `tasks`, of which `out_dir/runs` holds a run, its
    runs made as the study makes them (`search.runs`, `protocol.training`,
    `evaluation.evaluation`)."""
    store = RunStore(out_dir)
    found = []
    for task in (task for task in protocol.tasks_on(plant) if tasks is None or task in tasks):
        searched = search.runs(task, plant)
        for row in protocol.rows(task):
            if row.label not in protocol.deep(task):
                continue
            for index, settings in enumerate(search.configurations(task, row)):
                trainings = [searched[row.label, index]] + [
                    protocol.training(task, row, settings, 0, protocol.AGENTS, fraction, plant)
                    for fraction in protocol.FRACTIONS]
                held = tuple(config for config in trainings if store.path(config).exists())
                evaluations = tuple(config for config in map(evaluation.evaluation, held)
                                    if store.path(config).exists())
                if held:
                    found.append(DeepConfiguration(task, row.label, index, trainings[0].key,
                                                   held, evaluations))
    return found


def twin_cpu_s(config, table, measured: dict) -> float:
    """The CPU seconds the run `config` (its table of episodes) would have taken on the
    Stable-Baselines3 twin measured as `measured` (an entry of `SB3_COST`): each agent's
    first `warm_up_steps` steps at the warm-up's CPU per step and the rest at learning's,
    an evaluation's every step at the greedy steps'."""
    steps = table.groupby("seed")["steps"].sum().to_numpy()
    rate = measured["cpu_s_per_step"]
    if config.greedy:
        return float(steps.sum()) * rate["greedy"]
    warm = np.minimum(steps, measured["warm_up_steps"])
    return float(warm.sum()) * rate["warm_up"] + float((steps - warm).sum()) * rate["learning"]


def sentence(out_dir: str, tasks=None) -> str:
    """What the deep rows' runs in `out_dir/runs` (of `tasks` only, where given) would have
    cost on their Stable-Baselines3 twins (`twin_cpu_s` of every run of a configuration
    `SB3_COST` holds) against what the ledger counts of them (`ledger_cpu_s`), or the command
    that measures it."""
    path = os.path.join(out_dir, SB3_COST)
    measured = {}
    if os.path.exists(path):
        with open(path) as file:
            measured = json.load(file)
    store = RunStore(out_dir)
    found = [c for plant in sorted({entry["plant"] for entry in measured.values()})
             for c in deep_configurations(out_dir, plant, tasks)]
    if measured and not found:
        return "No deep row's run is in `runs/`."
    if not any(c.key in measured for c in found):
        return ("What the deep rows would have cost with Stable-Baselines3 alone is not "
                f"measured: `python -m benchmarks.sb3_cost {out_dir}` measures it.")
    given = on_the_way(out_dir, [config for c in found for config in c.trainings])
    twin, steps, rows = {}, {"training": 0, "greedy evaluation": 0}, {}
    for c in (c for c in found if c.key in measured):
        for config in c.trainings + c.evaluations:
            if config.key in given:
                twin[config.key] = 0.0
                continue
            table = store.read([config])
            twin[config.key] = twin_cpu_s(config, table, measured[c.key])
            steps["greedy evaluation" if config.greedy else "training"] += int(table["steps"].sum())
            rows[c.label] = rows.get(c.label, 0.0) + twin[config.key]
    deep_runs = {config.key for c in found for config in c.trainings + c.evaluations}
    spent, counted = ledger_cpu_s(out_dir, deep_runs)
    against = (f"the ledger counts {len(counted)} of their {len(deep_runs)} runs, which cost "
               f"{spent / 3600:.2f} h of CPU and would have cost about "
               f"{sum(twin.get(key, 0.0) for key in counted) / 3600:.2f} h"
               if counted else f"the ledger counts none of their {len(deep_runs)} runs")
    partial = (f" ({len([c for c in found if c.key in measured])} of the {len(found)} "
               "configurations measured: the others' runs are not counted)"
               if len(twin) < len(deep_runs) else "")
    used = [measured[c.key] for c in found if c.key in measured]
    names = ", ".join(dict.fromkeys(f"`{entry['twin']}`" for entry in used))
    commands = ", ".join(dict.fromkeys(f"`{entry['command']}`" for entry in used))
    return (f"With Stable-Baselines3 alone (the JAX learners' twins {names}, torch on one "
            f"thread) the deep rows would have cost about {sum(twin.values()) / 3600:.2f} h "
            "of CPU for their " + " and ".join(f"{n:,} agent-steps of {kind}"
                                               for kind, n in steps.items())
            + " (" + ", ".join(f"{label} {seconds / 3600:.2f} h" for label, seconds in rows.items())
            + f"){partial}; {against}." + (
                f" {len(given)} runs, given on the way by a longer run of theirs (a row's "
                "fractions of the budget, `runners.sweep.families`), count nothing more on "
                "either side." if given else "")
            + " Each configuration's twin trained one agent with its "
            "settings on its task: its CPU per step of warm-up before learning starts, of "
            "learning, and of greedy evaluation, each times the runs' steps of that kind "
            f"(`{SB3_COST}`, measured by {commands}).")


def on_the_way(out_dir: str, configs) -> set:
    """The keys of the runs of `configs` whose steps are a longer run's first
    (`runners.sweep.families`: the same settings, a larger budget, the longer run's
    checkpoints): those a ledger line names with a longer run of their family, and those no
    line names where a longer run of their family is among `configs` (written at its
    checkpoint by a process stopped before that run ended, `runners.resume`, or before the
    ledger was kept: Stable-Baselines3 keeping its checkpoints computes them on the way as
    well). A run a line names apart from its family was computed on its own, and counts on
    both sides."""
    by_key = {config.key: config for config in configs}
    lines = ledger_lines(out_dir)
    named = set(ledger_runs(lines))
    together = set().union(*(given_on_the_way([by_key[key] for key in line["runs"] if key in by_key])
                             for line in lines))
    unnamed = given_on_the_way(list(by_key.values())) - named
    return together | unnamed


def ledger_cpu_s(out_dir: str, runs: set) -> tuple:
    """`(CPU seconds, run keys)` of the lines of `out_dir`'s ledger (`RunStore.record_compute`)
    that name runs of `runs` only: the seconds of every such line, each run once
    (`ledger_runs`)."""
    mine = ledger_lines(out_dir, runs)
    return sum(line["cpu_s"] for line in mine), ledger_runs(mine)
