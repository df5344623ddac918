"""What each implementation costs per agent-step, measured on this machine.

Each implementation of a cell runs the cell's own configuration for `COST_EPISODES`
episodes or more of `timed_steps` steps at most together: its warm-up (`learning_starts`)
then `COST_STEPS`, so that a learner waiting 10 000 steps before its first update, as TD3
does, is timed learning as well as filling its buffer, in about the proportion of the
study's runs. It runs in this process, timed by the wall clock
and by the CPU time of the process (all its threads: XLA's among them): the reference
learner one agent (its agents are independent models, one after the other, so a batch costs
the sum of its agents), the population learner the study's whole population (it trains as
one program, all agents at once). A population learner runs twice, the second call timed:
the first compiles its program (or loads it from JAX's disk cache), which the report states
apart; a reference learner first runs a few steps (`warm_up`: PyTorch and
Stable-Baselines3 imported). The costs are kept in `costs.json` and not measured again; the
study's runs themselves may run on Ray, whose workers' CPU time this process does not see,
so the report multiplies these costs by the agent-steps the study's agents took.
"""

import dataclasses
import json
import os
import platform
import sys
import time

import numpy as np

from lwrl import agent as learners
from lwrl import outputs, tasks

COST_STEPS = 8192
"""Steps of the timed episodes at most after the learner's warm-up (two of the longest tuned
rollouts)."""
COST_EPISODES = 4
"""Timed episodes at least, each of a quarter of the timed steps at most: an agent whose
first episode ends early at a goal is still timed over several."""
WARM_UP_STEPS = 16
"""Steps of the run before a reference learner is timed (its libraries imported)."""


def timed_steps(config) -> int:
    """Steps timed of `config`: its learner's warm-up (`learning_starts`, 0 where it has none)
    then `COST_STEPS`."""
    return getattr(config.settings, "learning_starts", 0) + COST_STEPS


def cost_config(cell, name: str):
    """The timed run of learner `name` of `cell`: `timed_steps` steps of the cell's task in
    `COST_EPISODES` episodes or more (as many as its episodes, capped at a share of the
    steps, take), one agent (the reference) or the cell's population (the twin)."""
    definition = tasks.definition(*tasks.split_name(cell.task), **cell.task_options)
    options = dict(cell.task_options)
    agents = cell.agents if learners.learner(name).population else 1
    steps = timed_steps(cell.config(name, 0, agents=agents))
    cap = steps // COST_EPISODES
    if definition.step_limit > cap:
        options["time_limit"] = cap * definition.control_timestep
    episodes = -(-steps // min(cap, definition.step_limit))
    return cell.config(name, 0, agents=agents, episodes=episodes, task_options=options)


def _timed(config) -> tuple:
    """`(wall s, CPU s, agent-steps)` of one run of `config` in this process."""
    from lwrl.runners.run import run
    wall, cpu = time.perf_counter(), time.process_time()
    _, results = run(config)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    if results.interrupted:
        raise KeyboardInterrupt
    return wall, cpu, float(np.nansum(results.steps))


def warm_up(config):
    """`config` cut to one episode of `WARM_UP_STEPS` steps at most: a run that imports and
    sets up what a reference learner needs (PyTorch, Stable-Baselines3) before it is timed."""
    definition = tasks.definition(*tasks.split_name(config.task), **config.task_options)
    if definition.step_limit <= WARM_UP_STEPS:
        return config
    options = dict(config.task_options, time_limit=WARM_UP_STEPS * definition.control_timestep)
    return dataclasses.replace(config, task_options=options)


def measure(config) -> dict:
    """The costs of one implementation (see the module)."""
    population = learners.learner(config.learner).population
    first = _timed(config if population else warm_up(config))
    wall, cpu, steps = _timed(config)
    return {"learner": config.learner, "task": config.task, "agents": config.agents,
            "agent_steps": steps, "wall_s": wall, "cpu_s": cpu,
            "wall_us_per_agent_step": 1e6 * wall / steps if steps else None,
            "cpu_us_per_agent_step": 1e6 * cpu / steps if steps else None,
            "first_call_wall_s": first[0],
            "compile_wall_s": max(first[0] - wall, 0.0) if population else None,
            "host": platform.node(), "cores": os.cpu_count(),
            "measured": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}


def load(out_dir: str) -> dict:
    path = os.path.join(out_dir, "costs.json")
    if not os.path.isfile(path):
        return {}
    try:
        with open(path) as file:
            return json.load(file)
    except (OSError, ValueError):
        return {}  # measured again


def measure_all(cells, out_dir: str, log=None) -> dict:
    """`{cell key: {learner: costs}}` of every cell, measuring what `costs.json` lacks
    and writing it after each measurement (an interrupted call keeps what it measured)."""
    log = log or (lambda line: print(line, file=sys.stderr, flush=True))
    costs = load(out_dir)
    for cell in cells:
        for name in cell.pair.names:
            config = cost_config(cell, name)
            kept = costs.get(cell.key, {}).get(name)
            if kept is not None and kept.get("config") == config.key:
                continue
            definition = tasks.definition(*tasks.split_name(config.task), **config.task_options)
            log(f"measuring the cost of {name} on {cell.task} ({config.agents} agent(s), "
                f"{config.episodes} episodes of at most {definition.step_limit} steps)")
            costs.setdefault(cell.key, {})[name] = {**measure(config), "config": config.key}
            with outputs.atomic_write(os.path.join(out_dir, "costs.json")) as file:
                json.dump(costs, file, indent=1)
    return costs
