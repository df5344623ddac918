"""`lwrl bench`: the light-weight claim's benchmark.

    lwrl bench run TASK... [--plant P] [--out DIR] ...   the second benchmark (FINDINGS'
                                                         reviewer's rule), resumable
    lwrl bench status TASK... [--plant P] [--out DIR]    how far it has got (read only)
    lwrl bench report DIR [--plant P]                    its report rewritten from DIR alone
    lwrl bench evaluate TASK --policy M:F --learner NAME the protocol's greedy episodes of any
                                                         library's policy, as a results file
    lwrl bench score RESULTS... [--out DIR] [--replace]  an outside learner's results, checked
                                                         and placed in that benchmark
    lwrl bench export DIR --parquet OUT                  its runs as one Parquet dataset with
                                                         a data card

The first benchmark (docs/benchmark) is an archive: its report, costs and controllers are
kept, its code is in lwrl's history (docs/benchmark/README.md names the commits).
"""

import importlib
import os
import pathlib
import shlex
import sys
import time

import lwrl
from lwrl import outputs
from lwrl.agent import io as agent_io
from lwrl.cli import bench_export, output, reproduce
from lwrl.cli.output import Parser

SECOND = "benchmark2"
"""The second benchmark's default directory."""
COMMITTED = {"analytic": "docs/benchmark2", "mujoco": "docs/benchmark2/mujoco"}
"""The committed second benchmark of each plant, in lwrl's checkout."""


def add_parser(commands) -> None:
    bench = commands.add_parser(
        "bench", help="the light-weight claim's benchmark: every learner under one protocol",
        description="The light-weight claim's benchmark. `run`: the second benchmark, by "
                    "docs/FINDINGS.md's rule (one budget of steps per task, greedy "
                    "evaluations, random and classical rows, the same search for every "
                    "learner, 20 agents, Holm-corrected tests, the not-judged gate). "
                    "`status`: how far it has got. `report`: its report rewritten from its "
                    "directory alone. `evaluate`: any library's policy evaluated as the "
                    "protocol evaluates every row. `score`: an outside learner's results "
                    "placed in it. `export`: its runs as one Parquet dataset.")
    actions = bench.add_subparsers(dest="action", required=True, metavar="ACTION",
                                   parser_class=Parser)
    add_run(actions)
    add_status(actions)
    add_report(actions)
    add_evaluate(actions)
    add_score(actions)
    bench_export.add_export(actions)


def add_plant(parser) -> None:
    """`--plant`: the plant of the tasks that have both."""
    parser.add_argument("--plant", choices=("analytic", "mujoco"), default="analytic",
                        help="plant of the tasks that have both")


def add_plant_and_out(parser, out: str, what: str) -> None:
    """`--plant` and `--out DIR` (default `out`, described as `what`)."""
    add_plant(parser)
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
        actions, "run", "the second benchmark (resumable), or the third (--rule 3)",
        "Run (or resume) the second benchmark on the tasks: the reference rows, every row's "
        "search, the chosen configurations at each fraction of the budget, their greedy "
        "evaluations and costs; then the report with the verdicts, the aggregates across "
        "tasks and the figures. Runs are written as they finish: the same command resumes, "
        "on a fresh clone from the committed tables. With --rule 3, or in a directory that "
        "records it (rule.json), the third benchmark (studies/paper/benchmark/third).",
        TASKS, "output directory", run_second)
    run.add_argument("--rule", choices=("2", "3"),
                     help="the benchmark's rule (default: the one --out records, else 2)")
    run.add_argument("--no-report", dest="report", action="store_false",
                     help="compute and keep the runs only (`lwrl bench report DIR` writes the "
                          "report from them)")
    reproduce.add_sweep_flags(run)


THIRD = "lwrl.studies.paper.benchmark.third.benchmark"
"""The third benchmark's commands, for a directory that records its rule (`third.rule`)."""


def figures(directory: str) -> list:
    """The line of `output.done` naming a benchmark's figures, where it drew any (the third
    benchmark's report has none yet)."""
    path = os.path.join(directory, "figures")
    return [f"the figures in {path}"] if os.path.isdir(path) else []


def third(directory: str, asked=None):
    """The third benchmark's module where `asked` is "3" or `directory` records its rule,
    else None (the second's)."""
    rule, = output.study_modules("bench", "lwrl.studies.paper.benchmark.third.rule")
    if asked == "2" and rule.edition(directory) is not None:
        raise ValueError(f"{directory} records the rule {rule.edition(directory)} "
                         f"({rule.EDITION_FILE}); --rule 2 runs the second benchmark in a "
                         "directory of its own")
    if asked == "3" or rule.edition(directory) is not None:
        return output.study_modules("bench", THIRD)[0]
    return None


def add_status(actions) -> None:
    add_second(
        actions, "status", "how far the second benchmark has got in its directory (read only)",
        "Print, per task, whether the reference rows are written, each row's search "
        "trainings and greedy evaluations done, the configuration it chose and its rows' "
        "trainings and evaluations, then what the ledger counts: what `lwrl bench run` with "
        "the same tasks has left to do. Nothing is run or written.", TASKS,
        "the benchmark's directory", run_status)


