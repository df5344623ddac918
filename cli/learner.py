"""`lwrl learner`: a learner as dependency-free C99 that goes on learning on a device.

A command of its own, not a flag of `lwrl export`: `export` turns one trained agent into a
frozen controller and takes only an agent file, while the learner starts from a task (a new
agent of `--learner` with the task's settings, each overridable here with the flags of
`lwrl train`) or resumes a saved agent, and has a RAM budget to fit (`--ram`).
"""

import os
import time

from lwrl import agent as learners
from lwrl import outputs
from lwrl.cli import fields, output
from lwrl.export import learner
from lwrl.export.c import DTYPES
from lwrl.runners.config import LearnerChoice


def add_parser(commands) -> None:
    parser = commands.add_parser("learner", help="write a learner as C99 that learns on a device",
                                 description=__doc__.split("\n\n")[0])
    parser.add_argument("source", metavar="DOMAIN.TASK|AGENTS.npz",
                        help="a task (a new agent with its settings) or a file of lwrl train "
                             "--save (that agent resumed)")
    parser.add_argument("--c", metavar="OUT_DIR", required=True,
                        help="directory for lwrl_learner.c and lwrl_learner.h")
    parser.add_argument("--agent", type=fields.non_negative_int, default=0,
                        help="which agent of a saved batch (default 0)")
    parser.add_argument("--real", choices=tuple(DTYPES), default="float",
                        help="C floating-point type of the weights and arithmetic")
    parser.add_argument("--ram", type=fields.positive_int, default=None, metavar="BYTES",
                        help="refuse a learner that needs more RAM than this")
    parser.add_argument("--force", action="store_true",
                        help="replace lwrl_learner.c and lwrl_learner.h already in OUT_DIR")
    fields.add_fields(parser, LearnerChoice, title="a new agent's learner (a task only)")
    fields.add_learner_fields(parser, learners.LEARNERS.values(),
                              title="its settings (a task only; default: the task's; in "
                                    "brackets: the learners that take each)")
    parser.add_argument("--seed", type=fields.non_negative_int, default=None,
                        help="a new agent's seed, which its random stream starts from (a task "
                             "only; default 0)")
    parser.set_defaults(run=write)


def source_of(args) -> learner.LearnerSource:
    """The agent `args` ask for: a saved one resumed, or a new one for a task."""
    settings = {**fields.given(args, LearnerChoice),
                **fields.given_learner_settings(args, learners.LEARNERS.values())}
    if args.source.endswith(".npz") or os.path.isfile(args.source):
        flags = {field.name: fields.flags_of(field)[0] for _, field in fields.cli_fields(
            LearnerChoice, *(each.settings for each in learners.LEARNERS.values()))}
        given = [flags[name] for name in settings] + (["--seed"] if args.seed is not None else [])
        if given:
            raise ValueError(f"{', '.join(given)}: a resumed agent keeps its own learner, "
                             f"settings and stream; these apply to a task")
        return learner.from_file(args.source, args.agent)
    return learner.from_task(args.source, seed=args.seed or 0, **settings)


def write(args) -> int:
    """Write the learner's C files; print the RAM it needs."""
    output.claim_outputs(args, "c")
    started = time.perf_counter()
    source = source_of(args)
    outputs.check_directory(args.c, "--c", args.force, names=(learner.SOURCE, learner.HEADER))
    written = learner.write_learner(source, args.c, args.real, ram=args.ram)
    print(f"{source.task}: {written['summary']} ({source.origin})")
    print(f"RAM: {written['ram']['total']} bytes in {args.real} ({learner.describe_ram(written['ram'])})"
          + (f", within --ram {args.ram}" if args.ram else ""))
    output.done(started, [written["source"], written["header"]])
    return 0
