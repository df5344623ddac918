"""`lwrl robustness`: how far from the paper's plant the learned controllers still work."""

import shlex
import sys
import time

from lwrl import outputs, tasks
from lwrl.cli import fields, output


def add_parser(commands) -> None:
    study = commands.add_parser(
        "robustness", help="evaluate trained controllers away from the paper's plant",
        description="Train every learner that fits each task on the paper's plant and with "
                    "randomised physics, then run them greedily over a grid of the domain's "
                    "robustness parameters, observation noise and actuation delays, with the "
                    "exported C controller beside them; write a map figure per task and a "
                    "report. Runs are written as they finish: the same command resumes.")
    study.add_argument("task", nargs="+", metavar="DOMAIN.TASK", choices=tasks.TASK_NAMES,
                       help="one or more of: " + ", ".join(tasks.TASK_NAMES))
    study.add_argument("--plant", default="analytic",
                       help="the plant (default analytic: it agrees with MuJoCo to round-off "
                            "at any parameter values, and costs less)")
    study.add_argument("--agents", type=fields.positive_int,
                       help="agents per trained batch (default: the task's protocol)")
    study.add_argument("--episodes", type=fields.positive_int,
                       help="training episodes per agent (default: the task's protocol)")
    study.add_argument("--evaluation-episodes", type=fields.positive_int,
                       help="greedy episodes per agent and cell (default: the plant "
                            "comparison's transfer episodes, else 10)")
    study.add_argument("--out", metavar="DIR", default="robustness",
                       help="output directory (default: robustness)")
    study.add_argument("--workers", type=fields.positive_int,
                       help="threads (default: all cores)")
    study.add_argument("--quick", action="store_true", help="tiny grids: a smoke test in seconds")
    study.set_defaults(run=study_robustness)


def study_robustness(args) -> int:
    """Run (or resume) the study and write its report."""
    module, = output.study_modules("robustness", "lwrl.studies.robustness.robustness")
    started = time.perf_counter()
    output.claim_outputs(args, "out")
    outputs.check_directory(args.out, "--out")  # a study resumes in its directory
    command = shlex.join(["lwrl", *sys.argv[1:]]) if sys.argv[1:2] == ["robustness"] else \
        shlex.join(["lwrl", "robustness", *args.task])
    path = module.robustness(args.task, args.out, command, plant=args.plant, quick=args.quick,
                             agents=args.agents, episodes=args.episodes,
                             evaluation_episodes=args.evaluation_episodes, workers=args.workers)
    output.done(started, [path, f"the figures in {args.out}/figures", f"the runs in {args.out}/runs"])
    return 0
