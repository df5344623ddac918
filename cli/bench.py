"""`lwrl bench`: the light-weight claim's benchmark.

    lwrl bench run TASK... [--plant P] [--out DIR] ...   the second benchmark (FINDINGS'
                                                         reviewer's rule), resumable
    lwrl bench status TASK... [--plant P] [--out DIR]    how far it has got (read only)
    lwrl bench score RESULTS... [--out DIR]              an outside learner's results, checked
                                                         and placed in that benchmark
    lwrl bench first TASK... [--learners ...] ...        the first benchmark, kept with its
                                                         report; `lwrl bench TASK...` is it
"""

import os
import shlex
import time

from lwrl import outputs
from lwrl.cli import output, reproduce
from lwrl.cli.output import Parser

ACTIONS = ("run", "status", "score", "first")
SECOND = "benchmark2"
"""The second benchmark's default directory."""


def legacy(argv: list) -> list:
    """`lwrl bench TASK...` as it was written before `bench` had actions: `lwrl bench first
    TASK...` (the first benchmark's reports name their command so)."""
    if len(argv) > 1 and argv[0] == "bench" and argv[1] not in ACTIONS and not argv[1].startswith("-"):
        return ["bench", "first", *argv[1:]]
    return argv


def add_parser(commands) -> None:
    bench = commands.add_parser(
        "bench", help="the light-weight claim's benchmark: every learner under one protocol",
        description="The light-weight claim's benchmark. `run`: the second benchmark, by "
                    "docs/FINDINGS.md's rule (one budget of steps per task, greedy "
                    "evaluations, random and classical rows, the same search for every "
                    "learner, 20 agents, Holm-corrected tests, the not-judged gate). "
                    "`status`: how far it has got. `score`: an outside learner's results "
                    "placed in it. `first`: the first "
                    "benchmark (`lwrl bench TASK...`).")
    actions = bench.add_subparsers(dest="action", required=True, metavar="ACTION",
                                   parser_class=Parser)
    add_run(actions)
    add_status(actions)
    add_score(actions)
    add_first(actions)


def add_plant_and_out(parser, out: str, what: str) -> None:
    """`--plant` and `--out DIR` (default `out`, described as `what`)."""
    parser.add_argument("--plant", choices=("analytic", "mujoco"), default="analytic",
                        help="plant of the tasks that have both")
    parser.add_argument("--out", metavar="DIR", default=out, help=f"{what} (default: {out})")


TASKS = ("tasks", "TASK", "tasks (DOMAIN.TASK, or DOMAIN.TASK-continuous for one made with "
         "continuous actions), or all (those whose domain has --plant)")
"""The positional argument of `run` and `status`: (name, metavar, help)."""


def add_second(actions, name: str, summary: str, description: str, positional: tuple,
               directory: str, run):
    """One action on the second benchmark's directory: its `positional` argument (name,
    metavar, help; one or more), `--plant`, `--out` (described as `directory`), and `run`."""
    parser = actions.add_parser(name, help=summary, description=description)
    dest, metavar, text = positional
    parser.add_argument(dest, metavar=metavar, nargs="+", help=text)
    add_plant_and_out(parser, SECOND, directory)
    parser.set_defaults(run=run)
    return parser


def add_run(actions) -> None:
    run = add_second(
        actions, "run", "the second benchmark (resumable)",
        "Run (or resume) the second benchmark on the tasks: the reference rows, every row's "
        "search, the chosen configurations at each fraction of the budget, their greedy "
        "evaluations and costs; then the report with the verdicts, the aggregates across "
        "tasks and the figures. Runs are written as they finish: the same command resumes, "
        "on a fresh clone from the committed tables.", TASKS, "output directory", run_second)
    reproduce.add_sweep_flags(run)


def add_status(actions) -> None:
    add_second(
        actions, "status", "how far the second benchmark has got in its directory (read only)",
        "Print, per task, whether the reference rows are written, each row's search "
        "trainings and greedy evaluations done, the configuration it chose and its rows' "
        "trainings and evaluations, then what the ledger counts: what `lwrl bench run` with "
        "the same tasks has left to do. Nothing is run or written.", TASKS,
        "the benchmark's directory", run_status)