def add_report(actions) -> None:
    report = actions.add_parser(
        "report", help="the second benchmark's report rewritten from its directory alone",
        description="Rewrite the report (README.md, its figures, configs.jsonl) of the "
                    "benchmark directory DIR from what it holds, computing nothing: every task "
                    "with runs there, every outside row. A task whose runs are not all written "
                    "is named in the report as such and not judged. A benchmark directory holds "
                    "configs.jsonl and a task's reference rows (references/TASK-PLANT.csv.gz), "
                    "as `lwrl bench run` writes them.")
    report.add_argument("directory", metavar="DIR", help="the benchmark's directory")
    add_plant(report)
    report.set_defaults(run=run_report)


def add_evaluate(actions) -> None:
    evaluate = actions.add_parser(
        "evaluate", help="any library's policy evaluated by the protocol, as a results file",
        description="Run the second benchmark's greedy evaluation episodes (each agent's 10 "
                    "episodes from the starts of its seed + 10000, capped at 1000 steps on the "
                    "tasks measured in steps, the task's own episodes on the others) for a "
                    "policy of any library, and write the results file `lwrl bench score` "
                    "takes, with the protocol's version and the digest of the starts it ran "
                    "from. A policy is a function of observations (a batch (n, d), or one (d,)) "
                    "giving actions (an index; u in [-1, 1] on a continuous task), an object "
                    "with Stable-Baselines3's predict, or the saved agents of a learner of "
                    "lwrl's registry (studies/paper/benchmark/harness.py).")
    evaluate.add_argument("task", metavar="TASK", help="the benchmark task (DOMAIN.TASK, or "
                          "DOMAIN.TASK-continuous)")
    given = evaluate.add_mutually_exclusive_group(required=True)
    given.add_argument("--policy", metavar="MODULE:NAME",
                       help="the policy every agent acts by, at every fraction of the budget")
    given.add_argument("--agents", metavar="MODULE:NAME",
                       help="a function (seed, fraction) -> the policy of the agent of that seed "
                            "after that fraction of the budget (seeds 0 to 19; fractions 0.1, "
                            "0.25, 0.5, 1)")
    given.add_argument("--saved", metavar="FRACTION=FILE", action="append",
                       help="the saved agents (lwrl train --save) of seeds 0 to 19 after that "
                            "fraction of the budget, once per fraction")
    evaluate.add_argument("--learner", metavar="NAME", required=True,
                          help="the learner's name in the benchmark (letters, digits, _ . -)")
    add_plant(evaluate)
    evaluate.add_argument("--out", metavar="FILE",
                          help="the results file (default: LEARNER-TASK.csv.gz)")
    evaluate.add_argument("--force", action="store_true", help="replace --out if it exists")
    evaluate.set_defaults(run=run_evaluate)


def add_score(actions) -> None:
    score = actions.add_parser(
        "score", help="an outside learner's results, checked and placed in the benchmark",
        description="Check results files of a learner outside lwrl's registry against the "
                    "second benchmark's protocol (one CSV row per greedy evaluation episode: "
                    "learner, task, budget, fraction, seed, episode, steps, uptime_s, protocol, "
                    "starts, as `lwrl bench evaluate` writes them; "
                    "studies/paper/benchmark/outside.py), print their normalised scores, and "
                    "keep them in the benchmark's directory, whose report lists them in its "
                    "leaderboard (`lwrl bench report DIR`). A refused file changes nothing.")
    score.add_argument("results", metavar="RESULTS", nargs="+", help="results files (CSV, .gz)")
    add_plant(score)
    committed = {plant: committed_benchmark(plant) for plant in COMMITTED}
    score.add_argument("--out", metavar="DIR",
                       help="the benchmark directory (configs.jsonl and references/, as `lwrl "
                            "bench run` writes them; default, in lwrl's checkout: "
                            f"{' or '.join(COMMITTED.values())} by --plant"
                            + ("" if all(committed.values()) else "; required here") + ")")
    score.add_argument("--replace", action="store_true",
                       help="replace a learner's results already scored on its task")
    score.set_defaults(run=run_score)


def committed_benchmark(plant: str):
    """The committed second benchmark on `plant` (`COMMITTED`) where lwrl runs from its
    checkout, else None."""
    path = pathlib.Path(lwrl.__file__).resolve().parent.parent / COMMITTED[plant]
    return str(path) if (path / "configs.jsonl").is_file() else None


def run_second(args) -> int:
    """Run (or resume) the second benchmark and write its report."""
    module, protocol = output.study_modules("bench", "lwrl.studies.paper.benchmark.benchmark",
                                            "lwrl.studies.paper.benchmark.protocol")
    started = time.perf_counter()
    newer = third(args.out, args.rule)
    if newer is not None:
        module, tasks = newer, newer.check(args.tasks, args.plant)
    else:
        tasks = protocol.tasks_on(args.plant) if args.tasks == ["all"] else args.tasks
        for task in tasks:
            protocol.check_task(task, args.plant)
    output.claim_outputs(args, "out")
    outputs.check_directory(args.out, "--out")  # a benchmark resumes in its directory
    path = module.benchmark(tasks, args.out, shlex.join(["lwrl", *args.argv]), plant=args.plant,
                            sweep={"backend": args.backend, "workers": args.workers,
                                   "address": args.address}, with_report=args.report)
    output.done(started, [path, *figures(args.out)] if args.report else
                [f"the runs in {args.out} (`lwrl bench report {args.out}` writes the report)"])
    return 0


