"""The mjx plant (MuJoCo's XLA port) against the C engine, open loop and in the learning loop.

For a sweep-sized batch of pendulum agents (512, `--agents`), one run of this script measures,
each in wall time and in CPU time of all the process's threads, per agent-step (one plant
transition of one agent):

1. **the C engine, open loop**: `mujoco.rollout` stepping the states with random torques as
   `tasks.plants.MujocoPlant` calls it, one call per step (`benchmarks.mujoco_plant`'s
   measurement 1, the baseline of every ratio);
2. **MJX, open loop**: `tasks.mjx_plant.MjxPlant.step`, one call per step with the states it
   returned fed back, as a batched environment calls it; and, for reference, the same
   compiled step scanned over all the steps in one call (no return to Python between steps);
3. **learning on the C engine**: `runners.run.run` of the paper's pendulum agent with
   `plant="mujoco"`, `--episodes` episodes of 3000 steps: the compiled loop calling
   `mj_step` itself; and, like for like with 4, the stepped path (`runners.stepped.run_batched`
   over a `tasks.batched.BatchedEnv`), with the time of the plant's step within it;
4. **learning on MJX**: the same with `plant="mjx"`, which `run` runs on the stepped path.

The agents' kernels are compiled (or loaded) first, and the compilation of MJX's step (once
per process and batch size) is timed apart and left out of 2 and 4. It prints each time's
ratio to 1's.

Run from the repository root, with the extra installed (`pip install -e '.[mjx]'`):

    python -m benchmarks.mjx_plant              # 512 agents x 2 episodes, a few minutes
    python -m benchmarks.mjx_plant --quick      # smoke test
"""

import argparse
import dataclasses
import os
import time

import jax
import mujoco
import numpy as np

from benchmarks.agent_speed import machine
from benchmarks.mujoco_plant import (Clock, config, engine_open_loop, parse_batch_args,
                                     per_step, timed, timed_run)
from lwrl.runners.run import make_agents, run_batched
from lwrl.tasks.batched import BatchedEnv


def mjx_open_loop(args, steps: int) -> tuple[Clock, Clock, Clock]:
    """`steps` steps of the batch's states with random torques through `MjxPlant.step`, one
    call per step (the states fed back), and through its compiled step scanned over all
    steps in one call; and the clock of compiling both."""
    env = BatchedEnv("pendulum", "swingup", "mjx", seeds=range(args.agents))
    plant = env.plant
    rng = np.random.default_rng(0)
    controls = rng.choice(np.asarray(env.definition.controls), size=(args.agents, steps))
    with jax.enable_x64(True):
        scanned = jax.jit(lambda state, controls: jax.lax.scan(
            lambda state, control: (plant._step(state, control), None), state, controls)[0])
        compile_clock = Clock()
        compile_clock.time(plant.step, env.state, controls[:, 0])
        compile_clock.time(lambda: scanned(env.state, controls.T).block_until_ready())
        per_call, state = Clock(), env.state
        for t in range(steps):
            state = per_call.time(plant.step, state, controls[:, t])
        at_once = Clock()
        at_once.time(lambda: scanned(env.state, controls.T).block_until_ready())
    return per_call, at_once, compile_clock


def stepped_run(args, plant: str) -> tuple[Clock, Clock, int]:
    """`run_batched` of the configuration on `plant`: the whole run's clock, its plant
    steps' clock and the agent-steps it took."""
    run_config = dataclasses.replace(config(args), plant=plant)
    env = BatchedEnv("pendulum", "swingup", plant, seeds=run_config.seeds,
                     time_limit=args.time_limit)
    whole, plant_clock = Clock(), Clock()
    timed(plant_clock, env.plant, "step")
    results = whole.time(run_batched, env, make_agents(run_config), args.episodes)
    return whole, plant_clock, int(np.nansum(results.steps))


def parse_args(argv=None) -> argparse.Namespace:
    return parse_batch_args(
        "Per agent-step wall and CPU time of the mjx plant, open loop and in a learning run of "
        "pendulum agents, against mujoco.rollout's and the mujoco plant's; prints a Markdown "
        "table.", argv)


def main(argv=None) -> None:
    args = parse_args(argv)
    script_start = time.perf_counter()
    steps = round(args.time_limit / 0.02) * args.episodes
    open_steps = args.agents * steps
    warm_up = argparse.Namespace(**{**vars(args), "episodes": 1, "time_limit": 0.1})
    timed_run(config(warm_up))  # compile (or load) the kernels of both paths
    stepped_run(warm_up, "mujoco")
    engine, _ = engine_open_loop(args, steps)
    mjx_per_call, mjx_at_once, compiling = mjx_open_loop(args, steps)
    _, results, compiled = timed_run(config(args))
    stepped = {plant: stepped_run(args, plant) for plant in ("mujoco", "mjx")}

    engine_wall, engine_cpu = per_step(engine, open_steps)
    rows = [("1. `mujoco.rollout`, one call per step (`MujocoPlant`'s call)", engine, open_steps),
            ("2. MJX, one call per step (`MjxPlant.step`)", mjx_per_call, open_steps),
            ("2. MJX, one scanned call for all steps (reference)", mjx_at_once, open_steps),
            ("3. learning run, plant mujoco (`run`: the compiled loop)", compiled,
             int(np.nansum(results.steps)))]
    for plant, (whole, plant_clock, agent_steps) in stepped.items():
        number = 3 if plant == "mujoco" else 4
        rows += [(f"{number}. learning run, plant {plant}, stepped path", whole, agent_steps),
                 (f"{number}. of which the plant's step", plant_clock, agent_steps)]
    print(f"Pendulum, {args.agents} agents, {args.episodes} x {steps // args.episodes} steps "
          "each; microseconds per agent-step, and ratios to 1:\n")
    print("| | wall | CPU | wall / 1 | CPU / 1 |")
    print("|---|---:|---:|---:|---:|")
    for name, clock, count in rows:
        wall, cpu = per_step(clock, count)
        print(f"| {name} | {wall:.3f} | {cpu:.3f} | {wall / engine_wall:.2f} | "
              f"{cpu / engine_cpu:.2f} |")
    print(f"\nCompiling MJX's step and its scan for {args.agents} states (left out above): "
          f"{compiling.wall:.1f} s.")
    print("\n" + machine(f"{os.cpu_count()} cores", mujoco, jax, np))
    print(f"Total {time.perf_counter() - script_start:.1f} s.")


if __name__ == "__main__":
    main()
