"""`lwrl bench`: every learner under the paper's protocol, with what each costs."""

import os
import shlex
import time

from lwrl import outputs
from lwrl.cli import output, reproduce


def add_parser(commands) -> None:
    bench = commands.add_parser(
        "bench", help="every learner under one protocol, with its costs (the light-weight claim)",
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
    bench.add_argument("--plant", choices=("analytic", "mujoco"), default="analytic",
                       help="plant of the tasks that have both")
    bench.add_argument("--agents-per-cell", metavar="N", type=reproduce.agents_per_cell, default=5,
                       help="agents per learner and task (seeds 0 to N-1; default 5)")
    bench.add_argument("--quick", action="store_true", help="tiny episodes and budgets: a smoke test (minutes, most of it the costs)")
    bench.add_argument("--out", metavar="DIR", default="benchmark",
                       help="output directory (default: benchmark)")
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