def add_score(actions) -> None:
    add_second(
        actions, "score", "an outside learner's results, checked and placed in the benchmark",
        "Check results files of a learner outside lwrl's registry against the second "
        "benchmark's protocol (one CSV row per greedy evaluation episode: learner, task, "
        "budget, fraction, seed, episode, steps, uptime_s; "
        "studies/paper/benchmark/outside.py), print their normalised scores, and keep them "
        "in the benchmark's directory, whose report places them.",
        ("results", "RESULTS", "results files (CSV, .gz)"), "the benchmark's directory",
        run_score)


def add_first(actions) -> None:
    bench = actions.add_parser(
        "first", help="the first benchmark, with its costs",
        description="Run every learner of the registry on the tasks under one protocol (the "
                    "same seeds, episodes and starts), measure what each costs, and write the "
                    "report with per-task tables, Pareto figures and learning curves. The same "
                    "command resumes an interrupted run.")
    bench.add_argument("tasks", metavar="TASK", nargs="+",
                       help="tasks of the benchmark (DOMAIN.TASK), or all")
    bench.add_argument("--learners", metavar="L,L,...", type=lambda text: text.split(","),
                       help="learner rows to run (default: all of each task's): paper, "
                            "sarsa-accumulating, sarsa-replacing, true_online_sarsa, cmac, "
                            "ase_ace, dqn, ppo, dqn_jax, ppo_jax")
    bench.add_argument("--agents-per-cell", metavar="N", type=reproduce.agents_per_cell, default=5,
                       help="agents per learner and task (seeds 0 to N-1; default 5)")
    bench.add_argument("--quick", action="store_true", help="tiny episodes and budgets: a smoke test (minutes, most of it the costs)")
    add_plant_and_out(bench, "benchmark", "output directory")
    reproduce.add_sweep_flags(bench)
    bench.set_defaults(run=run_bench)


def run_bench(args) -> int:
    study, protocol = output.study_modules("bench", "lwrl.studies.paper.bench",
                                           "lwrl.studies.paper.bench_protocol")
    started = time.perf_counter()
    tasks = list(protocol.TASKS) if args.tasks == ["all"] else args.tasks
    output.claim_outputs(args, "out")
    outputs.check_directory(args.out, "--out")  # a benchmark resumes in its directory
    command = shlex.join(["lwrl", *args.argv])
    path = study.bench(tasks, args.learners, args.out, plant=args.plant,
                       agents=args.agents_per_cell, quick=args.quick, backend=args.backend,
                       workers=args.workers, address=args.address, command=command)
    output.done(started, [path, f"the figures in {os.path.join(args.out, 'figures')}"])
    return 0


def run_second(args) -> int:
    """Run (or resume) the second benchmark and write its report."""
    module, protocol = output.study_modules("bench", "lwrl.studies.paper.benchmark.benchmark",
                                            "lwrl.studies.paper.benchmark.protocol")
    started = time.perf_counter()
    tasks = protocol.tasks_on(args.plant) if args.tasks == ["all"] else args.tasks
    for task in tasks:
        protocol.check_task(task, args.plant)
    output.claim_outputs(args, "out")
    outputs.check_directory(args.out, "--out")  # a benchmark resumes in its directory
    path = module.benchmark(tasks, args.out, shlex.join(["lwrl", *args.argv]), plant=args.plant,
                            sweep={"backend": args.backend, "workers": args.workers,
                                   "address": args.address})
    output.done(started, [path, f"the figures in {os.path.join(args.out, 'figures')}"])
    return 0


def run_status(args) -> int:
    """Print how far the benchmark in `--out` has got."""
    module, protocol = output.study_modules("bench", "lwrl.studies.paper.benchmark.progress",
                                            "lwrl.studies.paper.benchmark.protocol")
    tasks = protocol.tasks_on(args.plant) if args.tasks == ["all"] else args.tasks
    for task in tasks:
        protocol.check_task(task, args.plant)
    for line in module.lines(tasks, args.out, args.plant):
        print(line)
    return 0


def run_score(args) -> int:
    """Check outside results, print their scores, keep them for the report."""
    module, = output.study_modules("bench", "lwrl.studies.paper.benchmark.benchmark")
    output.claim_outputs(args, "out")
    for line in module.score(args.results, args.out, plant=args.plant):
        print(line)
    return 0
