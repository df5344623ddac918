"""What the second benchmark's deep rows would have cost on Stable-Baselines3 alone: CPU per
agent-step of each deep row's configuration on its SB3 twin, written to
`OUT_DIR/sb3_cost.json` for the report's cost line (`studies.paper.benchmark.twin_cost.sentence`).

The deep rows run on the JAX population learners (`protocol.DEEP`, `protocol.CONTINUOUS_DEEP`);
each one's twin is the SB3 learner whose settings class its own subclasses
(`studies.implementations.plan.pairs`: `dqn_jax` and `dqn`, `ppo_jax` and `ppo`, `sac_jax` and
`sac`, `td3_jax` and `td3`), field for field the same settings. The configurations are those
of `OUT_DIR/runs` (`twin_cost.deep_configurations`: every search configuration of a deep row with
a run there, found as the study makes them; the row's own runs are its chosen configuration's),
each named by its search training's run key.

Every configuration is measured, none sampled or grouped: what one SB3 step costs depends on
the settings the search draws together (width, batch, training frequency and gradient steps,
rollout length and epochs), so no few settings stand for the others, and a configuration
takes about ten seconds (16 per deep row and task: the 128 of four tasks' two rows took 21
min of wall time while the benchmark's own runs kept both cores busy).

Per configuration, one agent of the twin with the configuration's settings (its horizon
`timesteps` the run's, so the schedules are the same), on its task and plant, in this process
through lwrl's loop (`runners.run.run`, SB3's models stepped one time step at a time, torch on
one thread: `agent.stable_baselines.torch_modules`), after an untimed run of `WARM_UP` steps of
another agent of it (imports, the first calls). Then the same agent, continued, in three
phases, each's CPU time (`time.process_time()`) over its agent-steps:

1. warm-up: its `learning_starts` steps (DQN, SAC, TD3; none for PPO), which act before any
   update and store transitions;
2. learning: `--steps` steps (default `STEPS`) and at least two training periods (PPO's
   rollouts of `n_steps`, with their updates; the others' `train_freq`), in whole periods, so
   that the updates are counted in their share;
3. greedy: `--steps` steps acting greedily without learning, as the evaluations run.

The report multiplies each run's steps by these: a training agent's first `learning_starts`
steps by the warm-up's, its others by learning's, an evaluation's by the greedy steps'. The
learning phase times the first `--steps` steps of learning; the replay buffer's and the
rollout's costs per update do not grow with the steps taken, so they stand for the run's.

Written after each configuration (`lwrl.outputs.atomic_write`), and resumable: a configuration
the file holds is not measured again. Each entry: task, plant, row, configuration index,
learner and twin, the twin's settings, `warm_up_steps`, the steps and CPU seconds per step of
each phase, host, lwrl's version, the command, the time.

    python -m benchmarks.sb3_cost docs/benchmark2
    python -m benchmarks.sb3_cost docs/benchmark2 --steps 5000
"""

import dataclasses
import json
import os
import platform
import sys
import time

import numpy as np

import lwrl
from lwrl import outputs
from lwrl.cli.output import Parser
from lwrl.runners.config import learner_settings
from lwrl.runners.run import make_agents, run
from lwrl.studies.implementations.plan import pairs, reference_settings
from lwrl.studies.paper.benchmark import twin_cost
from lwrl.tasks.task_definition import ACTIONS

STEPS = 3000
"""Learning and greedy steps timed per configuration (learning: at least two periods)."""
WARM_UP = 100
"""Steps of the untimed run before a configuration's measurement."""
PROG = "python -m benchmarks.sb3_cost"


def twins() -> dict:
    """`{population learner: its SB3 twin}` of every kind of action (`plan.pairs`)."""
    return {pair.twin: pair.reference for actions in ACTIONS for pair in pairs(actions=actions)}


def twin_config(config, twin: str, plant: str):
    """One agent of `twin` with the settings of the run `config`'s learner on the
    benchmark's `plant` (on MuJoCo's model the C engine, which SB3 steps, where the JAX
    learner stepped MJX), the rest of the run as it is."""
    settings = learner_settings(twin, reference_settings(twin, config.settings))
    return dataclasses.replace(config, learner=twin, settings=settings, agents=1, plant=plant)


