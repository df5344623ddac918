"""`lwrl robustness`: how far from the paper's plant the learned controllers still work."""

import shlex
import time

from lwrl import outputs, tasks
from lwrl.cli import fields, output, reproduce

OUT = "robustness"
"""The default output directory."""


def add_parser(commands) -> None:
    study = commands.add_parser(
        "robustness", help="evaluate trained controllers away from the paper's plant",
        description="Train every learner that fits each task (a learner of continuous "
                    "actions on the task made with them) on the paper's plant and with "
                    "randomised physics, then run them greedily over a grid of the domain's "
                    "robustness parameters, observation noise and actuation delays, with the "
                    "exported C controllers beside them; write a map figure per task and a "
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
    study.add_argument("--learners", metavar="L,L,...", type=lambda text: text.split(","),
                       help="learners to train, by their registry names (default: every one "
                            "that fits each task)")
    study.add_argument("--out", metavar="DIR", default=OUT,
                       help=f"output directory (default: {OUT})")
    reproduce.add_sweep_flags(study)
    study.add_argument("--quick", action="store_true", help="tiny grids: a smoke test in seconds")
    study.set_defaults(run=study_robustness)


def command_line(args) -> str:
    """The command that makes this study again, as the report names it: the tasks and every
    option away from its default, where its batches run aside (that changes no number)."""
    words = ["lwrl", "robustness", *args.task]
    if args.plant != "analytic":
        words += ["--plant", args.plant]
    for name in ("agents", "episodes", "evaluation_episodes"):
        if getattr(args, name) is not None:
            words += ["--" + name.replace("_", "-"), str(getattr(args, name))]
    if args.learners is not None:
        words += ["--learners", ",".join(args.learners)]
    if args.quick:
        words.append("--quick")
    if args.out != OUT:
        words += ["--out", args.out]
    return shlex.join(words)


def study_robustness(args) -> int:
    """Run (or resume) the study and write its report."""
    module, budgets = output.study_modules("robustness", "lwrl.studies.robustness.robustness",
                                           "lwrl.studies.paper.episode_budgets")
    started = time.perf_counter()
    output.claim_outputs(args, "out")
    outputs.check_directory(args.out, "--out")  # a study resumes in its directory
    path = module.robustness(args.task, args.out, command_line(args), plant=args.plant, quick=args.quick,
                             agents=args.agents, episodes=args.episodes,
                             evaluation_episodes=args.evaluation_episodes, learners=args.learners,
                             sweep={"backend": args.backend, "workers": args.workers,
                                    "address": args.address},
                             stepped=budgets.episode_budgets())  # DQN, PPO: the first benchmark's
    output.done(started, [path, f"the figures in {args.out}/figures", f"the runs in {args.out}/runs"])
    return 0
