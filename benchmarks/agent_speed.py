"""Agent-steps per second of lwrl's learner against a plain per-step NumPy loop.

On Mountain-Car and Cart-Pole (the analytic plant, semi-implicit Euler), with the paper's
agent of each task (`agent.paper_settings`), one run of this script measures:

1. **plain loop**: one agent written here as a straightforward per-step NumPy loop (the
   reference point, not project code): eq. 8 over all n^d centroids, Q = phi @ w, epsilon-
   greedy with random ties from a NumPy Generator, the trace (eq. 2 or 6) and weight update
   as whole-array operations, and the plant stepped by the task module's own `step` and
   `outcome` on scalars. Single-threaded; run for `--seconds` of wall time.
2. **lwrl, 1 agent**: `lwrl.runners.run.run_compiled` with a `BatchedSarsa` of one agent.
3. **lwrl, 300 agents**: the same with 300 seeds of that agent, on the default thread pool
   (`agent.threads.workers()` threads).

Beside each of lwrl's rates it prints the arithmetic model's bound for that task and size
(`benchmarks.arithmetic_bound`: the exponentials, multiply-adds and bytes of one agent-step
of the task's paper agent, from its feature sizes, at this machine's rates, measured by
micro-benchmarks in the same run; one core for one agent, `agent.threads.workers()` cores
for the batch) and lwrl's fraction of it.

An agent-step is one plant transition. The lwrl runs are bounded by episodes: after a
compiling warm-up (not timed), each measurement starts with few episodes and grows their
number, from zero weights each time, until one run lasts about `--seconds`; that run is
the measurement (rate = its agent-steps / its wall time). Cart-Pole episodes lengthen as
the agents learn (up to 12 000 steps), so the runs are reported with their episodes and
steps. Ratios compare rates measured in the same run of this script.

Run from the repository root:

    python -m benchmarks.agent_speed              # about 3 s per measurement
    python -m benchmarks.agent_speed --quick      # smoke test
"""

import argparse
import dataclasses
import math
import os
import time
from typing import Callable

import numba
import numpy as np

from benchmarks import arithmetic_bound
from lwrl import tasks
from lwrl.agent.threads import workers
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents, run_compiled
from lwrl.tasks import cartpole, mountain_car

BATCH = 300
"""Agents in the sweep-sized batch."""
QUICK_SECONDS = 0.1
"""Time budget per measurement with `--quick`."""
MOUNTAIN_CAR, CARTPOLE = np.asarray(mountain_car.NOMINAL), np.asarray(cartpole.NOMINAL)
"""The paper's physical parameter values of the benchmarked tasks."""


def mountain_car_plant(state, thrust):
    """(next state, reward, terminal) through `tasks.mountain_car`'s own functions."""
    next_state = mountain_car.step(*state, thrust, MOUNTAIN_CAR)
    reward, terminal, _ = mountain_car.outcome(*next_state, MOUNTAIN_CAR)
    return next_state, reward, terminal


def cartpole_plant(state, force):
    """(next state, reward, terminal) through `tasks.cartpole`'s own functions."""
    next_state = cartpole.step(*state, force, dt=cartpole.TIMESTEP, semi_implicit=True,
                               slips=False, p=CARTPOLE)
    reward, terminal, _ = cartpole.outcome(*next_state, track_limit=cartpole.TRACK_LIMIT,
                                           p=CARTPOLE)
    return next_state, reward, terminal


PLANTS: dict[str, Callable] = {
    "mountain_car.cost_to_go": mountain_car_plant,
    "cartpole.balance": cartpole_plant,
}
"""The benchmarked tasks and the plain loop's plant step for each."""


