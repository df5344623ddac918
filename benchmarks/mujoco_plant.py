"""The MuJoCo plant's cost per agent-step against the engine's own stepping, and where it goes.

For a sweep-sized batch of pendulum agents (512, `--agents`) on the MuJoCo plant, one run of
this script measures, each in wall time and in CPU time of all the process's threads, per
agent-step (one plant transition of one agent):

1. **the engine, open loop**: `mujoco.rollout` stepping the 512 pendulum states with random
   torques, as `tasks.plants.MujocoPlant` calls it (its `Rollout`, its thread count and
   `MjData`s, one call per step with the states it returned fed back); and, for reference,
   one call that rolls all the steps out at once (no return to Python between steps);
2. **learning**: `runners.run.run` of the paper's pendulum agent (`TaskDefinition.defaults`)
   with `plant="mujoco"`, 512 agents for `--episodes` episodes of 3000 steps
   (`runners.stepped.run_batched` over a `tasks.batched.BatchedEnv`);
3. **the breakdown of 2**: the same run through a copy of `run_batched`'s loop (here, not in
   the library) with clocks around its parts: the agents' step (`BatchedSarsa.step`), the
   plant's step (`MujocoPlant.step`, and within it the `rollout` call), the rest of
   `BatchedEnv.step` (starts, rewards, terminations, up-time, observations) and the rest of
   the loop (`run_batched`'s bookkeeping). The copy's results are checked equal to run 2's;
4. **references**: the same agents on the analytic plant in lwrl's compiled loop (the
   learner's own cost plus an Euler step, with no Python per step), and the fixed cost of a
   hand-off to each thread pool (lwrl's `run_in_chunks` of an empty kernel, `rollout` of
   two states), which a step pays whatever the batch.

It prints the ratio 2 / 1, the project's aim being at most 1.5. Ratios compare times
measured in the same run of this script.

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

from benchmarks.agent_speed import cpu_model
from lwrl.agent.threads import run_in_chunks, workers
from lwrl.runners.config import RunConfig
from lwrl.runners.episodes import EpisodeResults, finish_episode
from lwrl.runners.run import make_agent, run
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


@numba.njit(nogil=True)
def _nothing(start, stop, counts):
    """An empty kernel: what a hand-off to lwrl's thread pool costs without work."""
    counts[start] += 1


def hand_offs(args, calls: int = 1000) -> tuple[float, float]:
    """Wall seconds of one hand-off to lwrl's thread pool (`run_in_chunks` of an empty
    kernel over the batch) and of one `rollout` call of two states, one step."""
    counts = np.zeros(args.agents)
    _nothing(0, 1, counts)
    start = time.perf_counter()
    for _ in range(calls):
        run_in_chunks(_nothing, args.agents, counts)
    lwrl_pool = (time.perf_counter() - start) / calls
    plant = BatchedEnv("pendulum", "swingup", "mujoco", seeds=range(args.agents)).plant
    state, control = np.zeros((2, 1 + plant.model.nq + plant.model.nv)), np.zeros((2, 1, 1))
    start = time.perf_counter()
    for _ in range(calls):
        plant._rollout.rollout(plant.model, plant._datas, state, control, nstep=1)
    return lwrl_pool, (time.perf_counter() - start) / calls


def timed_run_batched(env: BatchedEnv, agent, episodes: int) -> tuple[EpisodeResults, dict]:
    """`runners.stepped.run_batched` without recording, with clocks around its parts."""
    clocks = {name: Clock() for name in ("agents", "env", "plant", "rollout", "loop")}
    plant, rollout = env.plant, env.plant._rollout
    plant_step, rollout_call = plant.step, rollout.rollout
    plant.step = lambda *a, **k: clocks["plant"].time(plant_step, *a, **k)
    rollout.rollout = lambda *a, **k: clocks["rollout"].time(rollout_call, *a, **k)
    whole = Clock()
    wall, cpu = time.perf_counter(), time.process_time()
    try:
        batch = env.batch_size
        results = EpisodeResults.empty(batch, episodes)
        done = np.zeros(batch, dtype=np.int64)
        running = np.ones(batch, dtype=bool)
        returns = np.zeros(batch)
        ts = env.reset()
        while True:
            actions = clocks["agents"].time(agent.step, ts.first(), ts.reward, ts.discount,
                                            ts.observation, active=running, learn=True)
            newly_diverged = running & agent.diverged
            ended = running & (ts.last() | newly_diverged)
            for b in np.flatnonzero(ended):
                finish_episode(b, done[b], env.steps[b], returns[b], env.uptime[b],
                               ts.last()[b] and ts.discount[b] == 1.0, newly_diverged[b],
                               results.steps, results.returns, results.uptime,
                               results.truncated, results.diverged_episode, done)
            running &= (done < episodes) & ~agent.diverged
            if not running.any():
                break
            ts = clocks["env"].time(env.step, actions)
            returns = np.where(ts.first(), 0.0, returns + ts.reward)
    finally:
        whole.wall, whole.cpu = time.perf_counter() - wall, time.process_time() - cpu
        del plant.step, rollout.rollout
    clocks["loop"] = whole - clocks["agents"] - clocks["env"]
    clocks["env"] = clocks["env"] - clocks["plant"]
    clocks["plant"] = clocks["plant"] - clocks["rollout"]
    clocks["whole"] = whole
    return results, clocks


