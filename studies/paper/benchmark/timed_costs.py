"""What each row of the second benchmark costs (`costs.json`, the report's CPU per learning
step), timed apart from its runs, the same way for all, one process per (task, row) (a fresh
process, so its peak memory is the learner's):

- CPU time per learning step: one agent learning on the task, one thread, each learner's own
  fast path (`runners.run.run`: the compiled loop for lwrl's learners, the stepped loop with
  torch for SB3's, the jitted JAX program for the population learners), agent and plant
  together, `time.process_time` over a step budget after a warm-up (compilation, imports)
  on another agent. The budget covers the start of learning (DQN's `learning_starts` plus
  2000 steps, two of PPO's rollouts, at least 3000 steps; 20 000 for lwrl's learners); a
  population learner's is one call of 20 episodes (`_learn`).
- CPU time per greedy decision: `Agents.step` of that agent with `learn=False, greedy=True`,
  one state at a time, over 2000 states drawn in the task's ranges.
- Parameters in bytes: what the learner learns (`arrays.weights` of one agent, float64 for
  lwrl's learners, float32 for SB3's networks); the learner's own estimate of one agent's
  memory (`Learner.memory`: buffers, target network and optimiser moments included).
- Peak resident memory of the process (`getrusage`; Python, NumPy, torch and numba's
  compiler, which loads lwrl's kernels, included: the process's, not the learner's alone).
- For the paper's agent, DQN and PPO where their agents have one (`Agents.controller`; the
  JAX populations have none: `c_controller` says so): the greedy controller exported as C99
  (`lwrl.export.c`), its code and data bytes at `-Os`, and instructions per decision counted
  by `valgrind --tool=callgrind` over 1000 decisions (`-O2`; counts do not depend on the
  machine's load).
"""

import dataclasses
import json
import multiprocessing
import os
import re
import resource
import shutil
import subprocess
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool

import numpy as np

from lwrl import outputs

DECISIONS = 2000
CALLGRIND_DECISIONS = 1000
EPISODES_PER_CALL = 20
EXPORTED = ("paper", "dqn", "ppo")
"""Rows whose controller is exported and counted."""

_HARNESS = r"""
#include <stdio.h>
#include "lwrl_policy.h"
#define COUNT %d
int main(void)
{
    const double low[LWRL_STATE_DIM] = {LWRL_LOW}, high[LWRL_STATE_DIM] = {LWRL_HIGH};
    unsigned long long x = 88172645463325252ULL;
    lwrl_real state[LWRL_STATE_DIM];
    long i, checksum = 0;
    int j;
    for (i = 0; i < COUNT; i++) {
        for (j = 0; j < LWRL_STATE_DIM; j++) {
            x ^= x << 13; x ^= x >> 7; x ^= x << 17;
            state[j] = (lwrl_real)(low[j] + (high[j] - low[j]) * ((double)(x >> 11) / 9007199254740992.0));
        }
        checksum += lwrl_act(state);
    }
    printf("%%ld\n", checksum);
    return 0;
}
"""


def step_budget(config) -> int:
    """Learning steps to time: past the start of learning (see the module)."""
    settings = config.settings
    if not hasattr(settings, "timesteps"):
        return 20_000
    return max(3000, getattr(settings, "learning_starts", 0) + 2000, 2 * getattr(settings, "n_steps", 0))


def _learn(config, agent, steps: int) -> int:
    """Run `agent` for about `steps` steps of learning, `EPISODES_PER_CALL` episodes a call
    (each at most the steps left), so that a call's setup is spread over many steps; the
    steps it took. A population learner runs one call of `EPISODES_PER_CALL` episodes of
    the task's own length whatever `steps`: its program is compiled for the episodes' shape,
    so the warm-up's call, of the same shape, leaves the timed one nothing to compile."""
    from lwrl import tasks
    from lwrl.runners.run import run
    if agent.learner.population:
        _, results = run(dataclasses.replace(config, episodes=EPISODES_PER_CALL), agents=agent)
        return int(np.nansum(results.steps))
    definition = tasks.definition(*tasks.split_name(config.task))
    taken = 0
    limit = config.task_options.get("time_limit", definition.step_limit * definition.control_timestep)
    while taken < steps:
        left = (steps - taken) * definition.control_timestep
        episode = dataclasses.replace(config, episodes=EPISODES_PER_CALL, task_options={
            **config.task_options, "time_limit": min(limit, max(left, definition.control_timestep))})
        _, results = run(episode, agents=agent)
        taken += int(np.nansum(results.steps))
    return taken


def _greedy_decisions(agents, config) -> float:
    """CPU seconds per greedy decision (`Agents.step`, learn=False, greedy=True)."""
    low, high = np.asarray(config.task_spec.ranges.low), np.asarray(config.task_spec.ranges.high)
    states = low + (high - low) * np.random.default_rng(1).uniform(size=(DECISIONS, len(low)))
    zero, one = np.zeros(1), np.ones(1)
    agents.step(np.ones(1, dtype=bool), zero, one, states[:1], learn=False, greedy=True)
    not_first = np.zeros(1, dtype=bool)
    start = time.process_time()
    for state in states:
        agents.step(not_first, zero, one, state[None], learn=False, greedy=True)
    return (time.process_time() - start) / DECISIONS


