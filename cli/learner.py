"""`lwrl learner`: NRBF Sarsa(lambda) as dependency-free C99 that learns on the device.

A command of its own, not a flag of `lwrl export`: `export` turns one trained agent into a
frozen controller and takes only an agent file, while the learner starts from a task (its
grid and best settings, each overridable here) or resumes a saved agent, and has a RAM
budget to fit (`--ram`).
"""

import os
import time

from lwrl import outputs
from lwrl.cli import fields, output
from lwrl.export import learner

SETTINGS = (("--n", fields.integer_at_least(2, "2 or larger"), "centroids per dimension"),
            ("--r2", fields.finite_number, "the NRBF spread r^2"),
            ("--trace", str, "replacing (eq. 6) or accumulating (eq. 2)"),
            ("--alpha", fields.finite_number, "learning rate"),
            ("--lambda", fields.finite_number, "trace decay"),
            ("--epsilon", fields.finite_number, "exploration rate"),
            ("--gamma", fields.finite_number, "discount rate"))
"""The task's settings a new learner may override (a resumed one keeps its own)."""


def add_parser(commands) -> None:
    parser = commands.add_parser("learner", help="write NRBF Sarsa(lambda) as C99 that learns on a device",
                                 description=__doc__.split("\n\n")[0])
    parser.add_argument("source", metavar="DOMAIN.TASK|AGENTS.npz",
                        help="a task (a new learner with its settings) or a file of lwrl train "
                             "--save (that agent resumed)")
    parser.add_argument("--c", metavar="OUT_DIR", required=True,
                        help="directory for lwrl_learner.c and lwrl_learner.h")
    parser.add_argument("--agent", type=fields.non_negative_int, default=0,
                        help="which agent of a saved batch (default 0)")
    parser.add_argument("--real", choices=("float", "double"), default="float",
                        help="C floating-point type of the weights and arithmetic")
    for flag, kind, meaning in SETTINGS:
        parser.add_argument(flag, type=kind, default=None, help=f"{meaning} (default: the task's)")
    parser.add_argument("--seed", type=fields.non_negative_int, default=0,
                        help="the random stream's seed of a new learner (lwrl's agent seed)")
    parser.add_argument("--ram", type=fields.positive_int, default=None, metavar="BYTES",
                        help="refuse a learner that needs more RAM than this")
    parser.add_argument("--force", action="store_true",
                        help="replace lwrl_learner.c and lwrl_learner.h already in OUT_DIR")
    parser.set_defaults(run=write)


def settings_of(args) -> learner.LearnerSettings:
    """The learner `args` ask for: a saved agent resumed, or a task's with overrides."""
    overrides = {"n": args.n, "r2": args.r2, "trace": args.trace, "alpha": args.alpha,
                 "lam": getattr(args, "lambda"), "epsilon": args.epsilon, "gamma": args.gamma}
    if args.source.endswith(".npz") or os.path.isfile(args.source):
        given = [flag for (flag, _, _), value in zip(SETTINGS, overrides.values()) if value is not None]
        if given:
            raise ValueError(f"{', '.join(given)}: a resumed agent keeps its own settings; "
                             f"these apply to a task")
        return learner.settings_from_agent(args.source, args.agent)
    return learner.settings_for_task(args.source, seed=args.seed, **overrides)


def write(args) -> int:
    """Write the learner's C files; print the RAM it needs."""
    started = time.perf_counter()
    settings = settings_of(args)
    outputs.check_directory(args.c, "--c", args.force, names=(learner.SOURCE, learner.HEADER))
    written = learner.write_learner(settings, args.c, args.real, ram=args.ram)
    grid = " x ".join([str(settings.features.n)] * settings.features.dim)
    print(f"{settings.task}: {grid} grid x {settings.num_actions} actions, {settings.trace} traces, "
          f"alpha {settings.alpha:g}, lambda {settings.lam:g}, epsilon {settings.epsilon:g} "
          f"({settings.origin})")
    print(f"RAM: {written['ram']['total']} bytes in {args.real} ({learner.describe_ram(written['ram'])})"
          + (f", within --ram {args.ram}" if args.ram else ""))
    output.done(started, [written["source"], written["header"]])
    return 0
