"""The numbers the third benchmark's rule is planned from (docs/FINDINGS.md, "The light-weight
claim judged a third time: the third benchmark's rule"), read from a finished benchmark's
committed tables (the second's, docs/benchmark2): per task and row, the standard deviation
of the agents' final normalised scores, how many sit at the classical level, the smallest
difference from the light-weight row that the one-sided test detects with 80 % power at the
benchmark's agents per row at the level the third benchmark's procedure starts it at
(alpha / `FAMILY`), and the agents a row needs to show non-inferiority at the margin
(`analysis.power`); and the third benchmark's compute, planned from its ledger
(`compute_plan`).

    python -m lwrl.studies.paper.benchmark.planning docs/benchmark2 [--margin M]
        [--family K] [--agents N] [--light-agents N] [--plant P] [--variants TASK...]

reads the runs only (`study.study_task` resumes from the committed tables and runs nothing
where they are all there) and prints the tables in Markdown.
"""

import argparse
import dataclasses
import math
import sys

import numpy as np

from lwrl.analysis import power
from lwrl.studies.paper.benchmark import compute_plan, protocol, study

MARGIN = 0.1
"""The non-inferiority margin on the normalised score the third benchmark's rule fixes."""
FAMILY = 78
"""The hypotheses the third benchmark's graphical Holm procedure starts with, each at
alpha / FAMILY: "not worse" and "worse" for each of its 39 comparisons (the four discrete
tasks and the three variants, each against five rivals: DQN, PPO, ARS, stream-Q(lambda),
stream-AC(lambda); the continuous pendulum against four: SAC, TD3, ARS, stream-AC(lambda)).
"Better" starts with none: it takes the level of its comparison's "not worse" once that is
shown."""
SATURATED = 0.99
"""A final normalised score at or above which an agent counts as at the classical level."""


@dataclasses.dataclass(frozen=True)
class RowPlan:
    """One row of one task: its agents' final normalised scores' spread, the share at the
    classical level at each fraction of the budget, and against the light-weight row the
    difference detectable with `agents` agents a row and the agents needed at the margin."""

    task: str
    row: str
    agents: int
    mean: float
    sd: float
    saturated: dict
    """`{fraction: agents with a normalised score >= SATURATED}`."""
    detectable: float = math.nan
    """The smallest difference the one-sided test detects with `power.POWER`, NaN for the
    light-weight row itself."""
    needed: float = math.nan
    """The agents per row for non-inferiority at the margin with `power.POWER` where the true
    difference is 0; inf where more than `power.MOST_AGENTS`, NaN for the light-weight row."""


def plan_task(runs: study.TaskRuns, agents: int, margin: float = MARGIN,
              family: int = FAMILY, alpha: float = 0.05, light_agents: int | None = None) -> list:
    """`RowPlan` of every row of `runs` (a finished task's `study.TaskRuns`), the light-weight
    row first, each rival's against it with `agents` agents a rival row and `light_agents`
    (default `agents`) in the light-weight row."""
    final = protocol.FRACTIONS[-1]
    light = protocol.light(runs.task)
    labels = [label for label, fraction in runs.scores if fraction == final]
    labels = [light] + [label for label in labels if label != light]
    sd_light = spread(runs.scores[light, final])
    plans = []
    for label in labels:
        values = np.asarray(runs.scores[label, final], dtype=float)
        saturated = {fraction: int(np.sum(np.asarray(runs.scores[label, fraction]) >= SATURATED))
                     for fraction in protocol.FRACTIONS if (label, fraction) in runs.scores}
        plan = RowPlan(runs.task, label, len(values), float(np.mean(values)), spread(values),
                       saturated)
        if label != light:
            sd = plan.sd
            try:
                needed = power.agents_needed(sd_light, sd, margin, alpha=alpha, family=family)
            except ValueError:
                needed = math.inf
            plan = dataclasses.replace(
                plan, detectable=power.detectable_difference(sd_light, sd, light_agents or agents,
                                                             agents, alpha, family),
                needed=needed)
        plans.append(plan)
    return plans


def spread(values) -> float:
    """The standard deviation (n - 1) of the agents' scores."""
    return float(np.std(np.asarray(values, dtype=float), ddof=1))


def table(plans: list, agents: int, margin: float, family: int, light_agents: int) -> str:
    """The plans as a Markdown table."""
    lines = [f"| task | row | mean | sd | at the classical level (of {plans[0].agents if plans else 0}) "
             f"at {', '.join(f'{f:g}' for f in protocol.FRACTIONS)} | detectable at {agents} a "
             f"rival row, {light_agents} light-weight "
             f"(at 0.05 / {family}) | agents for margin {margin:g} |",
             "|---|---|---|---|---|---|---|"]
    for plan in plans:
        shares = " / ".join(str(plan.saturated.get(f, "—")) for f in protocol.FRACTIONS)
        detectable = "" if math.isnan(plan.detectable) else f"{plan.detectable:.2f}"
        needed = ("" if math.isnan(plan.needed) else "more than "
                  f"{power.MOST_AGENTS}" if math.isinf(plan.needed) else f"{plan.needed:.0f}")
        lines.append(f"| {plan.task} | {plan.row} | {plan.mean:.2f} | {plan.sd:.3f} | {shares} | "
                     f"{detectable} | {needed} |")
    return "\n".join(lines)


def main(argv=None) -> None:
    """Print the plan of every task of the benchmark in `out_dir` on its plant."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out_dir", help="a finished benchmark's directory (docs/benchmark2)")
    parser.add_argument("--margin", type=float, default=MARGIN)
    parser.add_argument("--family", type=int, default=FAMILY)
    parser.add_argument("--agents", type=int, default=protocol.AGENTS,
                        help="agents per rival row")
    parser.add_argument("--light-agents", type=int, default=None,
                        help="agents of the light-weight row (default: --agents)")
    parser.add_argument("--plant", default="analytic")
    parser.add_argument("--variants", nargs="*", default=list(compute_plan.VARIANT_TASKS),
                        help="the base tasks of the third benchmark's variants")
    args = parser.parse_args(argv)
    try:
        power.check_margin(args.margin)
        power.level(0.05, args.family)
        light_agents = args.agents if args.light_agents is None else args.light_agents
        for task in args.variants:
            protocol.check_task(task, args.plant)
        if min(args.agents, light_agents) < 2:
            raise ValueError(f"--agents and --light-agents must be at least 2; got "
                             f"{args.agents} and {light_agents}")
        task_runs = {task: study.study_task(task, args.out_dir, args.plant)
                     for task in protocol.tasks_on(args.plant)}
        plans = [plan for runs in task_runs.values()
                 for plan in plan_task(runs, args.agents, args.margin, args.family,
                                       light_agents=light_agents)]
        rates = compute_plan.ledger_rates(args.out_dir)
        planned = compute_plan.plan(task_runs, rates, args.variants)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        raise SystemExit(2)
    print(table(plans, args.agents, args.margin, args.family, light_agents))
    print()
    print(compute_plan.rates_table(rates))
    print()
    print(compute_plan.plan_table(planned))


if __name__ == "__main__":
    main()
