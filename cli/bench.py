"""`lwrl bench`: the light-weight claim's benchmark.

    lwrl bench run TASK... [--plant P] [--out DIR] ...   the second benchmark (FINDINGS'
                                                         reviewer's rule), resumable
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

ACTIONS = ("run", "score", "first")
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
                    "`score`: an outside learner's results placed in it. `first`: the first "
                    "benchmark (`lwrl bench TASK...`).")
    actions = bench.add_subparsers(dest="action", required=True, metavar="ACTION",
                                   parser_class=Parser)
    add_run(actions)
    add_score(actions)
    add_first(actions)


def add_plant_and_out(parser, out: str, what: str) -> None:
    """`--plant` and `--out DIR` (default `out`, described as `what`)."""
    parser.add_argument("--plant", choices=("analytic", "mujoco"), default="analytic",
                        help="plant of the tasks that have both")
    parser.add_argument("--out", metavar="DIR", default=out, help=f"{what} (default: {out})")


def add_run(actions) -> None:
    run = actions.add_parser(
        "run", help="the second benchmark (resumable)",
        description="Run (or resume) the second benchmark on the tasks: the reference rows, "
                    "every row's search, the chosen configurations at each fraction of the "
                    "budget, their greedy evaluations and costs; then the report with the "
                    "verdicts, the aggregates across tasks and the figures. Runs are written "
                    "as they finish: the same command resumes, on a fresh clone from the "
                    "committed tables.")
    run.add_argument("tasks", metavar="TASK", nargs="+",
                     help="tasks (DOMAIN.TASK, or DOMAIN.TASK-continuous for one made with "
                          "continuous actions), or all (those whose domain has --plant)")
    add_plant_and_out(run, SECOND, "output directory")
    reproduce.add_sweep_flags(run)
    run.set_defaults(run=run_second)


def add_score(actions) -> None:
    score = actions.add_parser(
        "score", help="an outside learner's results, checked and placed in the benchmark",
        description="Check results files of a learner outside lwrl's registry against the "
                    "second benchmark's protocol (one CSV row per greedy evaluation episode: "
                    "learner, task, budget, fraction, seed, episode, steps, uptime_s; "
                    "studies/paper/benchmark/outside.py), print their normalised scores, and "
                    "keep them in the benchmark's directory, whose report places them.")
    score.add_argument("results", metavar="RESULTS", nargs="+", help="results files (CSV, .gz)")
    add_plant_and_out(score, SECOND, "the benchmark's directory")
    score.set_defaults(run=run_score)


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


def run_score(args) -> int:
    """Check outside results, print their scores, keep them for the report."""
    module, = output.study_modules("bench", "lwrl.studies.paper.benchmark.benchmark")
    output.claim_outputs(args, "out")
    for line in module.score(args.results, args.out, plant=args.plant):
        print(line)
    return 0
