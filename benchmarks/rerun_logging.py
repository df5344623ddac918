"""What logging to Rerun costs.

1. Per episode: `log_episode` (one `send_columns` per entity) against the per-step
   alternative (`set_time` and one `rr.log` per entity and step).
2. Per training run: the paper's pendulum and cart-pole runs (10 agents x 200 episodes,
   analytic plant) trained plainly, and trained recording agent 0's episodes as
   `lwrl train --rrd` does by default (every 20th) and sending everything it sends
   (episodes, value functions, learning curves) to an .rrd; the difference over the plain
   time is what logging adds.

    python -m benchmarks.rerun_logging [--steps-cartpole 12000] [--steps-pendulum 3000]

Both write to a temporary .rrd and include the final flush (Rerun encodes and writes in
background threads, which compete with the caller on a small machine). The recordings are
synthetic arrays of the right shapes: the cost does not depend on the values.
"""

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import rerun as rr

from lwrl import tasks
from lwrl.runners.config import RunConfig
from lwrl.cli.rerun_options import DEFAULT_EPISODES, episodes_to_log, send_run
from lwrl.runners.recording import EpisodeRecording
from lwrl.runners.run import make_agents, run
from lwrl.viz import names
from lwrl.viz import rerun as viz
from lwrl.viz import scene
from lwrl.viz.scene import scene_poses


def synthetic_recording(task: str, steps: int, seed: int = 0, plant: str | None = None,
                        episode: int = 0) -> EpisodeRecording:
    """An `EpisodeRecording` of `steps` steps with random arrays and NRBF-sized weights."""
    definition = names.task_definition(task)
    key, domain = definition.name, definition.domain
    rng = np.random.default_rng(seed)
    dim, actions = len(definition.state_names), definition.num_actions
    states = rng.normal(scale=0.1, size=(steps + 1, dim)).cumsum(axis=0)
    features = make_agents(RunConfig(task=key, agents=1)).features
    return EpisodeRecording(
        task=key, plant=plant or tasks.PLANTS[domain][0], agent=0, seed=seed, episode=episode,
        timestep=float(definition.control_timestep), state_names=definition.state_names,
        controls=definition.controls, states=states, observations=states.copy(),
        actions=rng.integers(actions, size=steps), rewards=-rng.random(steps),
        td_errors=rng.normal(size=steps), q_values=rng.normal(size=(steps + 1, actions)),
        uptime=np.arange(1, steps + 1) * definition.control_timestep if definition.has_uptime
        else np.full(steps, np.nan),
        weights=rng.normal(size=(actions, features.num_features)))


def time_columns(recording: EpisodeRecording, directory) -> tuple[float, float, float]:
    """`(call, wall, cpu)` seconds to `log_episode` a recording into a fresh .rrd: the call
    alone (what the caller waits for), wall time to the end of the flush, and the CPU time of
    all the process's threads (Rerun's encoder and writer included) to the end of the flush."""
    rec = viz.open_recording("lwrl_speed", rrd_path=Path(directory) / "columns.rrd")
    viz.log_task_scene(rec, recording.task)
    rec.flush()
    model = viz.load_model(recording.task) if scene.has_model(recording.task) else None
    box = make_agents(RunConfig(task=recording.task, agents=1)).value_box()
    start, cpu = time.perf_counter(), time.process_time()
    viz.log_episode(rec, recording, model=model, value_ranges=box)
    call = time.perf_counter() - start
    rec.flush()
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    viz.close_recording(rec)
    return call, wall, cpu


def time_per_step(recording: EpisodeRecording, directory) -> float:
    """Seconds to log the same data row by row: `set_time` and `rr.log` per entity and step."""
    rec = viz.open_recording("lwrl_speed", rrd_path=Path(directory) / "rows.rrd")
    viz.log_task_scene(rec, recording.task)
    rec.flush()
    start = time.perf_counter()
    poses = scene_poses(recording.task, recording.states)  # the same kinematics, vectorised
    run = names.run_name(recording.agent, recording.episode)
    controls = np.asarray(recording.controls)
    returns = recording.returns
    for t in range(recording.steps + 1):
        rec.set_time(names.STEP, sequence=t)
        rec.set_time(names.SIM_TIME, duration=t * recording.timestep)
        rec.set_time(names.EPISODE, sequence=recording.episode)
        for path, (translation, quaternion) in poses.items():
            rec.log(path, rr.Transform3D(translation=translation[t], quaternion=quaternion[t]))
        for j, variable in enumerate(recording.state_names):
            rec.log(names.state_path(variable, run), rr.Scalars(recording.states[t, j]))
        rec.log(f"{names.Q}/{run}", rr.Scalars(recording.q_values[t]))
        if t < recording.steps:
            a = int(recording.actions[t])
            rec.log(f"{names.ACTION}/{run}", rr.Scalars(a))
            rec.log(f"{names.CONTROL}/{run}", rr.Scalars(controls[a]))
        if t > 0:
            rec.log(f"{names.REWARD}/{run}", rr.Scalars(recording.rewards[t - 1]))
            rec.log(f"{names.RETURN}/{run}", rr.Scalars(returns[t - 1]))
            rec.log(f"{names.TD_ERROR}/{run}", rr.Scalars(recording.td_errors[t - 1]))
            if np.isfinite(recording.uptime[t - 1]):
                rec.log(f"{names.UPTIME}/{run}", rr.Scalars(recording.uptime[t - 1]))
    rec.flush()
    elapsed = time.perf_counter() - start
    viz.close_recording(rec)
    return elapsed


