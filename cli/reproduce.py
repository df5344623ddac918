"""`lwrl reproduce`: the paper's figures and table, beside the paper's numbers."""

import argparse
import dataclasses
import os
import time

from lwrl import agent as learners
from lwrl import outputs
from lwrl.cli import fields, output
from lwrl.runners.config import RunConfig
from lwrl.tasks.integrators import INTEGRATORS

ITEMS = ("fig2", "fig3", "fig5", "fig6", "fig8", "table1")
"""The paper's items, as `lwrl.studies.paper.items.ITEMS` names them."""


def reading(text: str) -> tuple:
    """`NAME=VALUE` of `--set`, split (the value is read in `reading_value`)."""
    name, equals, value = text.partition("=")
    if not equals or not name or not value:
        raise argparse.ArgumentTypeError(f"must be NAME=VALUE (e.g. r2=0.05, epsilon=0, "
                                         f"track_limit=none, centroids=edges); got {text!r}")
    return name, value


def reading_value(name: str, text: str):
    """A reading's value: as its configuration field reads it (`cli.fields`), or, for a
    task's option, `none`, a number, numbers separated by commas (a tuple) or a word."""
    classes = (RunConfig, *(learner.settings for learner in learners.LEARNERS.values()))
    if name in {field.name for cls in classes for field in dataclasses.fields(cls)}:
        try:
            return fields.parse_value(classes, name, text)
        except argparse.ArgumentTypeError as error:
            raise ValueError(f"--set {error}") from None
    if text.lower() == "none":
        return None
    try:
        numbers = tuple(float(part) for part in text.split(","))
    except ValueError:
        return text
    return numbers if len(numbers) > 1 else numbers[0]


def agents_per_cell(text: str) -> int:
    """`--agents-per-cell`: an integer of at least 2 (an interval needs two agents)."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 2:
        raise argparse.ArgumentTypeError(f"must be an integer of at least 2 (an interval needs "
                                         f"two agents); got {text!r}")
    return value


def add_parser(commands) -> None:
    paper = commands.add_parser(
        "reproduce", help="reproduce the paper's figures and table",
        description="Run the paper's protocols, writing each run as it finishes (the same "
                    "command resumes an interrupted run), then the figures and a report "
                    "beside the paper's numbers.")
    paper.add_argument("item", nargs="+", choices=(*ITEMS, "all"),
                       help="one or more items, or all")
    paper.add_argument("--plant", choices=("analytic", "mujoco"), default="analytic",
                       help="plant of the tasks that have both (the others run on their one plant)")
    paper.add_argument("--integrator", choices=INTEGRATORS, default="semi_implicit",
                       help="Euler scheme of the analytic plant")
    paper.add_argument("--set", metavar="NAME=VALUE", type=reading, action="append", default=[],
                       dest="readings",
                       help="a reading of an open point for every run that has it (repeatable): "
                            "r2=0.05, epsilon=0, centroids=edges, low=A,B,.., high=A,B,.., "
                            "equations=kfnnet or a task option such as track_limit=none")
    paper.add_argument("--alphas", metavar="A,A,...", type=fields.numbers,
                       help="the NRBF runs' alpha grid instead of the items' own (the CMAC "
                            "baseline keeps its grid)")
    paper.add_argument("--agents-per-cell", metavar="N", type=agents_per_cell,
                       help="a confirmation run beside the paper-sized one: N fresh agents at "
                            "each cell the analysis chooses on the first half of the seeds "
                            "(Fig. 5, 6, 8, Table 1); the verdict is judged on them")
    paper.add_argument("--quick", action="store_true", help="tiny grids: a smoke test in seconds")
    paper.add_argument("--out", metavar="DIR", default="reproduction",
                       help="output directory (default: reproduction)")
    add_sweep_flags(paper)
    paper.set_defaults(run=reproduce_items)


def add_sweep_flags(parser) -> None:
    """The flags of a command that runs a sweep (`runners.sweep`): where its batches run."""
    parser.add_argument("--workers", type=fields.positive_int,
                        help="threads of the local backend (default: all cores)")
    parser.add_argument("--backend", choices=("local", "ray"), default="local")
    parser.add_argument("--address", help="Ray cluster address (default: start a local Ray instance)")


def reproduce_items(args) -> int:
    """Run the paper's protocols (resuming whatever an earlier run finished) and report."""
    study, = output.study_modules("reproduce", "lwrl.studies.paper.reproduce")
    started = time.perf_counter()
    readings = {name: reading_value(name, text) for name, text in args.readings}
    output.claim_outputs(args, "out")
    outputs.check_directory(args.out, "--out")  # a reproduction resumes in its directory
    path = study.reproduce(args.item, args.out, plant=args.plant, quick=args.quick,
                           integrator=args.integrator, backend=args.backend,
                           workers=args.workers, address=args.address, readings=readings,
                           alphas=args.alphas, agents_per_cell=args.agents_per_cell)
    output.done(started, [path, f"the figures in {os.path.join(args.out, 'figures')}",
                          f"each item's results under {args.out}"])
    return 0
