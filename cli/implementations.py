"""`lwrl implementations`: the JAX population learners against the Stable-Baselines3
learners they re-implement, under the same settings, seeds and episodes."""

import argparse
import math
import os
import shlex
import time

from lwrl import outputs, tasks
from lwrl.cli import fields, output, reproduce

OUT = {"discrete": "implementations", "continuous": "implementations-continuous"}
"""The default output directory of each kind of action (`--action-kind`): one study's
report does not take the other's place."""
AGENTS = 10
"""Agents per implementation, task and pair by default."""


def positive_seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number of seconds > 0; got {text!r}")
    return value


def add_parser(commands) -> None:
    study = commands.add_parser(
        "implementations",
        help="the JAX population learners against the SB3 learners they re-implement",
        description="For each task and each pair of the registry (a population learner and "
                    "the learner whose settings it takes), run both with the settings tuned "
                    "for the reference on the task's domain, the same for both, the same seeds "
                    "and episodes; then write a report with the settings field by field, "
                    "learning curves, each implementation's measure with 95 % intervals, the "
                    "probability that the population learner does better, a verdict and the "
                    "costs. Runs are written as they finish: the same command resumes. The "
                    "pairs of discrete actions by default; --action-kind continuous runs those "
                    "of continuous actions on the tasks made with them.")
    study.add_argument("task", nargs="+", metavar="DOMAIN.TASK", choices=tasks.TASK_NAMES,
                       help="one or more of: " + ", ".join(tasks.TASK_NAMES))
    study.add_argument("--agents", metavar="N", type=reproduce.agents_per_cell, default=AGENTS,
                       help=f"agents per implementation, task and pair, seeds 0 to N-1 "
                            f"(default {AGENTS}; at least 2)")
    study.add_argument("--episodes", metavar="K", type=fields.positive_int,
                       help="episodes per agent (default: the benchmark's per task, lwrl bench's "
                            "protocol: 20 for the tasks measured in steps, 30 for those measured "
                            "in up-time, the cart-pole's of 60 s; the task's own for a task "
                            "the benchmark does not run)")
    study.add_argument("--timesteps", metavar="T", type=fields.positive_int,
                       help="both learners' learning horizon instead of the tuned set's "
                            "(a smoke test: it changes the protocol)")
    study.add_argument("--time-limit", metavar="SECONDS", type=positive_seconds,
                       help="the episodes' time limit, a whole number of control steps "
                            "(a smoke test: it changes the protocol)")
    study.add_argument("--action-kind", dest="actions", choices=tasks.ACTIONS,
                       default=tasks.ACTIONS[0],
                       help="the kind of action of the pairs run and of the tasks they run on "
                            f"(default {tasks.ACTIONS[0]}, the paper's; continuous: the force, "
                            "torque or thrust itself)")
    study.add_argument("--out", metavar="DIR",
                       help="output directory (default: "
                            + ", ".join(f"{out} with {kind} actions" for kind, out in OUT.items())
                            + ")")
    reproduce.add_sweep_flags(study)
    study.set_defaults(run=study_implementations)


def study_implementations(args) -> int:
    """Run (or resume) the study and write its report."""
    module, budgets = output.study_modules("implementations",
                                           "lwrl.studies.implementations.study",
                                           "lwrl.studies.paper.episode_budgets")
    started = time.perf_counter()
    args.out = args.out or OUT[args.actions]
    output.claim_outputs(args, "out")
    outputs.check_directory(args.out, "--out")  # a study resumes in its directory
    command = shlex.join(["lwrl", *args.argv])
    path = module.implementations(args.task, args.out, agents=args.agents,
                                  budgets=budgets.episode_budgets(),  # the first benchmark's
                                  episodes=args.episodes, timesteps=args.timesteps,
                                  time_limit=args.time_limit, backend=args.backend,
                                  workers=args.workers, address=args.address, command=command,
                                  actions=args.actions)
    output.done(started, [path, f"the figures in {os.path.join(args.out, 'figures')}",
                          f"the runs in {os.path.join(args.out, 'runs')}"])
    return 0
