"""`lwrl compare`: the analytic and MuJoCo plants of a task, open loop, closed loop and in
transfer, held to the paper's item for the task where it has one."""

import os
import time

from lwrl import agent as learners
from lwrl import outputs, tasks
from lwrl.cli import fields, output
from lwrl.runners.config import RunConfig
from lwrl.runners.run import memory_needed
from lwrl.runners.summary import plural


def add_parser(commands) -> None:
    comparison = commands.add_parser(
        "compare", help="compare the analytic and MuJoCo plants of a task",
        description="Open loop (divergence from an RK4 reference, energy drift), closed loop "
                    "(the task's agent learning on each plant) and transfer (trained on one "
                    "plant, run greedily on the others), written as a report with figures.")
    comparison.add_argument("task", metavar="DOMAIN.TASK", help="a task with a MuJoCo plant: " + ", ".join(
        name for name in tasks.TASK_NAMES if "mujoco" in tasks.PLANTS[tasks.split_name(name)[0]]))
    comparison.add_argument("--seeds", type=fields.positive_int, default=10,
                            help="open-loop trials and agents per plant, seeds 0..N-1 (default 10)")
    comparison.add_argument("--episodes", type=fields.positive_int,
                            help="training episodes per agent (default: the task's)")
    comparison.add_argument("--learner", choices=learners.LEARNER_NAMES,
                            default=learners.DEFAULT_LEARNER,
                            help="the learner trained on each plant, with its settings for the "
                                 f"task (default {learners.DEFAULT_LEARNER})")
    comparison.add_argument("--out", metavar="DIR", default="compare",
                            help="output directory (default: compare)")
    comparison.add_argument("--rrd", metavar="PATH",
                            help="save a Rerun recording of the plants' trajectories from one start")
    comparison.add_argument("--quick", action="store_true",
                            help="short horizons: a smoke test in seconds")
    comparison.add_argument("--force", action="store_true",
                            help="replace the report of an earlier comparison in --out, and --rrd")
    comparison.set_defaults(run=compare_plants)


def compare_plants(args) -> int:
    """Compare the plants of a task open loop, closed loop and in transfer; write a report."""
    closed_loop, compare, paper = output.study_modules(
        "compare", "lwrl.studies.compare.closed_loop", "lwrl.studies.compare.comparison",
        "lwrl.studies.paper.items")
    started = time.perf_counter()
    compare.check_task(args.task)
    output.claim_outputs(args, "out", "rrd")
    outputs.check_directory(args.out, "--out", args.force, names=("report.md",))
    if args.rrd:
        outputs.check_file(args.rrd, "--rrd", args.force)
    episodes = compare.QUICK["episodes"] if args.quick else args.episodes
    trained = RunConfig(task=args.task, agents=args.seeds, episodes=episodes,
                        learner=args.learner)
    outputs.check_memory(len(closed_loop.PLANTS) * memory_needed(trained),
                         f"{plural(args.seeds, 'agent')} on each of {len(closed_loop.PLANTS)} plants")
    total = closed_loop.total_episodes(args.task, args.seeds, episodes,
                                       compare.QUICK["eval_episodes"] if args.quick else None,
                                       learner=args.learner)
    print(f"comparing the plants of {args.task} with seeds 0..{args.seeds - 1}"
          f"{' (quick)' if args.quick else ''}")
    bar, update = output.progress_bar(total, "closed loop")
    with bar, outputs.atomic_directory(args.out) as staging:  # the report appears whole
        result = compare.compare(args.task, seeds=args.seeds, episodes=args.episodes,
                                 out_dir=str(staging), quick=args.quick, progress=update,
                                 judge=paper.judge(args.task, args.learner),
                                 learner=args.learner)
    result.report_path = os.path.join(args.out, os.path.basename(result.report_path))
    if args.rrd:  # once the report is in place, so that a recording that fails loses nothing else
        recording = time.perf_counter()
        with outputs.atomic_path(args.rrd) as temporary:
            compare.record(args.task, result.closed_loop.replay, temporary)
        result.rrd_path, result.timings["recording"] = args.rrd, time.perf_counter() - recording
    parts = ", ".join(f"{part} {output.duration(seconds)}" for part, seconds in result.timings.items())
    output.done(started, [result.report_path, f"the tables and figures under {args.out}"]
                + ([f"the recording {args.rrd}"] if args.rrd else []), detail=parts)
    return 0