class PlainSarsa:
    """One gradient-descent Sarsa(lambda) agent with NRBF features, in plain NumPy."""

    def __init__(self, config: RunConfig, num_actions: int, rng: np.random.Generator):
        ranges = config.task_spec.ranges
        self.low = np.array(ranges.low)
        self.span = np.array(ranges.high) - self.low
        settings = config.settings
        grid = (np.arange(settings.n) + 0.5) / settings.n
        axes = np.meshgrid(*[grid] * len(self.low), indexing="ij")
        self.centroids = np.stack(axes, axis=-1).reshape(-1, len(self.low))
        self.r2 = settings.r2
        self.alpha, self.epsilon, self.gamma = settings.alpha, settings.epsilon, settings.gamma
        self.gamma_lambda = settings.gamma * settings.lam
        self.accumulating = settings.trace == "accumulating"
        self.weights = np.zeros((len(self.centroids), num_actions))
        self.traces = np.zeros_like(self.weights)
        self.rng = rng

    def features(self, state) -> np.ndarray:
        """Eq. 8 over every centroid, normalised to sum to 1 (eq. 9)."""
        s = (np.asarray(state, dtype=np.float64) - self.low) / self.span
        phi = np.exp(-((s - self.centroids) ** 2).sum(axis=1) / self.r2)
        return phi / phi.sum()

    def act(self, phi: np.ndarray) -> int:
        """Epsilon-greedy on Q = phi @ w, ties broken uniformly at random."""
        q = phi @ self.weights
        if self.epsilon > 0.0 and self.rng.random() < self.epsilon:
            return int(self.rng.integers(q.size))
        best = np.flatnonzero(q == q.max())
        return int(best[self.rng.integers(best.size)]) if best.size > 1 else int(best[0])

    def learn(self, phi, action, reward, next_phi=None, next_action=0):
        """Eq. 1 for the transition from (phi, action); `next_phi` None at a terminal state."""
        delta = reward - phi @ self.weights[:, action]
        if next_phi is not None:
            delta += self.gamma * (next_phi @ self.weights[:, next_action])
        self.traces *= self.gamma_lambda
        if self.accumulating:
            self.traces[:, action] += phi
        else:
            np.maximum(self.traces[:, action], phi, out=self.traces[:, action])
        self.weights += self.alpha * delta * self.traces


def plain_episode(agent: PlainSarsa, definition, plant, deadline: float) -> int:
    """One episode (cut at `deadline`); returns its agent-steps."""
    agent.traces[:] = 0.0
    state = definition.initial_states(agent.rng, 1)[0]
    phi = agent.features(state)
    action = agent.act(phi)
    steps = 0
    while True:
        state, reward, terminal = plant(state, definition.controls[action])
        steps += 1
        if terminal:
            agent.learn(phi, action, reward)
            return steps
        next_phi = agent.features(state)
        next_action = agent.act(next_phi)
        agent.learn(phi, action, reward, next_phi, next_action)
        if steps >= definition.step_limit or time.perf_counter() >= deadline:
            return steps
        phi, action = next_phi, next_action


@dataclasses.dataclass
class Measurement:
    """Agent-steps done in a timed run."""

    steps: int
    seconds: float
    agents: int = 1
    episodes: int = 0
    """Episodes per agent (lwrl); for the plain loop, the episodes begun."""

    @property
    def rate(self) -> float:
        return self.steps / self.seconds


def measure_plain(task: str, seconds: float, seed: int = 0) -> Measurement:
    """The plain loop's agent, from zero weights, for `seconds` of wall time."""
    config = RunConfig(task=task, agents=1)
    definition = tasks.definition(config.domain, config.task_name)
    agent = PlainSarsa(config, definition.num_actions, np.random.default_rng(seed))
    start = time.perf_counter()
    deadline = start + seconds
    steps = episodes = 0
    while time.perf_counter() < deadline:
        steps += plain_episode(agent, definition, PLANTS[task], deadline)
        episodes += 1
    return Measurement(steps, time.perf_counter() - start, episodes=episodes)


def run_lwrl(task: str, agents: int, episodes: int) -> Measurement:
    """One timed `run_compiled` of `agents` seeds of the task's paper agent."""
    config = RunConfig(task=task, agents=agents, episodes=episodes, plant="analytic")
    agent = make_agents(config)
    start = time.perf_counter()
    results = run_compiled(config.domain, config.task_name, agent, episodes, config.seeds,
                           integrator=config.integrator)
    elapsed = time.perf_counter() - start
    return Measurement(int(np.nansum(results.steps)), elapsed, agents, episodes)


def measure_lwrl(task: str, agents: int, seconds: float) -> Measurement:
    """Grow the episodes (at most 4-fold a run) until a run lasts at least 3/4 of `seconds`;
    return that run."""
    episodes = 1
    while True:
        run = run_lwrl(task, agents, episodes)
        if run.seconds >= 0.75 * seconds:
            return run
        growth = min(4.0, 1.1 * seconds / max(run.seconds, 1e-6))
        episodes = max(episodes + 1, math.ceil(episodes * growth))


def cpu_model() -> str:
    """The CPU's model name from /proc/cpuinfo, or `unknown`."""
    try:
        with open("/proc/cpuinfo") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown"


def machine(cores: str, *modules) -> str:
    """A benchmark's machine line: `cores`, the CPU, the load average now (other jobs change
    what the figures mean) and the versions of `modules`."""
    load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    versions = ", ".join(f"{module.__name__} {module.__version__}" for module in modules)
    return f"Machine: {cores}, CPU {cpu_model()}, load average {load} at the end; {versions}."


