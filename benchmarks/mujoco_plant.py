"""The MuJoCo plant's cost per agent-step against the engine's own stepping, and where it goes.

For a sweep-sized batch of pendulum agents (512, `--agents`) on the MuJoCo plant, one run of
this script measures, each in wall time and in CPU time of all the process's threads, per
agent-step (one plant transition of one agent):

1. **the engine, open loop**: `mujoco.rollout` stepping the 512 pendulum states with random
   torques, as `tasks.plants.MujocoPlant` calls it (its `Rollout`, its thread count and
   `MjData`s, one call per step with the states it returned fed back); and, for reference,
   one call that rolls all the steps out at once (no return to Python between steps);
2. **learning**: `runners.run.run` of the paper's pendulum agent (`agent.paper_settings`)
   with `plant="mujoco"`, 512 agents for `--episodes` episodes of 3000 steps: the compiled
   loop (`runners.compiled`), which calls MuJoCo's `mj_step` itself (`tasks.engine`) with
   each agent's episodes run through on one thread; the same run acting greedily
   (`learn=False`, no updates) separates the learner's updates from the rest;
3. **the stepped path**: the same agents through `runners.stepped.run_batched` over a
   `tasks.batched.BatchedEnv` (one `mujoco.rollout` call per step of the batch, what `run`
   did before the compiled loop stepped MuJoCo), with clocks wrapped around the library's
   own functions: the agents' step (`Agents.step`), the `rollout` call, the rest of
   `MujocoPlant.step` and of `BatchedEnv.step` (starts, outcomes, observations), and the
   rest of the loop. Its results are checked equal to run 2's, bit for bit;
4. **reference**: the same agents on the analytic plant in the compiled loop (the learner's
   own cost plus an Euler step).

Runs 1 and 2 are measured `--repeats` times, alternately, and the fastest of each kept, so
that other jobs on the machine weigh less on their ratio. It prints the ratio 2 / 1 in wall
and in CPU time, the project's aim being at most 1.5. Ratios compare times measured in the
same run of this script.

Run from the repository root:

    python -m benchmarks.mujoco_plant              # 512 agents x 2 episodes, about a minute
    python -m benchmarks.mujoco_plant --quick      # smoke test
"""

import argparse
import dataclasses
import os
import time

import mujoco
import numba
import numpy as np

from benchmarks.agent_speed import machine
from lwrl.agent.threads import workers
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents, run, run_batched
from lwrl.tasks.batched import BatchedEnv

TASK = "pendulum.swingup"
AGENTS = 512
"""A sweep-sized batch (`lwrl reproduce` runs batches of 512 agents)."""
QUICK = {"agents": 16, "episodes": 1, "time_limit": 2.0}
"""`--quick`: a smoke test of 16 agents and one 2-second episode (100 steps)."""


@dataclasses.dataclass
class Clock:
    """Wall and CPU seconds (all threads) accumulated over the calls it timed."""

    wall: float = 0.0
    cpu: float = 0.0
    calls: int = 0

    def time(self, function, *args, **kwargs):
        """Call `function`, adding its wall and CPU time."""
        wall, cpu = time.perf_counter(), time.process_time()
        try:
            return function(*args, **kwargs)
        finally:
            self.wall += time.perf_counter() - wall
            self.cpu += time.process_time() - cpu
            self.calls += 1

    def __sub__(self, other: "Clock") -> "Clock":
        return Clock(self.wall - other.wall, self.cpu - other.cpu, self.calls)


def config(args) -> RunConfig:
    return RunConfig(task=TASK, plant="mujoco", agents=args.agents, episodes=args.episodes,
                     task_options={"time_limit": args.time_limit})