def callgrind_instructions(c_dir: str, count: int = CALLGRIND_DECISIONS) -> float | None:
    """Instructions per `lwrl_act` call of the C files in `c_dir` (callgrind, `-O2`), or None
    where valgrind is not installed."""
    if shutil.which("valgrind") is None:
        return None
    from lwrl.export.c import find_compiler
    compiler = find_compiler()
    with tempfile.TemporaryDirectory() as build:
        with open(os.path.join(build, "main.c"), "w") as file:
            file.write(_HARNESS % count)
        subprocess.run([compiler, "-O2", "-std=c99", "-I", os.path.abspath(c_dir), "main.c",
                        os.path.join(os.path.abspath(c_dir), "lwrl_policy.c"), "-o", "act", "-lm"],
                       cwd=build, check=True, capture_output=True)
        out = os.path.join(build, "callgrind.out")
        subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                        "--toggle-collect=lwrl_act", "./act"], cwd=build, check=True,
                       capture_output=True)
        with open(out) as file:
            totals = re.search(r"^(?:summary|totals):\s+(\d+)", file.read(), re.M)
    return int(totals.group(1)) / count


def _controller(agents, config, c_dir: str) -> dict:
    """Export agent 0's greedy controller as C, from the agent saved beside it
    (`c_dir/agent.npz`, which the C file's header names); its sizes and instructions per
    decision."""
    from lwrl.agent import io as agent_io
    from lwrl.export.c import export_c, measure
    path = os.path.join(c_dir, "agent.npz")
    os.makedirs(c_dir, exist_ok=True)
    agent_io.save(path, agents, {"config": {"task": config.task}})
    written = export_c(path, c_dir)
    sizes = measure(c_dir)
    return {"c_weight_bytes": written["weight_bytes"], "c_code_bytes": sizes["code_bytes"],
            "c_rodata_bytes": sizes["rodata_bytes"], "c_ns_per_decision": sizes["ns_per_decision"],
            "c_instructions_per_decision": callgrind_instructions(c_dir), "compiler": sizes["compiler"]}


def measure_cell(config, label: str, c_dir: str | None) -> dict:
    """The costs of one (task, learner) (see the module); runs in a process of its own."""
    from lwrl.agent import threads
    from lwrl.runners.run import make_agents
    threads.set_workers(1)
    try:
        import torch
        torch.set_num_threads(1)
    except ImportError:
        pass
    one = dataclasses.replace(config, agents=1, seed=1000)
    _learn(dataclasses.replace(one, seed=2000), make_agents(dataclasses.replace(one, seed=2000)), 50)  # warm-up
    agent = make_agents(one)
    steps = step_budget(config)
    start = time.process_time()
    taken = _learn(one, agent, steps)
    seconds = time.process_time() - start
    costs = {"learning_steps_timed": taken, "cpu_s_per_learning_step": seconds / taken,
             "cpu_s_per_greedy_decision": _greedy_decisions(agent, one),
             "parameter_bytes": int(agent.arrays.weights[0].nbytes),
             "memory_bytes": int(agent.learner.memory(one.settings, one.task_spec))}
    if c_dir is not None:
        try:
            agent.controller(0)
        except ValueError as reason:  # a row on an implementation without one (dqn_jax)
            costs["c_controller"] = f"none: {reason}"
        else:
            costs.update(_controller(agent, one, c_dir))
    costs["peak_rss_bytes"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    return costs


def measure_all(cells, out_dir: str) -> dict:
    """`{run key: costs}` of every cell, measured where `costs.json` in `out_dir` does not
    hold them yet (it is rewritten after each), each in a fresh process (a RuntimeError
    where that process dies, killed or crashed, rather than waiting for it)."""
    path = os.path.join(out_dir, "costs.json")
    costs = {}
    if os.path.isfile(path):
        with open(path) as file:
            costs = json.load(file)
    context = multiprocessing.get_context("spawn")
    for task, label, config in cells:
        if config.key in costs:
            continue
        c_dir = (os.path.join(out_dir, "controllers", f"{task}-{label}") if label in EXPORTED else None)
        with ProcessPoolExecutor(1, mp_context=context) as pool:
            try:
                measured = pool.submit(measure_cell, config, label, c_dir).result()
            except BrokenProcessPool:
                raise RuntimeError(f"the process measuring the costs of {label} on {task} died "
                                   f"without a result; the costs measured before it are in "
                                   f"{path}") from None
        costs[config.key] = {"task": task, "label": label, **measured}
        with outputs.atomic_write(path) as file:
            json.dump(costs, file, indent=1)
    return costs