def cell(measurement: Measurement, reference: Measurement | None = None) -> str:
    """A rate, and its ratio to `reference`'s."""
    text = f"{measurement.rate:,.0f}"
    return text if reference is None else f"{text} (x{measurement.rate / reference.rate:.1f})"


def plural(count: int, noun: str) -> str:
    return f"{count} {noun}{'' if count == 1 else 's'}"


def run_line(task: str, name: str, m: Measurement) -> str:
    """What one measurement ran."""
    episodes = plural(m.episodes, "episode")
    if name != "plain loop":
        episodes = f"{plural(m.agents, 'agent')} x {episodes}"
    return (f"- {task}, {name}: {episodes}, {m.steps:,} agent-steps in {m.seconds:.2f} s "
            f"({m.steps / (m.agents * m.episodes):,.0f} steps per episode)")


def parse_args(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description="Agent-steps/s of lwrl's compiled learner (1 agent and a batch of "
                    f"{BATCH}) against a plain per-step NumPy loop, on Mountain-Car and "
                    "Cart-Pole; prints a Markdown table.")
    parser.add_argument("--seconds", type=float, default=3.0,
                        help="time budget per measurement, in seconds (default: 3)")
    parser.add_argument("--quick", action="store_true",
                        help=f"smoke test: {QUICK_SECONDS} s per measurement")
    args = parser.parse_args(argv)
    if not args.seconds > 0:
        parser.error(f"--seconds must be positive; got {args.seconds}")
    if args.quick:
        args.seconds = QUICK_SECONDS
    return args


def bound_cell(measurement: Measurement, bound: float) -> str:
    """The model's bound (agent-steps/s) and the measurement's fraction of it."""
    return f"{bound:,.0f} ({100 * measurement.rate / bound:.0f} %)"


def model_line(task: str, counts, rates, seconds: float) -> str:
    """One task's model: its agent's sizes, counts per agent-step, the rates measured at
    those sizes and one core's bound."""
    return (f"- {task}: d {counts.dim}, n {counts.n}, N {counts.features}, A {counts.actions}: "
            f"{counts.exponentials} exponentials, {counts.multiply_adds:,} multiply-adds, "
            f"{counts.bytes:,} bytes per agent-step; measured {rates.exp / 1e6:,.0f} M exp/s, "
            f"{rates.mac / 1e9:.2f} G multiply-adds/s, {rates.memory / 1e9:.1f} GB/s; bound "
            f"{1e9 * seconds:,.0f} ns per agent-step on one core")


def main(argv=None) -> None:
    args = parse_args(argv)
    script_start = time.perf_counter()
    for task in PLANTS:
        run_lwrl(task, 1, 1)  # compiles the task's loop
    compile_seconds = time.perf_counter() - script_start
    cores = workers()
    rows, runs, models = [], [], []
    for task in PLANTS:
        counts = arithmetic_bound.task_counts(task)
        rates = arithmetic_bound.measure_rates(counts)
        seconds = arithmetic_bound.bound_seconds(counts, rates)
        models.append(model_line(task, counts, rates, seconds))
        plain = measure_plain(task, args.seconds)
        single = measure_lwrl(task, 1, args.seconds)
        batch = measure_lwrl(task, BATCH, args.seconds)
        rows.append(f"| {task} | {cell(plain)} | {cell(single, plain)} | "
                    f"{bound_cell(single, 1 / seconds)} | {cell(batch, plain)} | "
                    f"{bound_cell(batch, min(cores, BATCH) / seconds)} |")
        runs += [run_line(task, name, m) for name, m in
                 (("plain loop", plain), ("lwrl 1 agent", single), (f"lwrl {BATCH} agents", batch))]
    print(f"| task | plain loop (agent-steps/s) | lwrl 1 agent (agent-steps/s, ratio to plain) "
          f"| bound, 1 core (lwrl's fraction) | lwrl {BATCH} agents (agent-steps/s, ratio to "
          f"plain) | bound, {plural(min(cores, BATCH), 'core')} (lwrl's fraction) |")
    print("|---|---:|---:|---:|---:|---:|")
    print("\n".join(rows))
    print("\nArithmetic model (benchmarks.arithmetic_bound), per task's paper agent:")
    print("\n".join(models))
    print("\n" + machine(f"{cores} cores used (agent.threads.workers())", np, numba))
    print("\nRuns measured:")
    print("\n".join(runs))
    print(f"\nTotal {time.perf_counter() - script_start:.1f} s, of which {compile_seconds:.1f} s "
          "compiling lwrl's loops (not in any rate).")


if __name__ == "__main__":
    main()