def learning_steps(settings, least: int) -> int:
    """At least `least` steps and two training periods (a rollout of `n_steps`, else
    `train_freq` steps), in whole periods."""
    period = getattr(settings, "n_steps", None) or getattr(settings, "train_freq", 1)
    return -(-max(least, 2 * period) // period) * period


def phase(config, agent, steps: int, learn: bool) -> tuple:
    """`(agent-steps, CPU seconds per agent-step)` of `agent` continued for `steps` steps,
    learning, or else greedy without learning."""
    start = time.process_time()
    _, results = run(dataclasses.replace(config, budget=steps), agents=agent, learn=learn,
                     greedy=not learn)
    seconds = time.process_time() - start
    taken = int(np.nansum(results.steps))
    return taken, seconds / taken


def measure(config, least: int) -> dict:
    """The steps and CPU seconds per step of the twin's run `config` (one agent) in each
    phase (see the module), and its `warm_up_steps`."""
    run(dataclasses.replace(config, seed=config.seed + 1, budget=WARM_UP))
    agent = make_agents(config)
    warm_up = getattr(config.settings, "learning_starts", 0)
    phases = {"warm_up": (warm_up, True), "learning": (learning_steps(config.settings, least), True),
              "greedy": (least, False)}
    measured = {name: phase(config, agent, steps, learn) if steps else (0, 0.0)
                for name, (steps, learn) in phases.items()}
    return {"warm_up_steps": warm_up,
            "steps": {name: steps for name, (steps, _) in measured.items()},
            "cpu_s_per_step": {name: rate for name, (_, rate) in measured.items()}}


def read(path: str) -> dict:
    """The entries `path` holds (none where it is absent)."""
    if not os.path.exists(path):
        return {}
    with open(path) as file:
        return json.load(file)


def parse_args(argv=None):
    parser = Parser(prog=PROG, description=__doc__.split("\n\n")[0])
    parser.add_argument("out_dir", metavar="OUT_DIR",
                        help="the benchmark's directory (its runs/ read, sb3_cost.json written)")
    parser.add_argument("--steps", type=int, default=STEPS,
                        help=f"learning and greedy steps timed per configuration (default {STEPS})")
    parser.add_argument("--plant", choices=("analytic", "mujoco"), default="analytic",
                        help="the benchmark's plant (its --plant; default analytic)")
    args = parser.parse_args(argv)
    if not os.path.isdir(os.path.join(args.out_dir, "runs")):
        parser.error(f"{args.out_dir} has no runs/ directory: give the benchmark's directory")
    if args.steps < 1:
        parser.error(f"--steps must be a positive number of steps; got {args.steps}")
    return parser, args


def main(argv=None) -> None:
    parser, args = parse_args(argv)
    started = time.perf_counter()
    command = " ".join([PROG, *(sys.argv[1:] if argv is None else argv)])
    path = os.path.join(args.out_dir, twin_cost.SB3_COST)
    try:
        measured = read(path)
        found = twin_cost.deep_configurations(args.out_dir, args.plant)
    except ValueError as error:  # an unreadable file, a learner that cannot run here
        parser.error(str(error))
    if not found:
        parser.error(f"{args.out_dir}/runs holds no run of a deep row of the second benchmark "
                     f"on the {args.plant} plant")
    pair = twins()
    for c in found:
        if c.key in measured:
            continue
        trained = c.trainings[0]
        try:
            config = twin_config(trained, pair[trained.learner], args.plant)
        except ValueError as error:  # SB3 not installed
            parser.error(str(error))
        measured[c.key] = {"task": c.task, "plant": config.plant, "row": c.label,
                           "configuration": c.index, "learner": trained.learner,
                           "twin": config.learner, "settings": dataclasses.asdict(config.settings),
                           **measure(config, args.steps), "host": platform.node(),
                           "lwrl": lwrl.__version__, "command": command,
                           "measured": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
        with outputs.atomic_write(path) as file:
            json.dump(measured, file, indent=1)
        rates = measured[c.key]["cpu_s_per_step"]
        print(f"{c.task} {c.label} #{c.index} on {config.learner}: "
              + ", ".join(f"{name} {1e6 * rate:,.0f} us" for name, rate in rates.items())
              + " CPU per agent-step", file=sys.stderr, flush=True)
    print(twin_cost.sentence(args.out_dir))
    print(f"{len(found)} configurations; {time.perf_counter() - started:.0f} s of wall time.")


if __name__ == "__main__":
    main()