def run_status(args) -> int:
    """Print how far the benchmark in `--out` has got."""
    newer = third(args.out)
    if newer is not None:
        print("\n".join(newer.status(args.tasks, args.out, args.plant)))
        return 0
    module, protocol = output.study_modules("bench", "lwrl.studies.paper.benchmark.progress",
                                            "lwrl.studies.paper.benchmark.protocol")
    tasks = protocol.tasks_on(args.plant) if args.tasks == ["all"] else args.tasks
    for task in tasks:
        protocol.check_task(task, args.plant)
    for line in module.lines(tasks, args.out, args.plant):
        print(line)
    return 0


def run_report(args) -> int:
    """Rewrite the report of the benchmark in DIR from what it holds."""
    module = third(args.directory)
    if module is None:
        module, = output.study_modules("bench", "lwrl.studies.paper.benchmark.benchmark")
        module.check_benchmark(args.directory, args.plant)
    outputs.claim_output(args.directory, "DIR")
    started = time.perf_counter()
    path = module.rebuild(args.directory, shlex.join(["lwrl", *args.argv]), plant=args.plant)
    output.done(started, [path, *figures(args.directory)])
    return 0


def named(text: str, flag: str):
    """The object `MODULE:NAME` names (the current directory importable), or a one-line
    ValueError."""
    module, _, name = text.partition(":")
    if not module or not name:
        raise ValueError(f"{flag} must be MODULE:NAME (e.g. mypolicy:act); got {text!r}")
    if os.getcwd() not in sys.path:
        sys.path.insert(0, os.getcwd())
    try:
        found = importlib.import_module(module)
    except ImportError as error:
        raise ValueError(f"{flag}: cannot import {module} ({type(error).__name__}: {error})") from None
    try:
        for part in name.split("."):
            found = getattr(found, part)
    except AttributeError:
        raise ValueError(f"{flag}: {module} has no {name}") from None
    return found


def saved_files(given, fractions) -> dict:
    """`{fraction: file}` of `--saved FRACTION=FILE` given once for each of `fractions`, or a
    one-line ValueError."""
    files = {}
    for text in given:
        fraction, _, path = text.partition("=")
        try:
            files[float(fraction)] = path
        except ValueError:
            raise ValueError(f"--saved must be FRACTION=FILE; got {text!r}") from None
    if sorted(files) != sorted(fractions) or len(files) != len(given):
        raise ValueError(f"--saved must give one file for each fraction "
                         f"{', '.join(f'{f:g}' for f in fractions)}; got "
                         f"{', '.join(f'{f:g}' for f in files) or 'none'}")
    return files


def run_evaluate(args) -> int:
    """Evaluate a policy by the protocol and write its results file."""
    harness, outside, protocol = output.study_modules(
        "bench", "lwrl.studies.paper.benchmark.harness", "lwrl.studies.paper.benchmark.outside",
        "lwrl.studies.paper.benchmark.protocol")
    protocol.check_task(args.task, args.plant)
    outside.check_name(args.learner, "--learner")
    out = args.out or f"{args.learner}-{args.task}.csv.gz"
    outputs.check_file(out, "--out", args.force)
    started = time.perf_counter()
    if args.policy:
        policy = named(args.policy, "--policy")
        evaluations = [harness.evaluate(policy, args.task, None, fraction, args.plant)
                       for fraction in protocol.FRACTIONS]
    elif args.saved:
        evaluations = [harness.evaluate(agent_io.load(path)[0], args.task, None, fraction,
                                        args.plant)
                       for fraction, path in saved_files(args.saved, protocol.FRACTIONS).items()]
    else:
        agents = named(args.agents, "--agents")
        evaluations = [harness.evaluate(agents(seed, fraction), args.task, seed, fraction,
                                        args.plant)
                       for fraction in protocol.FRACTIONS for seed in range(protocol.AGENTS)]
    outputs.write_table(harness.results(evaluations, args.learner), out)
    output.done(started, [out])
    return 0


def run_score(args) -> int:
    """Check outside results, print their scores, keep them for the report."""
    module, = output.study_modules("bench", "lwrl.studies.paper.benchmark.benchmark")
    if args.out is None:
        args.out = committed_benchmark(args.plant)
        if args.out is None:
            raise ValueError("--out: give the benchmark directory (lwrl runs from no checkout "
                             "holding the committed benchmark)")
    module.check_benchmark(args.out, args.plant)
    output.claim_outputs(args, "out")
    for line in module.score(args.results, args.out, plant=args.plant, replace=args.replace):
        print(line)
    return 0