def measure(task: str, steps: int, repeats: int = 5, per_step: bool = True) -> dict:
    """Median over `repeats` of `time_columns` (call, wall, CPU seconds), and one per-step run."""
    recording = synthetic_recording(task, steps)
    with tempfile.TemporaryDirectory() as directory:
        call, wall, cpu = np.median([time_columns(recording, directory) for _ in range(repeats)], axis=0)
        rows = time_per_step(recording, directory) if per_step else float("nan")
    return {"task": task, "steps": steps, "call_s": call, "wall_s": wall, "cpu_s": cpu,
            "per_step_s": rows}


def training_overhead(task: str, which: str = DEFAULT_EPISODES, repeats: int = 3) -> dict:
    """Median wall and CPU seconds (all the process's threads) of a paper run of `task`
    trained plainly and trained with agent 0's episodes `which` (as `--log-episodes`)
    recorded and sent to an .rrd, over `repeats` alternating pairs (compilation excluded).
    CPU time counts the work logging adds even where other processes share the cores."""
    config = RunConfig(task=task, plant="analytic")
    run(RunConfig(task=task, plant="analytic", agents=1, episodes=1), record=[(0, 0)])  # compile
    record = [(0, episode) for episode in episodes_to_log(which, config.episodes)]
    plain, logged = [], []
    with tempfile.TemporaryDirectory() as directory:
        for repeat in range(repeats):
            start, cpu = time.perf_counter(), time.process_time()
            run(config)
            plain.append((time.perf_counter() - start, time.process_time() - cpu))
            start, cpu = time.perf_counter(), time.process_time()
            agent, results = run(config, record=record)
            send_run(config, results, agent, rrd_path=Path(directory) / f"run{repeat}.rrd")
            logged.append((time.perf_counter() - start, time.process_time() - cpu))
    (plain_wall, plain_cpu), (logged_wall, logged_cpu) = np.median(plain, axis=0), np.median(logged, axis=0)
    plain, logged = np.asarray(plain), np.asarray(logged)
    return {"task": task, "episodes_logged": len(record), "plain_s": float(plain_wall),
            "logged_s": float(logged_wall), "plain_cpu_s": float(plain_cpu),
            "logged_cpu_s": float(logged_cpu),
            "spread_s": float(max(np.ptp(plain[:, 0]), np.ptp(logged[:, 0]))),
            "spread_cpu_s": float(max(np.ptp(plain[:, 1]), np.ptp(logged[:, 1])))}


def overhead(plain: float, logged: float, spread: float) -> str:
    """What logging adds, as a percentage of `plain`; `within noise` where the difference of
    the medians is no larger than the spread of the repeats (the larger of the two
    conditions' ranges): logging cannot make a run faster, so a difference that small, or
    negative, is the machine's noise, not a cost or a gain."""
    if logged - plain <= spread:
        return f"within noise (spread {100 * spread / plain:.1f} %)"
    return f"{100 * (logged / plain - 1):.1f} %"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps-cartpole", type=int, default=12_000)
    parser.add_argument("--steps-pendulum", type=int, default=3_000)
    parser.add_argument("--steps-mountain-car", type=int, default=1_000)
    parser.add_argument("--no-per-step", action="store_true", help="skip the slow per-step run")
    args = parser.parse_args(argv)
    print("| task | steps | log_episode call | to flushed (wall) | CPU, all threads | CPU per step "
          "| per-step rr.log (wall, flushed) |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for task, steps in (("cartpole.balance", args.steps_cartpole),
                        ("pendulum.swingup", args.steps_pendulum),
                        ("mountain_car.cost_to_go", args.steps_mountain_car)):
        result = measure(task, steps, per_step=not args.no_per_step)
        per_step = "—" if np.isnan(result["per_step_s"]) else f"{result['per_step_s']:.2f} s"
        print(f"| {task} | {steps} | {result['call_s'] * 1e3:.1f} ms | {result['wall_s'] * 1e3:.1f} ms "
              f"| {result['cpu_s'] * 1e3:.1f} ms | {result['cpu_s'] / steps * 1e6:.2f} us "
              f"| {per_step} |")
    if args.no_per_step:
        print("\n—: not measured (--no-per-step)")
    print("\n| paper run (10 agents x 200 episodes; medians of 3) | episodes logged | training "
          "| training + logging | logging adds | CPU: training | CPU: + logging | logging adds |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for task in ("pendulum.swingup", "cartpole.balance"):
        result = training_overhead(task)
        print(f"| {task} | {result['episodes_logged']} | {result['plain_s']:.2f} s "
              f"| {result['logged_s']:.2f} s "
              f"| {overhead(result['plain_s'], result['logged_s'], result['spread_s'])} "
              f"| {result['plain_cpu_s']:.2f} s | {result['logged_cpu_s']:.2f} s "
              f"| {overhead(result['plain_cpu_s'], result['logged_cpu_s'], result['spread_cpu_s'])} |")
    print("\nlogging adds: the difference of the medians over the plain run's; within noise where "
          "it is no larger than the spread (max - min) of the repeats")


if __name__ == "__main__":
    main()