def engine_open_loop(args, steps: int) -> tuple[Clock, Clock]:
    """`steps` steps of the batch's states with random torques through the plant's own
    `rollout` call: one call per step (the states fed back), and one call for all steps."""
    env = BatchedEnv("pendulum", "swingup", "mujoco", seeds=range(args.agents))
    plant = env.plant
    model, nq = plant.model, plant.model.nq
    rng = np.random.default_rng(0)
    controls = rng.choice(np.asarray(env.definition.controls), size=(args.agents, steps))
    physics_state = np.zeros((args.agents, 1 + nq + model.nv))
    physics_state[:, 1:1 + nq] = env.state[:, 0::2]
    physics_state[:, 1 + nq:] = env.state[:, 1::2]
    control = np.zeros((args.agents, 1, model.nu))
    per_step, state = Clock(), physics_state
    for t in range(steps):
        control[:, 0, plant._actuator] = controls[:, t]
        after, _ = per_step.time(plant._rollout.rollout, model, plant._datas, state, control,
                                 nstep=1)
        state = after[:, -1]
    whole = np.zeros((args.agents, steps, model.nu))
    whole[:, :, plant._actuator] = controls
    at_once = Clock()
    after, _ = at_once.time(plant._rollout.rollout, model, plant._datas, physics_state, whole,
                            nstep=steps)
    np.testing.assert_array_equal(after[:, -1], state)  # the same trajectories
    return per_step, at_once


def timed(clock: Clock, owner, name: str) -> None:
    """Time every call of `owner.name` on `clock` (an instance attribute over the method)."""
    function = getattr(owner, name)
    setattr(owner, name, lambda *args, **kwargs: clock.time(function, *args, **kwargs))


def timed_stepped(args):
    """`runners.stepped.run_batched` of the run's agents over a MuJoCo `BatchedEnv`, with
    clocks on the library's own functions; returns its results and the clocks, each part's
    own time (the parts it calls taken out)."""
    env = BatchedEnv("pendulum", "swingup", "mujoco", seeds=config(args).seeds,
                     time_limit=args.time_limit)
    agent = make_agents(config(args))
    clocks = {name: Clock() for name in ("agents", "env", "plant", "rollout", "whole")}
    timed(clocks["agents"], agent, "step")
    timed(clocks["env"], env, "step")
    timed(clocks["plant"], env.plant, "step")
    timed(clocks["rollout"], env.plant._rollout, "rollout")
    results = clocks["whole"].time(run_batched, env, agent, args.episodes)
    clocks["loop"] = clocks["whole"] - clocks["agents"] - clocks["env"]
    clocks["env"] = clocks["env"] - clocks["plant"]
    clocks["plant"] = clocks["plant"] - clocks["rollout"]
    return results, clocks


def timed_run(run_config, learn: bool = True, agent=None):
    """`runners.run.run` timed: (agent, results, clock)."""
    wall, cpu = time.perf_counter(), time.process_time()
    agent, results = run(run_config, agents=agent, learn=learn)
    return agent, results, Clock(time.perf_counter() - wall, time.process_time() - cpu, 1)


