"""What a search saves by training its configurations of one program as one population.

The third benchmark's search (`studies/paper/benchmark/third/halving.py`) trains 32
configurations of each row; those of a JAX population learner that differ only in settings
each agent may have of its own (its step size) run one program (`halving.programs`), and
`lwrl bench run` trains them as one batch (`runners.sweep.populations`). For each row of
`--rows` on `--task`, one run of this script takes the row's largest group of such
configurations (at most `--configurations` of them), their first rung's runs (2 agents each)
cut to `--budget` steps per agent, and measures the CPU time (`time.process_time`) of:

1. **alone**: each run computed as a batch of its own (`runners.sweep.run_batch`), one after
   another, as `lwrl bench run` computed the rows' searches before the populations;
2. **one population**: all of them as one batch.

Both programs are compiled first (a run of 50 steps each way, not timed), so the times are
of computing only. Each run's table must be the same both ways (an agent's numbers do not
depend on the others of its batch): the table says so. Ratios compare times measured in the
same run of this script.

Run from the repository root:

    python -m benchmarks.search_populations              # a few minutes
    python -m benchmarks.search_populations --quick      # smoke test
"""

import argparse
import dataclasses
import time

from lwrl.runners import sweep
from lwrl.studies.paper.benchmark.third import halving, rule


def group(task: str, label: str, count: int, budget: int) -> list:
    """The first rung's runs of the row `label`'s largest batch of one program on `task`
    (`sweep.batches`, as `halving.programs` counts them), at most `count`, cut to `budget`
    steps per agent."""
    row = {row.label: row for row in rule.rows(task)}[label]
    largest = max(sweep.batches(halving.first_rung(task, row)), key=len)
    return [dataclasses.replace(run, budget=budget) for run in largest[:count]]


def cpu_of(batches) -> tuple:
    """`(CPU seconds, {run key: table})` of computing `batches` one after another."""
    started, tables = time.process_time(), {}
    for batch in batches:
        for config, (table, _) in zip(batch, sweep.run_batch(batch)):
            tables[config.key] = table
    return time.process_time() - started, tables


def measure(task: str, label: str, count: int, budget: int) -> str:
    """One row of the table: the row's runs alone and as one population."""
    runs = group(task, label, count, budget)
    for warm_up in ([[dataclasses.replace(run, budget=50)] for run in runs[:1]],
                    [[dataclasses.replace(run, budget=50) for run in runs]]):
        cpu_of(warm_up)
    alone_s, alone = cpu_of([[run] for run in runs])
    joined_s, joined = cpu_of([runs])
    same = all(alone[run.key].equals(joined[run.key]) for run in runs)
    steps = sum(int(table["steps"].sum()) for table in alone.values())
    return (f"| {label} | {len(runs)} x {runs[0].agents} | {steps} | {alone_s:.1f} | "
            f"{joined_s:.1f} | {alone_s / joined_s:.2f} | {'yes' if same else 'NO'} |")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="cartpole.balance")
    parser.add_argument("--rows", nargs="+", default=["ars", "stream_q", "stream_ac"],
                        help="the rows of the third benchmark to measure (their labels)")
    parser.add_argument("--configurations", type=int, default=8)
    parser.add_argument("--budget", type=int, default=4000, help="steps per agent")
    parser.add_argument("--quick", action="store_true",
                        help="smoke test: ARS, 2 configurations, 200 steps")
    args = parser.parse_args(argv)
    if args.quick:
        args.rows, args.configurations, args.budget = ["ars"], 2, 200
    print(f"{args.task}, the search's first rung cut to {args.budget} steps per agent:\n")
    print("| row | runs x agents | agent-steps | CPU s alone | CPU s as one population "
          "| alone / one | tables the same |")
    print("|---|---|---|---|---|---|---|")
    for label in args.rows:
        print(measure(args.task, label, args.configurations, args.budget), flush=True)


if __name__ == "__main__":
    main()