def parse_args(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description="Per agent-step wall and CPU time of lwrl's MuJoCo plant in a learning run "
                    "of pendulum agents against mujoco.rollout's own open-loop stepping, and "
                    "where the difference goes; prints Markdown tables.")
    parser.add_argument("--agents", type=int, default=AGENTS,
                        help=f"agents in the batch (default: {AGENTS})")
    parser.add_argument("--episodes", type=int, default=2,
                        help="episodes of each learning run (default: 2, of 3000 steps each)")
    parser.add_argument("--quick", action="store_true",
                        help="smoke test: 16 agents, one episode of 100 steps")
    args = parser.parse_args(argv)
    args.time_limit = 60.0
    if args.quick:
        args.agents, args.episodes, args.time_limit = (QUICK["agents"], QUICK["episodes"],
                                                       QUICK["time_limit"])
    if args.agents < 1 or args.episodes < 1:
        parser.error("--agents and --episodes must be at least 1")
    return args


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
    per_call, at_once = engine_open_loop(args, steps)
    engine_steps = args.agents * steps

    start, cpu_start = time.perf_counter(), time.process_time()
    _, results = run(config(args))
    learning = Clock(time.perf_counter() - start, time.process_time() - cpu_start, 1)
    agent_steps = int(np.nansum(results.steps))

    env = BatchedEnv("pendulum", "swingup", "mujoco", seeds=config(args).seeds,
                     time_limit=args.time_limit)
    agent = make_agent(config(args))
    copy_results, clocks = timed_run_batched(env, agent, args.episodes)
    for field in ("steps", "returns", "uptime", "truncated"):
        np.testing.assert_array_equal(getattr(copy_results, field), getattr(results, field))

    analytic_config = dataclasses.replace(config(args), plant="analytic")
    start, cpu_start = time.perf_counter(), time.process_time()
    _, analytic_results = run(analytic_config)
    analytic = Clock(time.perf_counter() - start, time.process_time() - cpu_start, 1)
    analytic_steps = int(np.nansum(analytic_results.steps))
    lwrl_pool, rollout_pool = hand_offs(args)

    engine_wall, _ = per_step(per_call, engine_steps)
    rows = [("1. `mujoco.rollout`, one call per step (the plant's call)", per_call, engine_steps),
            ("1. `mujoco.rollout`, one call for all steps (reference)", at_once, engine_steps),
            ("2. learning run (`run`, plant mujoco)", learning, agent_steps),
            ("4. the same agents on the analytic plant (compiled loop)", analytic, analytic_steps)]
    print(f"Pendulum, {args.agents} agents, {args.episodes} x {steps // args.episodes} steps "
          "each; microseconds per agent-step:\n")
    print("| | wall | CPU | wall / 1 |")
    print("|---|---:|---:|---:|")
    for name, clock, count in rows:
        wall, cpu = per_step(clock, count)
        print(f"| {name} | {wall:.3f} | {cpu:.3f} | {wall / engine_wall:.2f} |")
    print(f"\nRatio 2 / 1 (wall): {per_step(learning, agent_steps)[0] / engine_wall:.2f} "
          "(aim: at most 1.5)")
    print("\n3. The learning run's parts (a copy of run_batched's loop, timed; results equal "
          "to run 2's), microseconds per agent-step:\n")
    print("| part | wall | CPU | share of the wall time |")
    print("|---|---:|---:|---:|")
    parts = (("agents' step (`BatchedSarsa.step`)", "agents"),
             ("`mujoco.rollout` call", "rollout"),
             ("rest of `MujocoPlant.step` (state packing, copies)", "plant"),
             ("rest of `BatchedEnv.step` (starts, outcomes, observations)", "env"),
             ("rest of the loop (`run_batched`'s bookkeeping)", "loop"),
             ("whole", "whole"))
    for name, key in parts:
        wall, cpu = per_step(clocks[key], agent_steps)
        share = clocks[key].wall / clocks["whole"].wall
        print(f"| {name} | {wall:.3f} | {cpu:.3f} | {100 * share:.0f} % |")
    outside = clocks["env"].wall + clocks["loop"].wall + clocks["plant"].wall
    python = outside / clocks["agents"].calls
    print(f"\nPer step of the batch (whatever its size): Python and copies outside the two "
          f"pools {1e6 * python:.0f} us; a hand-off to lwrl's pool {1e6 * lwrl_pool:.0f} us, "
          f"to rollout's {1e6 * rollout_pool:.0f} us.")
    print(f"\nMachine: {os.cpu_count()} cores ({workers()} lwrl threads, "
          f"{len(env.plant._datas)} rollout threads), CPU {cpu_model()}, load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())} at the end; mujoco "
          f"{mujoco.__version__}, numpy {np.__version__}, numba {numba.__version__}.")
    print(f"Total {time.perf_counter() - script_start:.1f} s.")


if __name__ == "__main__":
    main()