def parse_batch_args(description: str, argv=None, repeats: bool = False) -> argparse.Namespace:
    """The arguments of a benchmark of a batch of pendulum agents: `--agents`, `--episodes`,
    `--quick` and, with `repeats`, `--repeats`; `time_limit` set (60 s, or `QUICK`'s)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--agents", type=int, default=AGENTS,
                        help=f"agents in the batch (default: {AGENTS})")
    parser.add_argument("--episodes", type=int, default=2,
                        help="episodes of each learning run (default: 2, of 3000 steps each)")
    if repeats:
        parser.add_argument("--repeats", type=int, default=2,
                            help="measurements of runs 1 and 2, alternately, the fastest kept "
                                 "(default: 2)")
    parser.add_argument("--quick", action="store_true",
                        help="smoke test: 16 agents, one episode of 100 steps")
    args = parser.parse_args(argv)
    args.time_limit = 60.0
    if args.quick:
        args.agents, args.episodes, args.time_limit = (QUICK["agents"], QUICK["episodes"],
                                                       QUICK["time_limit"])
    if min(args.agents, args.episodes, getattr(args, "repeats", 1)) < 1:
        parser.error(f"--agents, --episodes{' and --repeats' if repeats else ''} must be at "
                     "least 1")
    return args


def parse_args(argv=None) -> argparse.Namespace:
    return parse_batch_args(
        "Per agent-step wall and CPU time of lwrl's MuJoCo plant in a learning run of pendulum "
        "agents against mujoco.rollout's own open-loop stepping, and where the difference "
        "goes; prints Markdown tables.", argv, repeats=True)


def per_step(clock: Clock, agent_steps: int) -> tuple[float, float]:
    """(wall, CPU) microseconds per agent-step."""
    return 1e6 * clock.wall / agent_steps, 1e6 * clock.cpu / agent_steps


def main(argv=None) -> None:
    args = parse_args(argv)
    script_start = time.perf_counter()
    for plant in ("mujoco", "analytic"):  # compile (or load) the kernels
        run(dataclasses.replace(config(args), plant=plant, episodes=1,
                                task_options={"time_limit": 0.1}))
    steps = round(args.time_limit / 0.02) * args.episodes
    engine_steps = args.agents * steps
    per_call = at_once = learning = None
    for _ in range(args.repeats):  # alternately, the fastest of each kept
        calls, whole = engine_open_loop(args, steps)
        agent, results, clock = timed_run(config(args))
        per_call = calls if per_call is None or calls.wall < per_call.wall else per_call
        at_once = whole if at_once is None or whole.wall < at_once.wall else at_once
        learning = clock if learning is None or clock.wall < learning.wall else learning
    agent_steps = int(np.nansum(results.steps))
    _, greedy_results, greedy = timed_run(config(args), learn=False, agent=agent)
    greedy_steps = int(np.nansum(greedy_results.steps))

    stepped_results, clocks = timed_stepped(args)
    for field in ("steps", "returns", "uptime", "truncated"):
        np.testing.assert_array_equal(getattr(stepped_results, field), getattr(results, field))
    _, analytic_results, analytic = timed_run(dataclasses.replace(config(args), plant="analytic"))
    analytic_steps = int(np.nansum(analytic_results.steps))

    engine_wall, _ = per_step(per_call, engine_steps)
    rows = [("1. `mujoco.rollout`, one call per step (the plant's call)", per_call, engine_steps),
            ("1. `mujoco.rollout`, one call for all steps (reference)", at_once, engine_steps),
            ("2. learning run (`run`, plant mujoco: the compiled loop)", learning, agent_steps),
            ("2. the same agents acting greedily (`learn=False`)", greedy, greedy_steps),
            ("3. learning run on the stepped path (`run_batched`, `BatchedEnv`)",
             clocks["whole"], agent_steps),
            ("4. the same agents on the analytic plant (compiled loop)", analytic, analytic_steps)]
    print(f"Pendulum, {args.agents} agents, {args.episodes} x {steps // args.episodes} steps "
          f"each; microseconds per agent-step (1 and 2: the fastest of {args.repeats}):\n")
    print("| | wall | CPU | wall / 1 |")
    print("|---|---:|---:|---:|")
    for name, clock, count in rows:
        wall, cpu = per_step(clock, count)
        print(f"| {name} | {wall:.3f} | {cpu:.3f} | {wall / engine_wall:.2f} |")
    learning_wall, learning_cpu = per_step(learning, agent_steps)
    print(f"\nRatio 2 / 1 (wall): {learning_wall / engine_wall:.2f} (aim: at most 1.5); in CPU "
          f"time, {learning_cpu / per_step(per_call, engine_steps)[1]:.2f} (the fairer one "
          "where other jobs leave the threads no free core)")
    print("\n3. The stepped path's parts (clocks on the library's functions; results equal "
          "to run 2's), microseconds per agent-step:\n")
    print("| part | wall | CPU | share of the wall time |")
    print("|---|---:|---:|---:|")
    parts = (("agents' step (`Agents.step`)", "agents"),
             ("`mujoco.rollout` call", "rollout"),
             ("rest of `MujocoPlant.step` (state packing, copies)", "plant"),
             ("rest of `BatchedEnv.step` (starts, outcomes, observations)", "env"),
             ("rest of the loop (`run_batched`'s bookkeeping)", "loop"),
             ("whole", "whole"))
    for name, key in parts:
        wall, cpu = per_step(clocks[key], agent_steps)
        share = clocks[key].wall / clocks["whole"].wall
        print(f"| {name} | {wall:.3f} | {cpu:.3f} | {100 * share:.0f} % |")
    print("\n" + machine(f"{os.cpu_count()} cores ({workers()} lwrl threads, "
                         f"{min(args.agents, os.cpu_count())} rollout threads)", mujoco, np, numba))
    print(f"Total {time.perf_counter() - script_start:.1f} s.")


if __name__ == "__main__":
    main()
